"""Bad input: ONE clear line on stderr naming the problem, exit code 2 (via cli.main)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.io import load, open_reader, save_csv, write_joint_state_bag
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
    # garbage, the same every run (3000 random ones at a forced v5 header: all refused this way)
    (tmp_path / "g.mat").write_bytes(b"MATLAB 5.0 MAT-file" + np.random.default_rng(1).bytes(300))
    msg = fails(["identify", tmp_path / "g.mat"], capsys)
    assert "g.mat" in msg and "not a readable MAT file" in msg


def test_garbage_mcap(tmp_path, capsys):
    (tmp_path / "g.mcap").write_bytes(np.random.default_rng(2).bytes(500))
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
    msg = fails(["identify", tmp_path / "c.csv", "--strict-rows"], capsys)
    assert "c.csv: broken row at line 3: column 1 ('position'): 'two' is not a number" in msg
    msg = fails(["identify", tmp_path / "c.csv"], capsys)  # skipped: one row is left
    assert "only 1 samples" in msg and "1 broken row(s) skipped" in msg


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


def test_duplicated_joint_names_in_a_message(tmp_path, ros2_bag, js_msgs, capsys):
    t = np.arange(10) * 1e-3
    msgs = js_msgs(t, ["a", "b"], position=np.ones((10, 2)), effort=np.ones((10, 2)))
    ros2_bag(tmp_path / "later", {"/joint_states": (JOINT_STATE, [
        *msgs[:6], (msgs[6][0], {"name": ["a", "b", "a"], "position": [1.0] * 3, "effort": [1.0] * 3}), *msgs[7:]])})
    msg = fails(["identify", tmp_path / "later"], capsys)  # decoded message by message
    assert "topic '/joint_states': message 6 names joint(s) ['a'] more than once (['a', 'b', 'a'])" in msg
    same = [(ns, {**f, "name": ["a", "a"]}) for ns, f in msgs]
    ros2_bag(tmp_path / "all", {"/joint_states": (JOINT_STATE, same)})
    msg = fails(["identify", tmp_path / "all"], capsys)  # every message alike: decoded at once
    assert "message 0 names joint(s) ['a'] more than once" in msg


@pytest.mark.parametrize("at", [None, 3])  # every message (decoded at once), one message
def test_arrays_longer_than_the_names(tmp_path, ros2_bag, js_msgs, capsys, at):
    t = np.arange(10) * 1e-3
    msgs = js_msgs(t, ["a", "b"], position=np.ones((10, 2)), effort=np.ones((10, 2)))
    for k, (_, f) in enumerate(msgs):
        if at is None or k == at:
            f["effort"] = [1.0, 2.0, 3.0]
    ros2_bag(tmp_path / "b", {"/joint_states": (JOINT_STATE, msgs)})
    msg = fails(["identify", tmp_path / "b"], capsys)
    assert (f"topic '/joint_states': message {at or 0}: field 'effort' has 3 values for 2 names ['a', 'b']: which "
            "values belong to which joint is ambiguous") in msg


def test_a_corrupt_message_names_topic_index_and_time(tmp_path, capsys):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_KILTED)
    good = write_joint_state_bag(tmp_path / "good", small_series(30))
    reader = open_reader(good)
    try:
        raws = [(ns, raw) for _, ns, raw in reader.messages()]
    finally:
        reader.close()
    with Writer(tmp_path / "bad", version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/joint_states", JOINT_STATE, typestore=ts)
        for k, (ns, raw) in enumerate(raws):
            w.write(conn, ns, raw[:30] if k == 12 else raw)
    msg = fails(["identify", tmp_path / "bad"], capsys)
    assert ("topic '/joint_states': message 12 (bag time 0.012 s after the first) is not a readable "
            "sensor_msgs/msg/JointState (AnyReaderError:") in msg


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
def test_nan_rows_of_a_csv_are_skipped_naming_line_field_and_joint(tmp_path):
    s = small_series(50)
    s.position[[7, 30], 1] = np.nan
    save_csv(s, tmp_path / "n.csv")
    with pytest.warns(UserWarning) as caught:
        out = load(tmp_path / "n.csv")
    assert len(out) == 48 and not np.isnan(out.position).any()
    (note,) = [str(w.message) for w in caught]
    assert note == (f"{tmp_path / 'n.csv'}: 2 broken row(s) skipped (garbage, not samples): 2 with a value NaN, inf or "
                    "beyond ±1e+15 (the first: line 9, field 'position', joint 'b': nan); at line 9, line 32")


def test_a_column_mostly_nan_names_field_and_joint(tmp_path, capsys):
    s = small_series(50)
    s.position[5:40, 1] = np.nan
    save_csv(s, tmp_path / "n.csv")
    msg = fails(["identify", tmp_path / "n.csv"], capsys)
    assert "35 NaN/inf samples" in msg and "field 'position'" in msg and "joint 'b': 35 of 50" in msg
    assert "t = 0.005 s" in msg


def test_inf_effort_in_bag_skips_its_message_and_a_mostly_inf_one_names_field_and_joint(tmp_path, capsys):
    s = small_series(50)
    s.effort[12, 0] = np.inf
    bag = write_joint_state_bag(tmp_path / "b", s)
    with pytest.warns(UserWarning, match=r"1 broken row\(s\) skipped .*sample 12, field 'effort', joint 'a': inf"):
        assert len(load(bag)) == 49
    s.effort[10:40, 0] = np.inf
    bag = write_joint_state_bag(tmp_path / "c", s)
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


def test_three_rows_and_a_constant_signal(tmp_path, capsys):
    (tmp_path / "c.csv").write_text("time,position,effort\n0,1,1\n0.001,2,2\n0.002,3,1\n")
    for system in ("emps", "joint", "friction-only"):
        msg = fails(["identify", tmp_path / "c.csv", "--system", system], capsys)
        assert msg.startswith(f"{tmp_path / 'c.csv'}: 3 samples are too few for the order-4 Butterworth filter")
    t = np.arange(2000) * 1e-3
    save_csv(JointSeries(t, ["a"], np.ones_like(t), np.sin(t), source="c"), tmp_path / "k.csv")
    msg = fails(["identify", tmp_path / "k.csv", "--system", "joint"], capsys)
    assert "k.csv: no joint moves more than 100× its position noise" in msg


def test_values_of_1e308(tmp_path, capsys, synthetic):
    s = synthetic()
    s.position = s.position * 1e308
    save_csv(s, tmp_path / "h.csv")
    msg = fails(["identify", tmp_path / "h.csv"], capsys)
    assert "h.csv:" in msg and "samples beyond ±1e+15 (not measured values) in field 'position' (joint 'emps'" in msg


def test_cutoff_at_nyquist(tmp_path, capsys, synthetic):
    save_csv(synthetic(), tmp_path / "s.csv")
    msg = fails(["identify", tmp_path / "s.csv", "--system", "joint", "--cutoff", "500"], capsys)
    assert "s.csv: cut-off 500 Hz at or above the Nyquist frequency 500 Hz" in msg


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
    assert any("3 repeated row(s) dropped: 3 with the time stamp and values of the row before (recorded twice); at "
               "line 503 (0.5 s), line 1504 (1.5 s), line 2505 (2.5 s) from the start" in w for w in warn)
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
def test_ls_solver_on_a_law_the_data_do_not_show_says_so(tmp_path, capsys, synthetic):
    """Tustin fitted by ls (variable projection) to Coulomb data: it succeeds, and its Stribeck
    velocity, which these data cannot fix, is reported at its bound (at_bound), not as a value with a σ."""
    save_csv(synthetic(), tmp_path / "s.csv")
    capsys.readouterr()
    code = main([str(a) for a in ["identify", tmp_path / "s.csv", "--system", "emps", "--friction", "tustin",
                                  "--solver", "ls", "--json", tmp_path / "r.json"]])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "at a search bound: vs" in err and "not an identified value" in err
    result = json.loads((tmp_path / "r.json").read_text())
    assert "vs" in result["at_bound"] and result["params"]["vs"] > 0


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


# ------------------------------------------------------- outputs never replace an input
ARM_URDF = """<?xml version="1.0"?>
<robot name="arm2">
  <link name="base"/>
  <link name="upper">
    <inertial><origin xyz="0.2 0 0" rpy="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/></inertial>
  </link>
  <link name="fore">
    <inertial><origin xyz="0.15 0 0" rpy="0 0 0"/><mass value="1.0"/>
      <inertia ixx="0.005" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.5" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" velocity="3" effort="100"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="0.4 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" velocity="3" effort="100"/>
  </joint>
</robot>
"""
LAYOUT = ("header: true\ntime: {column: time}\njoints: [emps]\nposition: [emps.position]\n"
          "effort: [emps.effort]\n")


@pytest.fixture(scope="module")
def emps_result():
    """An identification result of noise-free EMPS-like data (JSON keys)."""
    from frictionid_core.identification import IdentifyRequest, identify
    from support.data import emps_like

    return identify(emps_like(), IdentifyRequest(system="emps")).to_dict()


@pytest.fixture
def inputs(tmp_path, emps_result, synthetic):
    """Every kind of file a command reads: log (CSV), bag, result, a second result, request,
    layout (+ its efforts file), drive, URDF (+ a result of it), truth, trajectory."""
    f = {"log": tmp_path / "log.csv", "result": tmp_path / "result.json", "other": tmp_path / "other.json",
         "request": tmp_path / "request.yaml", "layout": tmp_path / "layout.yaml", "drive": tmp_path / "drive.yaml",
         "urdf": tmp_path / "arm.urdf", "urdf_result": tmp_path / "arm_result.json", "truth": tmp_path / "truth.json",
         "trajectory": tmp_path / "traj.csv", "efforts": tmp_path / "efforts.csv",
         "effort_layout": tmp_path / "effort_layout.yaml"}
    save_csv(synthetic(), f["log"])
    f["bag"] = write_joint_state_bag(tmp_path / "bag", small_series())
    f["result"].write_text(json.dumps(emps_result))
    f["other"].write_text(json.dumps(emps_result))
    f["request"].write_text("system: emps\n")
    f["layout"].write_text(LAYOUT)
    f["effort_layout"].write_text(LAYOUT + "effort_file: efforts.csv\n")
    f["efforts"].write_text(f["log"].read_text())
    f["drive"].write_text("joints: [emps]\ngear_ratio: [2.0]\n")
    f["urdf"].write_text(ARM_URDF)
    f["urdf_result"].write_text(json.dumps(dict(emps_result, system=f"urdf:{f['urdf']}")))
    f["truth"].write_text(json.dumps({"bags": {}}))
    t = np.arange(200) * 0.01
    f["trajectory"].write_text("t,q:shoulder,q:elbow\n" + "".join(f"{x},{0.1 * np.sin(x)},{0.2 * np.sin(2 * x)}\n"
                                                                   for x in t))
    return f


# (command line, the output option, the input it would replace, that input's label) — {key} is a file of `inputs`
OVERWRITES = {
    "identify --json SOURCE": ("identify {log} --json {log}", "--json", "log", "SOURCE"),
    "identify --json a bag's file": ("identify {bag} --json {bag}/metadata.yaml", "--json", "bag", "SOURCE"),
    "identify --save-request SOURCE": ("identify {log} --save-request {log}", "--save-request", "log", "SOURCE"),
    "identify --json --request": ("identify {log} --request {request} --json {request}", "--json", "request",
                                  "--request"),
    "identify --json --layout": ("identify {log} --layout {layout} --json {layout}", "--json", "layout", "--layout"),
    "identify --json effort_file": ("identify {log} --layout {effort_layout} --json {efforts}", "--json", "efforts",
                                    "--layout's effort_file"),
    "identify --json --drive": ("identify {log} --drive {drive} --json {drive}", "--json", "drive", "--drive"),
    "identify --json URDF": ("identify {log} --system urdf:{urdf} --json {urdf}", "--json", "urdf", "--system"),
    "validate --json --params": ("validate {log} --params {result} --json {result}", "--json", "result", "--params"),
    "validate --json SOURCE": ("validate {log} --params {result} --json {log}", "--json", "log", "SOURCE"),
    "simulate --json --params": ("simulate emps --params {result} --data {log} --json {result}", "--json", "result",
                                 "--params"),
    "export --yaml RESULT": ("export {result} --yaml {result}", "--yaml", "result", "RESULT"),
    "export --urdf the robot's URDF": ("export {urdf_result} --urdf {urdf}", "--urdf", "urdf", "--system"),
    "consistency --json RESULT": ("consistency {result} --json {result}", "--json", "result", "RESULT"),
    "compare --json FIT": ("compare {result} {other} --json {other}", "--json", "other", "FIT.json"),
    "compare --json --truth": ("compare {result} --truth {truth} --json {truth}", "--json", "truth", "--truth"),
    "synth --out TRAJ": ("synth {trajectory} --system urdf:{urdf} --out {trajectory}", "--out", "trajectory", "TRAJ"),
    "excite --out URDF": ("excite --system urdf:{urdf} --out {urdf}", "--out", "urdf", "--system"),
}


def _argv(template: str, files: dict) -> list[str]:
    return template.format(**{k: str(v) for k, v in files.items()}).split()


def _bytes(path):
    return {p: p.read_bytes() for p in sorted(path.rglob("*"))} if path.is_dir() else path.read_bytes()


@pytest.mark.parametrize("case", OVERWRITES)
def test_an_output_never_replaces_an_input(inputs, capsys, case):
    template, option, key, label = OVERWRITES[case]
    before = _bytes(inputs[key])
    msg = fails(_argv(template, inputs), capsys)
    assert msg.startswith(f"{option} ") and f" is the input {label} " in msg and str(inputs[key]) in msg, msg
    assert "refusing to overwrite what this command reads" in msg
    assert _bytes(inputs[key]) == before


def test_links_to_an_input_are_that_input(inputs, capsys):
    (inputs["log"].parent / "soft.json").symlink_to(inputs["result"])
    (inputs["log"].parent / "hard.json").hardlink_to(inputs["result"])
    before = inputs["result"].read_bytes()
    for name in ("soft.json", "hard.json"):
        msg = fails(["validate", inputs["log"], "--params", inputs["result"], "--json", inputs["log"].parent / name],
                    capsys)
        assert f"is the input --params {inputs['result']}" in msg
    assert inputs["result"].read_bytes() == before


def test_two_outputs_one_file(inputs, tmp_path, capsys):
    msg = fails(["identify", inputs["log"], "--json", tmp_path / "x", "--save-request", tmp_path / "x"], capsys)
    assert msg == f"--save-request {tmp_path / 'x'} is also --json: give each output its own file"


def test_an_output_folder_that_is_a_file(inputs, capsys):
    before = inputs["result"].read_bytes()
    msg = fails(["report", inputs["result"], inputs["log"], "--out", inputs["result"]], capsys)
    assert msg == (f"--out {inputs['result']} is a file; expected a directory to write report.json, report.html "
                   "into")
    assert inputs["result"].read_bytes() == before
    folder = inputs["log"].parent / "reports"  # the result sits where the report would write its own JSON
    folder.mkdir()
    (folder / "report.json").write_bytes(before)
    msg = fails(["report", folder / "report.json", inputs["log"], "--out", folder], capsys)
    assert f"--out (report.json) {folder / 'report.json'} is the input RESULT.json" in msg
    assert (folder / "report.json").read_bytes() == before


# ----------------------------------------------------------------------- result files
NON_FINITE = [float("nan"), float("inf"), 1e300, -1e300]
# (key, value, words of the message after "key '<key>'")
BAD_KEYS = [
    *[("params.M", v, "must be a finite number within ±1e+15") for v in NON_FINITE],
    ("params.M", None, "must be a number, got null"),
    ("params.M", "abc", "must be a number, got 'abc'"),
    ("joint_map", ["a"], "must be a mapping of names"),
    ("preprocessing", "fast", "must be a mapping of names"),
    ("preprocessing.cutoff_hz", float("nan"), "must be a finite number"),
    ("preprocessing.order", None, "must be an integer >= 1"),
    ("window", 2.5, "must be a mapping of names"),
    ("metrics.per_joint.emps", None, "must be a mapping of metrics"),
    ("standard_parameters", {"emps": {"mass": 1.0}}, "lacks ['com', 'inertia', 'rotor', 'rotor_inertia']"),
    ("drive", {"joints": "emps"}, "key 'joints' must be a non-empty list of joint names"),
    ("friction", "magic", "unknown friction model 'magic'"),
    ("system", None, "must be given, got null"),
    ("source", 3, "must be a source name or a list of them"),
    ("warnings", "one", "must be a list of strings"),
]
RESULT_COMMANDS = {
    "validate": "validate {log} --params {result} --json {out}",
    "simulate": "simulate emps --params {result} --data {log} --json {out}",
    "report": "report {result} {log} --out {folder}",
    "export": "export {result} --yaml {out}",
    "consistency": "consistency {result} --json {out}",
    "compare": "compare {result} {other} --json {out}",
}


def _set(result: dict, dotted: str, value) -> dict:
    out = json.loads(json.dumps(result))
    *parents, last = dotted.split(".")
    node = out
    for key in parents:
        node = node.setdefault(key, {})
    node[last] = value
    return out


@pytest.mark.parametrize("command", RESULT_COMMANDS)
@pytest.mark.parametrize(("key", "value", "problem"), BAD_KEYS)
def test_a_bad_key_of_a_result_file_is_named(inputs, emps_result, capsys, command, key, value, problem):
    inputs["result"].write_text(json.dumps(_set(emps_result, key, value)))
    out = inputs["log"].parent / "out.json"
    out.write_text("old output")
    msg = fails(_argv(RESULT_COMMANDS[command], {**inputs, "out": out, "folder": out.parent / "report"}), capsys)
    assert msg.startswith(f"{inputs['result']}: key '{key}") and problem in msg, msg
    assert out.read_text() == "old output" and not (out.parent / "report").exists()


def test_a_bad_request_key_of_a_result_file_is_named(inputs, emps_result, capsys):
    inputs["result"].write_text(json.dumps(_set(emps_result, "request.joints", True)))
    msg = fails(["validate", inputs["log"], "--params", inputs["result"]], capsys)
    assert msg == f"{inputs['result']}: request key 'joints' must be a non-empty list of joint names, got True"


def test_a_result_file_that_is_not_an_object(inputs, capsys):
    inputs["result"].write_text("[1, 2]")
    msg = fails(["consistency", inputs["result"]], capsys)
    assert msg == f"{inputs['result']}: not an identification result (expected a JSON object)"


@pytest.mark.parametrize(("option", "text"), [("--params", "[" * 100_000 + "]" * 100_000),
                                              ("--params", '{"a":' * 100_000 + "1" + "}" * 100_000),
                                              ("--request", "[" * 100_000), ("--layout", "a:\n" + "  - " * 5_000),
                                              ("--drive", "{" * 100_000)])
def test_files_nested_too_deeply(inputs, capsys, option, text):
    path = inputs["log"].parent / ("deep.json" if option == "--params" else "deep.yaml")
    path.write_text(text)
    command = ["validate", inputs["log"], "--params", path] if option == "--params" else ["identify", inputs["log"],
                                                                                          option, path]
    msg = fails(command, capsys)
    assert msg.startswith(f"{path}: cannot read ") and msg.endswith("(its values are nested too deeply)")


# -------------------------------------------------------------- metrics that are no answer
def test_non_finite_metrics_are_an_error(inputs, synthetic, capsys):
    zero = synthetic()
    zero.effort = zero.effort * 0.0
    save_csv(zero, inputs["log"])
    out = inputs["log"].parent / "v.json"
    out.write_text("old output")
    msg = fails(["validate", inputs["log"], "--params", inputs["result"], "--json", out], capsys)
    assert msg == (f"the cross-test of {inputs['result']} on {inputs['log']} gives non-finite metrics (relerr_pct "
                   "inf): the effort is zero or the model overflows on these data")
    assert out.read_text() == "old output"
    msg = fails(["identify", inputs["log"], "--json", out], capsys)  # refused before any metric: no usable effort
    assert msg == (f"{inputs['log']}: no joint to fit with a usable effort (joints ['emps']; emps: effort within "
                   "0 … 0 while it moves, 100 % of its samples in motion read 0)")
    assert out.read_text() == "old output"


def test_validate_with_no_row_left(inputs, emps_result, capsys):
    inputs["result"].write_text(json.dumps(_set(emps_result, "preprocessing.min_speed", 50.0)))  # faster than any
    msg = fails(["validate", inputs["log"], "--params", inputs["result"]], capsys)
    assert msg.endswith("no sample left to cross-test on (every one slower than the min speed of the pre-processing, "
                        "or trimmed away); --cutoff and --min-speed set them")


def test_synth_friction_parameters_must_be_finite(inputs, capsys):
    path = inputs["log"].parent / "friction.json"
    path.write_text(json.dumps({"shoulder": {"Fv": float("nan"), "Fc": 2.0}, "elbow": {"Fv": 0.5, "Fc": 1.0}}))
    msg = fails(["synth", inputs["trajectory"], "--system", f"urdf:{inputs['urdf']}", "--friction", "coulomb",
                 "--friction-params", path, "--out", inputs["log"].parent / "out"], capsys)
    assert msg == f"{path}: friction parameter(s) shoulder.Fv = nan are not finite numbers"


# ------------------------------------------------------------------------ URDF inertials
# (text replaced in ARM_URDF, by what, the message's end); the C++ parser must print nothing (capfd).
BAD_URDFS = {
    "xacro mass": ('<mass value="1.0"/>', '<mass value="${m1}"/>',
                   "link 'fore': <mass value=\"${m1}\"> is not a finite number (a xacro expression: expand the file "
                   "with xacro first)"),
    "NaN mass": ('<mass value="1.0"/>', '<mass value="nan"/>', "link 'fore': <mass value=\"nan\"> is not a finite "
                                                                "number"),
    "negative mass": ('<mass value="1.0"/>', '<mass value="-1"/>', "link 'fore': negative mass -1 kg"),
    "zero mass": ('<mass value="1.0"/>', '<mass value="0"/>',
                  "link 'fore' (moved by joint 'elbow') has mass 0 kg; a moving link needs a positive mass (its "
                  "<inertial>)"),
    "NaN inertia": ('ixx="0.005"', 'ixx="nan"', "link 'fore': <inertia ixx=\"nan\"> is not a finite number"),
    "negative inertia": ('ixx="0.005"', 'ixx="-0.005"',
                         "link 'fore' (moved by joint 'elbow') has an inertia no rigid body has: principal moments "
                         "-0.005, 0.01, 0.01 kg·m² about its centre of mass (each must be ≥ 0 and at most the sum of "
                         "the other two)"),
    "xacro origin": ('<origin xyz="0.4 0 0" rpy="0 0 0"/>', '<origin xyz="0.4 0 0" rpy="0 0 ${pi/2}"/>',
                     "joint 'elbow': <origin rpy=\"0 0 ${pi/2}\"> is not 3 finite numbers (a xacro expression: expand "
                     "the file with xacro first)"),
}


def test_the_arm_urdf_loads(tmp_path):
    # Guards the cases below against failing for another reason.
    from frictionid_core.robots import load_urdf

    (tmp_path / "arm.urdf").write_text(ARM_URDF)
    robot = load_urdf(tmp_path / "arm.urdf")
    assert robot.joints == ["shoulder", "elbow"]
    np.testing.assert_allclose(robot.parameters()[:4], [2.0, 0.4, 0.0, 0.0])  # m, m·c of the upper arm


def test_an_inertia_breaking_the_triangle_inequalities_is_a_warning(tmp_path):
    # real CAD exports have them (the real TIAGo's arm_1_link, by 2 %): the data fit does not need them
    from frictionid_core.robots import load_urdf

    (tmp_path / "arm.urdf").write_text(ARM_URDF.replace('ixx="0.005"', 'ixx="0.5"', 1))
    robot = load_urdf(tmp_path / "arm.urdf")
    assert robot.inertia_warnings == (
        f"{tmp_path / 'arm.urdf'}: link 'fore' (moved by joint 'elbow') has an inertia no rigid body has: principal "
        "moments 0.01, 0.01, 0.5 kg·m² about its centre of mass (the largest exceeds the sum of the other two); "
        "--prior urdf does not pull that link toward it",)
    (tmp_path / "ok.urdf").write_text(ARM_URDF)
    assert load_urdf(tmp_path / "ok.urdf").inertia_warnings == ()


@pytest.mark.parametrize("case", BAD_URDFS)
def test_bad_urdf_inertials_name_the_link(tmp_path, capfd, case):
    old, new, problem = BAD_URDFS[case]
    assert old in ARM_URDF
    (tmp_path / "arm.urdf").write_text(ARM_URDF.replace(old, new, 1))
    msg = fails(["excite", "--system", f"urdf:{tmp_path / 'arm.urdf'}", "--out", tmp_path / "t.npz"], capfd)
    assert msg == f"{tmp_path / 'arm.urdf'}: {problem}"
