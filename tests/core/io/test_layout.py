"""Log layouts: CSVs of other shapes (indices or header names, time column or rate, second effort
file, delimiters), their errors, and a small copy of the real TX40 log's shape."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from frictionid_core.drive import load_drive
from frictionid_core.errors import InputError
from frictionid_core.io import load
from frictionid_core.io.layout import Layout, load_layout, read_with_layout

J3 = ["a", "b", "c"]


def table(n: int = 50, ncols: int = 10, seed: int = 0) -> np.ndarray:
    """Columns: 0 time (s, 1 kHz with jitter), then random values."""
    rng = np.random.default_rng(seed)
    data = rng.standard_normal((n, ncols))
    data[:, 0] = np.arange(n) * 1e-3 + rng.uniform(0, 1e-5, n)
    return data


def write(path: Path, data: np.ndarray, delimiter: str = ",", names: list[str] | None = None) -> Path:
    header = delimiter.join(names) if names else ""
    np.savetxt(path, data, delimiter=delimiter, header=header, comments="", fmt="%.17g")
    return path


def write_layout(tmp_path: Path, text: str, name: str = "layout.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------------- layout forms
def test_no_header_indices_time_column_and_velocity(tmp_path):
    data = table()
    src = write(tmp_path / "log.csv", data)
    lay = write_layout(tmp_path, "header: false\ntime: {column: 0}\njoints: [a, b, c]\n"
                                 "position: [1, 2, 3]\nvelocity: [7, 8, 9]\neffort: [4, 5, 6]\n")
    s = load(src, layout=lay)
    assert s.joints == J3 and s.source == str(src)
    np.testing.assert_array_equal(s.t, data[:, 0])
    np.testing.assert_array_equal(s.position, data[:, 1:4])
    np.testing.assert_array_equal(s.effort, data[:, 4:7])
    np.testing.assert_array_equal(s.velocity, data[:, 7:10])
    assert s.notes == [f"read with layout {lay}"]


def test_header_names_time_in_ms_and_no_velocity(tmp_path):
    data = table()
    data[:, 0] = np.arange(len(data)) * 2.0  # ms
    names = ["stamp_ms", "q_a", "q_b", "q_c", "i_a", "i_b", "i_c", "x", "y", "z"]
    src = write(tmp_path / "log.csv", data, names=names)
    lay = write_layout(tmp_path, "header: true\ntime: {column: stamp_ms, scale: 0.001}\njoints: [a, b, c]\n"
                                 "position: [q_a, q_b, q_c]\neffort: [i_a, 5, i_c]\n")
    s = load(src, layout=lay)
    np.testing.assert_allclose(s.t, np.arange(len(data)) * 2e-3, rtol=1e-15, atol=0)
    np.testing.assert_array_equal(s.position, data[:, 1:4])
    np.testing.assert_array_equal(s.effort, data[:, 4:7])  # names and indices mixed
    assert s.velocity is None


def test_rate_hz_gives_evenly_spaced_times(tmp_path):
    data = table(n=40)
    src = write(tmp_path / "log.csv", data)
    lay = write_layout(tmp_path, "rate_hz: 250\njoints: [a]\nposition: [1]\neffort: [2]\n")
    s = load(src, layout=lay)
    np.testing.assert_allclose(s.t, np.arange(40) / 250.0, rtol=1e-15)
    np.testing.assert_array_equal(s.position[:, 0], data[:, 1])


def test_effort_file_beside_the_source(tmp_path):
    pos, eff = table(seed=1), table(seed=2)
    src = write(tmp_path / "pos.csv", pos, names=[f"c{k}" for k in range(10)])
    write(tmp_path / "eff.csv", eff, names=[f"c{k}" for k in range(10)])
    (tmp_path / "elsewhere").mkdir()
    lay = write_layout(tmp_path / "elsewhere", "header: true\ntime: {column: c0}\njoints: [a, b]\n"
                                               "position: [c1, c2]\neffort: [c3, c4]\neffort_file: eff.csv\n")
    s = load(src, layout=lay)
    np.testing.assert_array_equal(s.position, pos[:, 1:3])
    np.testing.assert_array_equal(s.effort, eff[:, 3:5])
    np.testing.assert_array_equal(s.t, pos[:, 0])
    assert f"efforts from {tmp_path / 'eff.csv'}" in s.notes


@pytest.mark.parametrize("delimiter, suffix", [(";", ".csv"), ("\t", ".tsv"), ("   ", ".txt"), (" ", ".dat")])
def test_detected_delimiters(tmp_path, delimiter, suffix):
    data = table(n=30)
    names = ["time", "p", "e"] + [f"x{k}" for k in range(7)]
    src = write(tmp_path / f"log{suffix}", data, delimiter=delimiter, names=names)
    lay = write_layout(tmp_path, "header: true\ntime: {column: time}\njoints: [a]\nposition: [p]\neffort: [e]\n")
    s = load(src, layout=lay)
    np.testing.assert_array_equal(s.position[:, 0], data[:, 1])
    np.testing.assert_array_equal(s.effort[:, 0], data[:, 2])


def test_delimiter_key_overrides_detection(tmp_path):
    # header names with spaces, whitespace-separated numbers: detection would take a tab if any
    (tmp_path / "log.txt").write_text("t\tq 1\ttau 1\n0 1.5 -2\n0.5  2.5  -3\n1.0 3.5 -4\n")
    lay = write_layout(tmp_path, "header: true\ndelimiter: tab\ntime: {column: t}\njoints: [a]\n"
                                 "position: ['q 1']\neffort: ['tau 1']\n")
    with pytest.raises(InputError) as e:
        load(tmp_path / "log.txt", layout=lay)
    assert "all 3 rows are broken, the first at line 2: 1 cell(s) where the header has 3" in str(e.value)
    (tmp_path / "log.txt").write_text("t\tq 1\ttau 1\n0\t1.5\t-2\n0.5\t2.5\t-3\n1.0\t3.5\t-4\n")
    s = load(tmp_path / "log.txt", layout=lay)
    np.testing.assert_array_equal(s.position[:, 0], [1.5, 2.5, 3.5])
    np.testing.assert_array_equal(s.effort[:, 0], [-2, -3, -4])


def test_layout_object_and_joint_selection(tmp_path):
    data = table()
    src = write(tmp_path / "log.csv", data)
    lay = Layout(joints=["a", "b", "c"], position=[1, 2, 3], effort=[4, 5, 6], time_column=0)
    s = load(src, layout=lay, joints=["c", "a"])
    assert s.joints == ["c", "a"]
    np.testing.assert_array_equal(s.position, data[:, [3, 1]])
    assert read_with_layout(src, lay).notes == ["read with layout layout"]


def test_load_layout_values_and_equality(tmp_path):
    text = "header: true\ntime: {column: T, scale: 1e-3}\njoints: [a]\nposition: [p]\neffort: [3]\ndelimiter: ';'\n"
    lay = load_layout(write_layout(tmp_path, text))
    assert lay == Layout(joints=("a",), position=("p",), effort=(3,), header=True, time_column="T",
                         time_scale=1e-3, delimiter=";")
    assert lay.rate_hz is None and lay.velocity is None and lay.source == str(tmp_path / "layout.yaml")


# --------------------------------------------------------------- the real TX40 shape
TX40_LAYOUT = """\
# pos_read_data.csv / curr_data.csv of the Stäubli TX40 (FIGAROH): 5 kHz, no time column
header: true
rate_hz: 5000
joints: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6]
position: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort_file: curr_data.csv
"""


def test_tx40_shaped_files_through_layout_and_drive(tmp_path):
    n = 600
    rng = np.random.default_rng(5)
    steps = rng.standard_normal((n, 6)) * 1e-3
    steps[0] = 0
    q_motor = np.cumsum(steps, axis=0) + [0, 50.265, -70.685, 0, 0, 0]  # first row as in the real file
    y = rng.standard_normal((n, 6)) * 0.1
    names = [f"Joint_{k}" for k in range(1, 7)]
    # same text form as the real files: mixed %g / E notation, header row, no time column
    for fname, arr in (("pos_read_data.csv", q_motor), ("curr_data.csv", y)):
        lines = [",".join(names)] + [",".join(f"{v:.5G}" for v in row) for row in arr]
        (tmp_path / fname).write_text("\n".join(lines) + "\n")
    lay = write_layout(tmp_path, TX40_LAYOUT)
    log = load(tmp_path / "pos_read_data.csv", layout=lay)
    assert log.joints == [f"joint_{k}" for k in range(1, 7)] and len(log) == n
    np.testing.assert_allclose(log.t[[0, 1, -1]], [0, 2e-4, (n - 1) * 2e-4], rtol=1e-12)
    np.testing.assert_allclose(log.position, q_motor, rtol=5e-5, atol=1e-9)  # 5 significant digits
    js = load_drive("tx40").to_joint_side(log)
    ye = log.effort
    np.testing.assert_allclose(js.effort[:, 4], 45 * ye[:, 4] + 32 * ye[:, 5], rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(js.position[:, 1], log.position[:, 1] / 32, rtol=1e-15)
    # 50.265 rad (5 digits, ±5e-4) on the motor is 32 · π/2 within 5e-4 / 32 = 1.6e-5 rad
    assert abs(js.position[0, 1] - np.pi / 2) < 1.6e-5


# ----------------------------------------------------------------------------- errors
HEAD = "header: true\n"
BODY = "joints: [a, b]\nposition: [p1, p2]\neffort: [e1, e2]\n"


def error_of(tmp_path, layout_text, csv_text="time,p1,p2,e1,e2\n0,1,2,3,4\n1,1,2,3,4\n2,1,2,3,4\n",
             source="log.csv", strict_rows: bool = False) -> str:
    (tmp_path / source).write_text(csv_text)
    lay = write_layout(tmp_path, layout_text)
    with pytest.raises(InputError) as e:
        load(tmp_path / source, layout=lay, strict_rows=strict_rows)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize("text, fragments", [
    (HEAD + BODY, ["exactly one of 'time'", "'rate_hz'"]),
    (HEAD + "rate_hz: 100\ntime: {column: time}\n" + BODY, ["exactly one of 'time'"]),
    (HEAD + "rate_hz: 100\njoints: [a, b]\nposition: [p1]\neffort: [e1, e2]\n",
     ["key 'position' has 1 columns for 2 joints"]),
    (HEAD + "rate_hz: 100\njoints: [a, b]\nposition: [p1, q2]\neffort: [e1, e2]\n",
     ["key 'position': column(s) ['q2'] not in the header of", "log.csv",
      "available: ['time', 'p1', 'p2', 'e1', 'e2']"]),
    (HEAD + "rate_hz: 100\njoints: [a, b]\nposition: [p1, p2]\neffort: [3, 5]\n",
     ["key 'effort': column index(es) [5] out of range", "has 5 columns (indices 0…4)"]),
    (HEAD + "rate_hz: 100\nvelocity_cols: [1, 2]\n" + BODY, ["unknown key(s) ['velocity_cols']", "known keys: header"]),
    (HEAD + "time: {column: time, unit: ms}\n" + BODY,
     ["key 'time': unknown key(s) ['unit']", "known keys: column, scale"]),
    (HEAD + "time: time\n" + BODY, ["key 'time' must be a mapping"]),
    (HEAD + "time: {column: time, scale: 0}\n" + BODY, ["key 'time: scale' must be a number > 0"]),
    (HEAD + "rate_hz: -5\n" + BODY, ["key 'rate_hz' must be a number > 0"]),
    ("header: false\nrate_hz: 100\n" + BODY, ["key 'position': column 'p1' is a name but 'header' is false"]),
    (HEAD + "rate_hz: 100\njoints: [a, b]\nposition: [1, -2]\neffort: [3, 4]\n",
     ["key 'position': column -2 is neither a 0-based index nor a header name"]),
    (HEAD + "rate_hz: 100\njoints: [a, b]\nposition: [p1, p2]\n", ["required key(s) ['effort'] missing"]),
    (HEAD + "rate_hz: 100\ndelimiter: '|'\n" + BODY, ["key 'delimiter' is '|'"]),
    ("header: yes please\nrate_hz: 100\n" + BODY, ["key 'header' must be true or false"]),
    (HEAD + "rate_hz: 100\neffort_file: missing.csv\n" + BODY, ["missing.csv: no such file (key 'effort_file' of"]),
])
def test_layout_errors_name_layout_file_and_key(tmp_path, text, fragments):
    msg = error_of(tmp_path, text)
    assert str(tmp_path / "layout.yaml") in msg or "missing.csv" in msg
    for f in fragments:
        assert f in msg


def test_effort_file_rows_must_match(tmp_path):
    (tmp_path / "eff.csv").write_text("time,p1,p2,e1,e2\n0,1,2,3,4\n1,1,2,3,4\n")
    msg = error_of(tmp_path, HEAD + "rate_hz: 100\neffort_file: eff.csv\n" + BODY)
    assert "eff.csv: 2 rows but" in msg and "log.csv has 3" in msg and "'effort_file'" in msg


def test_strict_rows_names_file_line_and_column_of_a_broken_row(tmp_path):
    msg = error_of(tmp_path, HEAD + "rate_hz: 100\n" + BODY,
                   csv_text="time;p1;p2;e1;e2\n0;1;2;3;4\n1;1;2;3;4\n2;1;2,5;3;4\n", strict_rows=True)
    assert msg.startswith(str(tmp_path / "log.csv"))
    assert "broken row at line 4: column 2 ('p2'): '2,5' is not a number" in msg and "--strict-rows" in msg
    msg = error_of(tmp_path, "rate_hz: 100\njoints: [a]\nposition: [0]\neffort: [1]\n",
                   csv_text="1 2\n3\n4 5\n", strict_rows=True)
    assert "broken row at line 2: 1 cell(s) where the rows have 2" in msg
    # without strict_rows the row is skipped: two rows are too few, and the error says why
    with pytest.warns(UserWarning, match="1 broken row"):
        msg = error_of(tmp_path, "rate_hz: 100\njoints: [a]\nposition: [0]\neffort: [1]\n", csv_text="1 2\n3\n4 5\n")
    assert "only 2 samples" in msg and "1 broken row(s) skipped" in msg and "line 2" in msg


def test_empty_file_and_a_binary_source(tmp_path):
    (tmp_path / "run.mcap").write_bytes(b"\x89MCAP0\r\n")
    msg = error_of(tmp_path, "rate_hz: 100\njoints: [a]\nposition: [0]\neffort: [1]\n", csv_text="",
                   source="x.csv")
    assert "no samples" in msg
    with pytest.raises(InputError, match="a layout applies to CSV"):
        load(tmp_path / "run.mcap", layout=tmp_path / "layout.yaml")
