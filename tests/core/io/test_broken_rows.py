"""Logs as the field writes them: broken rows of CSVs skipped (or refused with --strict-rows),
duplicated column names, absurd sizes refused early, reading in blocks with bounded memory."""

from __future__ import annotations

import tracemalloc
import warnings

import numpy as np
import pytest

from frictionid_core.errors import InputError
from frictionid_core.io import Layout, load, read_table, save_csv
from frictionid_core.io import csv as csvio
from frictionid_core.timeseries import JointSeries


def series(n: int = 300) -> JointSeries:
    rng = np.random.default_rng(3)
    t = np.arange(n) * 1e-3
    return JointSeries(t, ["a", "b"], rng.standard_normal((n, 2)), rng.standard_normal((n, 2)), source="mem")


def lines_of(s: JointSeries, tmp_path) -> list[str]:
    save_csv(s, tmp_path / "clean.csv")
    return (tmp_path / "clean.csv").read_text().splitlines()


def quietly(fn, *args, **kwargs):
    """``fn(...)`` and the UserWarnings it issued."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args, **kwargs)
    return out, [str(w.message) for w in caught if issubclass(w.category, UserWarning)]


def test_garbage_at_the_top_and_a_truncated_last_line_are_skipped(tmp_path):
    s = series()
    lines = lines_of(s, tmp_path)
    garbage = ["#### logger v2 ####", "date: today", "", "x,y", "1;2;3", "a,b,c,d,e", "nan", "-,-,-,-,-", "1,2"]
    text = "\n".join([lines[0], *garbage, *lines[1:], lines[-1][:7]])  # the last line cut, no newline
    (tmp_path / "log.csv").write_text(text)
    r, warned = quietly(load, tmp_path / "log.csv")
    # the rows are the clean ones, bit for bit
    np.testing.assert_array_equal(r.t, s.t)
    np.testing.assert_array_equal(r.position, s.position)
    np.testing.assert_array_equal(r.effort, s.effort)
    # 7 garbage rows (the blank line and the '#' line are no rows) + the truncated one; the first at line 3
    note = f"{tmp_path / 'log.csv'}: 8 broken row(s) skipped (malformed, not numeric or truncated); the first at line 3"
    assert r.notes[0].startswith(note) and warned[0] == r.notes[0]
    assert "date: today" not in r.notes[0] and "1 cell(s) where the header has 5" in r.notes[0]
    with pytest.raises(InputError, match=r"log.csv: broken row at line 3: 1 cell\(s\) where the header has 5 "
                                             r"\(delimiter ','\); without --strict-rows"):
        load(tmp_path / "log.csv", strict_rows=True)


def test_a_non_numeric_cell_in_the_middle_names_its_line_and_column(tmp_path):
    s = series()
    lines = lines_of(s, tmp_path)
    cells = lines[101].split(",")
    cells[3] = "1.2.3"
    lines[101] = ",".join(cells)
    lines[201] = lines[201].replace(",", ",,", 1)  # one cell too many
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    r, _ = quietly(load, tmp_path / "log.csv")
    keep = np.setdiff1d(np.arange(len(s)), [100, 200])
    np.testing.assert_array_equal(r.t, s.t[keep])
    np.testing.assert_array_equal(r.effort, s.effort[keep])
    assert "2 broken row(s) skipped" in r.notes[0] and "line 102: column 3 ('b.position'): '1.2.3' is not a number" \
        in r.notes[0]


def test_rows_read_across_blocks_keep_their_line_numbers(tmp_path, monkeypatch):
    monkeypatch.setattr(csvio, "BLOCK_BYTES", 97)  # blocks end inside lines
    s = series(120)
    lines = lines_of(s, tmp_path)
    lines.insert(60, "# a comment line")
    lines.insert(61, "")
    lines[90] = "broken"
    (tmp_path / "log.csv").write_text("\r\n".join(lines))  # Windows line ends, no final newline
    r, _ = quietly(load, tmp_path / "log.csv")
    keep = np.setdiff1d(np.arange(len(s)), [87])  # line 91 is data row 88 (two lines are no rows)
    np.testing.assert_array_equal(r.t, s.t[keep])
    np.testing.assert_array_equal(r.position, s.position[keep])
    assert "1 broken row(s) skipped" in r.notes[0] and "line 91:" in r.notes[0]


def test_headerless_layout_keeps_row_times_and_effort_file_rows_in_step(tmp_path):
    rng = np.random.default_rng(4)
    pos, eff = rng.standard_normal((50, 2)), rng.standard_normal((50, 2))
    pos_lines = [",".join(f"{v:.17g}" for v in row) for row in pos]
    eff_lines = [",".join(f"{v:.17g}" for v in row) for row in eff]
    pos_lines[10] = "1.0,oops"
    eff_lines[20] = "2.0"
    (tmp_path / "pos.csv").write_text("garbage line\n" + "\n".join(pos_lines) + "\n")
    (tmp_path / "eff.csv").write_text("more garbage\n" + "\n".join(eff_lines) + "\n")
    lay = Layout(joints=["a", "b"], position=[0, 1], effort=[0, 1], rate_hz=100.0, effort_file="eff.csv")
    r, warned = quietly(load, tmp_path / "pos.csv", layout=lay)
    keep = np.setdiff1d(np.arange(50), [10, 20])
    np.testing.assert_allclose(r.t, (keep + 1) / 100.0, rtol=1e-15)  # the garbage row is row 0 of each file
    np.testing.assert_array_equal(r.position, pos[keep])
    np.testing.assert_array_equal(r.effort, eff[keep])
    assert len(warned) == 2 and warned[0].startswith(f"{tmp_path / 'pos.csv'}: 2 broken row(s) skipped")
    assert warned[0].endswith("the first at line 1: 1 cell(s) where the rows have 2")
    assert any("2 row(s) broken in only one of" in note for note in r.notes)


def test_more_broken_rows_than_good_ones_refuse_the_file(tmp_path):
    (tmp_path / "log.csv").write_text("time,position,effort\n" + "0;1;2\n" * 5 + "0,1,2\n1,2,3\n2,3,4\n")
    with pytest.raises(InputError, match=r"log.csv: not a readable numeric CSV: 5 of the 8 rows read are broken, the "
                                         r"first at line 2: 1 cell\(s\) where the header has 3"):
        load(tmp_path / "log.csv")


def test_duplicated_column_names_are_refused(tmp_path):
    (tmp_path / "log.csv").write_text("time,a.position,a.effort,a.position\n0,1,2,3\n1,2,3,4\n2,3,4,5\n")
    with pytest.raises(InputError, match=r"log.csv: column name\(s\) \['a.position'\] appear more than once in the "
                                         r"header: which column is meant is ambiguous"):
        load(tmp_path / "log.csv")
    (tmp_path / "log.txt").write_text("t q q tau\n0 1 2 3\n1 2 3 4\n2 3 4 5\n")  # any header, any layout
    lay = Layout(joints=["a"], position=[1], effort=["tau"], time_column="t", header=True)
    with pytest.raises(InputError, match=r"log.txt: column name\(s\) \['q'\] appear more than once"):
        load(tmp_path / "log.txt", layout=lay)


def test_absurd_sizes_are_refused_early_with_the_numbers(tmp_path, monkeypatch):
    monkeypatch.setattr(csvio, "MAX_VALUES", 2_000)
    s = series(1000)
    save_csv(s, tmp_path / "log.csv")
    with pytest.raises(InputError, match=r"log.csv: about 1,000 rows \(estimated from its size\) × 5 columns used: "
                                         r"more than the 2,000 values"):
        load(tmp_path / "log.csv")
    monkeypatch.setattr(csvio, "MAX_VALUES", 4_600)  # the estimate within 1.1 × of it: refused while reading
    with pytest.raises(InputError, match=r"log.csv: more than [\d,]+ rows × 5 columns used: more than the 4,600 "
                                         r"values \(0.0 GB as float64\) frictionid reads from one log; cut it into "
                                         r"shorter logs$"):
        load(tmp_path / "log.csv")
    monkeypatch.setattr(csvio, "MAX_COLUMNS", 4)
    with pytest.raises(InputError, match=r"log.csv: 5 columns, more than the 4 a log may have"):
        load(tmp_path / "log.csv")


def test_an_overlong_line_is_refused_with_its_number(tmp_path, monkeypatch):
    monkeypatch.setattr(csvio, "BLOCK_BYTES", 1000)
    monkeypatch.setattr(csvio, "MAX_LINE_CHARS", 5000)
    (tmp_path / "log.csv").write_text("time,position,effort\n0,1,2\n1,2,3\n" + "9," * 10_000 + "\n2,3,4\n")
    with pytest.raises(InputError, match=r"log.csv: line 4 is longer than 5,000 characters: not a row of a log"):
        load(tmp_path / "log.csv")
    (tmp_path / "log.csv").write_text("time,position,effort\n0,1,2\n" + "9," * 10_000)  # the last line, no newline
    with pytest.raises(InputError, match=r"line 3 is longer"):
        load(tmp_path / "log.csv")


def test_memory_holds_only_the_columns_used(tmp_path, monkeypatch):
    """Peak traced memory of reading 2 of 12 columns of 100 000 rows stays within 3 × their float64
    size plus the blocks of text (set to 128 kB here): nothing holds every column or every line."""
    monkeypatch.setattr(csvio, "BLOCK_BYTES", 1 << 17)
    n = 100_000
    row = ",".join(["1.5"] * 12)
    (tmp_path / "wide.csv").write_text("".join(f"{k},{row}\n" for k in range(n)))
    used = n * 2 * 8
    tracemalloc.start()
    try:
        table = read_table(tmp_path / "wide.csv", header=False, columns=lambda names, ncols: [0, 5])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert table.data.shape == (n, 2) and table.data[-1, 0] == n - 1 and table.rows == n
    assert peak < 3 * used + 8 * (1 << 17), peak / used  # the text of a block takes a few times its bytes
