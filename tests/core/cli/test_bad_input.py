"""Bad input: ONE clear line on stderr naming the problem, exit code 2 (via cli.main)."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.io.bag import write_joint_state_bag
from frictionid_core.io.csv import save_csv
from frictionid_core.timeseries import JointSeries
from support.data import EMPS_ESTIMATION, JOINT_STATE

PREFIX = "frictionid: error: "


def fails(argv, capsys) -> str:
    """Run the CLI, expect exit 2 and exactly one stderr line, the error; return its message."""
    capsys.readouterr()
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{err}"
    assert lines[0].startswith(PREFIX), err
    return lines[0][len(PREFIX):]


def small_series(n: int = 20, joints=("a", "b")) -> JointSeries:
    t = np.arange(n) * 1e-3
    pos = np.column_stack([t * (k + 1) for k in range(len(joints))])
    return JointSeries(t, list(joints), pos, 10 * pos, source="mem")


@pytest.fixture
def small_bag(tmp_path):
    return write_joint_state_bag(tmp_path / "small", small_series())


# ------------------------------------------------------------------ files and formats
def test_missing_file(tmp_path, capsys):
    msg = fails(["identify", tmp_path / "nope.mcap"], capsys)
    assert "nope.mcap" in msg and "no such file" in msg


def test_unknown_format_suffix(tmp_path, capsys):
    (tmp_path / "data.xlsx").write_text("x")
    msg = fails(["identify", tmp_path / "data.xlsx"], capsys)
    assert "data.xlsx" in msg and "unknown format '.xlsx'" in msg and ".csv" in msg


def test_garbage_mat(tmp_path, capsys):
    (tmp_path / "g.mat").write_bytes(b"MATLAB 5.0 MAT-file" + os.urandom(300))
    msg = fails(["identify", tmp_path / "g.mat"], capsys)
    assert "g.mat" in msg and "not a readable MAT file" in msg


def test_garbage_mcap(tmp_path, capsys):
    (tmp_path / "g.mcap").write_bytes(os.urandom(500))
    msg = fails(["identify", tmp_path / "g.mcap"], capsys)
    assert "g.mcap" in msg and "not a readable bag" in msg


def test_rosbag2_dir_with_missing_metadata_key(small_bag, capsys):
    (small_bag / "metadata.yaml").write_text("something_else: 1\n")
    msg = fails(["identify", small_bag], capsys)
    assert str(small_bag) in msg and "not a readable bag" in msg


def test_rosbag2_dir_with_unparsable_metadata(small_bag, capsys):
    # A YAML syntax error: the parser's message spans several lines; the user must still
    # get one line.
    (small_bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [oops\n")
    msg = fails(["identify", small_bag], capsys)
    assert str(small_bag) in msg and "not a readable bag" in msg and "metadata.yaml" in msg


def test_rosbag2_dir_without_storage_file(small_bag, capsys):
    (small_bag / "small.mcap").unlink()
    msg = fails(["identify", small_bag], capsys)
    assert "not a readable bag" in msg


def test_csv_missing_effort_column(tmp_path, capsys):
    (tmp_path / "c.csv").write_text("time,arm.position\n0,1\n1,2\n2,3\n")
    msg = fails(["identify", tmp_path / "c.csv"], capsys)
    assert "c.csv" in msg and "'arm'" in msg and "'effort'" in msg


def test_csv_missing_time_column(tmp_path, capsys):
    (tmp_path / "c.csv").write_text("stamp,position,effort\n0,1,1\n1,2,2\n2,3,3\n")
    msg = fails(["identify", tmp_path / "c.csv"], capsys)
    assert "no 'time' column" in msg and "stamp" in msg


def test_csv_not_numeric(tmp_path, capsys):
    (tmp_path / "c.csv").write_text("time,position,effort\n0,1,1\n1,two,2\n")
    msg = fails(["identify", tmp_path / "c.csv"], capsys)
    assert "c.csv" in msg and "numeric CSV" in msg


def test_csv_header_only(tmp_path, capsys):
    # numpy.loadtxt warns "input contained no data" on an empty body; that warning must not
    # reach the user as a second, confusing line next to the error.
    (tmp_path / "c.csv").write_text("time,position,effort\n")
    msg = fails(["identify", tmp_path / "c.csv"], capsys)
    assert "no samples" in msg


# --------------------------------------------------------------------- topics, joints
def test_unknown_topic_lists_existing_topics(tmp_path, capsys):
    s = small_series()
    bag = write_joint_state_bag(tmp_path / "b", s, extra_topics={"/reference": ("position", s.position)})
    msg = fails(["identify", bag, "--topic", "/joint_state"], capsys)
    assert "'/joint_state'" in msg
    assert "/joint_states [sensor_msgs/msg/JointState]" in msg and "/reference" in msg


def test_unknown_topic_on_emps_bag(capsys):
    msg = fails(["identify", EMPS_ESTIMATION, "--topic", "/nope"], capsys)
    assert "'/nope'" in msg and "/joint_states" in msg and "/joint_reference" in msg


def test_unknown_effort_topic(small_bag, capsys):
    msg = fails(["identify", small_bag, "--effort-topic", "/effort"], capsys)
    assert "'/effort'" in msg and "/joint_states" in msg


def test_joint_not_present_lists_joints(small_bag, capsys):
    msg = fails(["identify", small_bag, "--joints", "a,wrist"], capsys)
    assert "wrist" in msg and "['a', 'b']" in msg


def test_joint_missing_from_a_later_message(tmp_path, ros2_bag, js_msgs, capsys):
    t = np.arange(10) * 1e-3
    msgs = js_msgs(t, ["a", "b"], position=np.ones((10, 2)), effort=np.ones((10, 2)))
    msgs[4] = (msgs[4][0], {"name": ["a"], "position": [1.0], "effort": [1.0]})
    ros2_bag(tmp_path / "b", {"/joint_states": (JOINT_STATE, msgs)})
    msg = fails(["identify", tmp_path / "b"], capsys)
    assert "message 4" in msg and "['b']" in msg


def test_emps_system_needs_one_joint(tmp_path, capsys, synthetic):
    s = synthetic()
    two = JointSeries(s.t, ["x", "y"], np.column_stack([s.position, s.position]),
                      np.column_stack([s.effort, s.effort]), source="two")
    save_csv(two, tmp_path / "two.csv")
    msg = fails(["identify", tmp_path / "two.csv", "--system", "emps"], capsys)
    assert "1 joint" in msg and "--joints" in msg


# ------------------------------------------------------------------ JointState fields
def test_empty_effort_arrays(tmp_path, ros2_bag, js_msgs, capsys):
    t = np.arange(10) * 1e-3
    ros2_bag(tmp_path / "b", {"/joint_states": (JOINT_STATE, js_msgs(t, ["a"], position=t[:, None]))})
    msg = fails(["identify", tmp_path / "b"], capsys)
    assert "'/joint_states'" in msg and "field 'effort' is empty" in msg and "10 of 10" in msg
    assert "--effort-topic" in msg


def test_short_position_arrays(tmp_path, ros2_bag, js_msgs, capsys):
    t = np.arange(10) * 1e-3
    msgs = js_msgs(t, ["a", "b"], position=np.ones((10, 2)), effort=np.ones((10, 2)))
    for k in (2, 3, 7):
        msgs[k][1]["position"] = np.array([1.0])  # one value for two names
    ros2_bag(tmp_path / "b", {"/joint_states": (JOINT_STATE, msgs)})
    msg = fails(["identify", tmp_path / "b"], capsys)
    assert "field 'position'" in msg and "shorter than 'name'" in msg and "3 of 10" in msg


def test_written_bag_with_empty_effort(tmp_path, capsys):
    # write_joint_state_bag with the effort carried only on another topic: /joint_states has
    # empty effort arrays.
    s = small_series()
    bag = write_joint_state_bag(tmp_path / "b", s, topic="/effort_only",
                                extra_topics={"/joint_states": ("position", s.position)})
    msg = fails(["identify", bag], capsys)
    assert "'/joint_states'" in msg and "'effort'" in msg


# ------------------------------------------------------------------- sample values
def test_nan_in_csv_names_field_and_joint(tmp_path, capsys):
    s = small_series(50)
    s.position[[7, 30], 1] = np.nan
    save_csv(s, tmp_path / "n.csv")
    msg = fails(["identify", tmp_path / "n.csv"], capsys)
    assert "2 NaN/inf samples" in msg and "field 'position'" in msg and "joint 'b'" in msg
    assert "t = 0.007 s" in msg


def test_inf_effort_in_bag_names_field_and_joint(tmp_path, capsys):
    s = small_series(50)
    s.effort[12, 0] = np.inf
    bag = write_joint_state_bag(tmp_path / "b", s)
    msg = fails(["identify", bag], capsys)
    assert "NaN/inf" in msg and "field 'effort'" in msg and "joint 'a'" in msg


def test_too_few_samples_for_the_filter(tmp_path, capsys, synthetic):
    save_csv(synthetic().slice(0, 10), tmp_path / "short.csv")
    msg = fails(["identify", tmp_path / "short.csv", "--system", "emps"], capsys)
    assert "10 samples are too few" in msg and "Butterworth" in msg


def test_too_few_samples_after_trimming(tmp_path, capsys, synthetic):
    save_csv(synthetic().slice(0, 40), tmp_path / "short.csv")
    msg = fails(["identify", tmp_path / "short.csv", "--system", "emps"], capsys)
    assert "40 samples" in msg and "trimming" in msg


def test_too_few_samples_for_the_decimation_filter(tmp_path, capsys, synthetic):
    # 49 samples trimmed at the start leave 21: too few for the order-8 anti-alias filter.
    save_csv(synthetic().slice(0, 70), tmp_path / "short.csv")
    msg = fails(["identify", tmp_path / "short.csv", "--system", "emps"], capsys)
    assert "21 samples are too few" in msg and "decimation by 10" in msg


def test_fewer_than_three_samples(tmp_path, capsys):
    (tmp_path / "c.csv").write_text("time,position,effort\n0,1,1\n1,2,2\n")
    msg = fails(["identify", tmp_path / "c.csv"], capsys)
    assert "only 2 samples" in msg


# -------------------------------------------------------------------- time stamps
def _disordered_csv(tmp_path, synthetic):
    """EMPS-like CSV with 3 duplicated stamps (rows repeated) and 2 swapped pairs."""
    s = synthetic()
    rows = list(range(len(s)))
    for k in (500, 1500, 2500):
        rows.insert(rows.index(k) + 1, k)  # sample k recorded twice
    for k in (800, 2000):
        i = rows.index(k)
        rows[i], rows[i + 1] = rows[i + 1], rows[i]  # out of order
    idx = np.array(rows)
    bad = JointSeries(s.t[idx], s.joints, s.position[idx], s.effort[idx], source="bad")
    save_csv(bad, tmp_path / "bad.csv")
    return tmp_path / "bad.csv"


def test_disordered_stamps_repaired_with_warning(tmp_path, capsys, synthetic):
    path = _disordered_csv(tmp_path, synthetic)
    capsys.readouterr()
    out_json = tmp_path / "r.json"
    code = main(["identify", str(path), "--system", "emps", "--json", str(out_json)])
    err = capsys.readouterr().err
    assert code == 0, err
    warn = [ln for ln in err.splitlines() if ln.startswith("frictionid: warning: ")]
    assert len(warn) == 2 and "error" not in err
    assert any("2 out-of-order time stamps" in w and "re-sorted" in w for w in warn)
    assert any("3 samples with duplicated time stamps dropped" in w for w in warn)
    # After the repair the data are the clean series: the parameters are recovered (the
    # noise-free synthetic data give ~0.3 % error; see test_emps_ls).
    p = json.loads(out_json.read_text())["params"]
    assert p["M"] == pytest.approx(95.0, rel=0.01)
    assert p["Fv"] == pytest.approx(200.0, rel=0.01)
    assert p["Fc"] == pytest.approx(20.0, rel=0.01)


def test_disordered_stamps_strict_time_is_an_error(tmp_path, capsys, synthetic):
    path = _disordered_csv(tmp_path, synthetic)
    msg = fails(["identify", path, "--system", "emps", "--strict-time"], capsys)
    assert "not strictly increasing" in msg and "2 go backwards" in msg and "3 duplicated" in msg


def test_duplicated_stamps_in_bag_strict(tmp_path, capsys):
    s = small_series(20)
    s.t[5] = s.t[4]
    bag = write_joint_state_bag(tmp_path / "b", s)
    msg = fails(["identify", bag, "--strict-time"], capsys)
    assert "0 go backwards, 1 duplicated" in msg


# ------------------------------------------------------------------------- solver
def test_ls_solver_with_nonlinear_friction(tmp_path, capsys, synthetic):
    save_csv(synthetic(), tmp_path / "s.csv")
    msg = fails(["identify", tmp_path / "s.csv", "--system", "emps", "--friction", "tustin", "--solver", "ls"],
                capsys)
    assert "solver 'ls'" in msg and "tustin" in msg and "'vs'" in msg
    assert "use lm" in msg  # points to another solver


def test_validate_with_unreadable_params(tmp_path, capsys, synthetic):
    save_csv(synthetic(), tmp_path / "s.csv")
    (tmp_path / "p.json").write_text("{not json")
    msg = fails(["validate", tmp_path / "s.csv", "--params", tmp_path / "p.json"], capsys)
    assert "p.json" in msg and "cannot read an identification result" in msg


def test_validate_with_params_lacking_a_key(tmp_path, capsys, synthetic):
    save_csv(synthetic(), tmp_path / "s.csv")
    (tmp_path / "p.json").write_text(json.dumps({"system": "emps", "friction": "coulomb", "asymmetric": False,
                                                 "params": {"M": 1.0, "Fv": 1.0, "Fc": 1.0}}))
    msg = fails(["validate", tmp_path / "s.csv", "--params", tmp_path / "p.json"], capsys)
    assert "'offset'" in msg and "frictionid identify" in msg


def test_unknown_system(tmp_path, capsys, synthetic):
    save_csv(synthetic(), tmp_path / "s.csv")
    msg = fails(["identify", tmp_path / "s.csv", "--system", "scara"], capsys)
    assert "unknown system 'scara'" in msg and "emps" in msg


def test_joint_map_on_a_system_without_one(tmp_path, capsys, synthetic):
    save_csv(synthetic(), tmp_path / "s.csv")
    msg = fails(["identify", tmp_path / "s.csv", "--system", "emps", "--joint-map", "a=b"], capsys)
    assert "system 'emps' takes no joint map" in msg
    msg = fails(["identify", tmp_path / "s.csv", "--system", "tx40", "--joint-map", "a:b"], capsys)
    assert "--joint-map item 'a:b'" in msg


def test_small_bag_is_readable_before_corruption(small_bag):
    # Guards the corrupt-bag tests above against passing for an unrelated reason.
    from frictionid_core.io import load

    assert load(small_bag).joints == ["a", "b"]
