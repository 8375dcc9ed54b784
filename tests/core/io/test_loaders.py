"""Loaders: CSV, MAT, rosbag2 (MCAP, sqlite3), ROS 1 bags and the bundled EMPS bags."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from frictionid_core.errors import InputError
from frictionid_core.io import list_topics, load, write_joint_state_bag
from frictionid_core.io.csv import load_csv, save_csv
from frictionid_core.timeseries import JointSeries
from support.data import EMPS_ESTIMATION, EMPS_VALIDATION, FLOAT_ARRAY, JOINT_STATE, T0_NS


def two_joint_series(n: int = 40, velocity: bool = True) -> JointSeries:
    rng = np.random.default_rng(1)
    t = np.arange(n) * 1e-3
    pos = rng.standard_normal((n, 2))
    eff = rng.standard_normal((n, 2)) * 1e3
    vel = rng.standard_normal((n, 2)) if velocity else None
    return JointSeries(t, ["shoulder", "elbow"], pos, eff, vel, source="mem")


def assert_same_samples(a: JointSeries, b: JointSeries, t_tol: float = 1e-9) -> None:
    assert a.joints == b.joints
    # Stamps go through integer nanoseconds in a bag: equal within 1 ns.
    np.testing.assert_allclose(a.t, b.t, rtol=0, atol=t_tol)
    np.testing.assert_array_equal(a.position, b.position)
    np.testing.assert_array_equal(a.effort, b.effort)


# ------------------------------------------------------------------------------- CSV
def test_csv_round_trip_is_exact(tmp_path):
    s = two_joint_series()
    save_csv(s, tmp_path / "s.csv")
    r = load_csv(tmp_path / "s.csv")
    assert r.joints == ["shoulder", "elbow"]
    # %.17g round-trips doubles exactly.
    np.testing.assert_array_equal(r.t, s.t)
    np.testing.assert_array_equal(r.position, s.position)
    np.testing.assert_array_equal(r.effort, s.effort)
    np.testing.assert_array_equal(r.velocity, s.velocity)


def test_csv_round_trip_without_velocity_and_via_load(tmp_path):
    s = two_joint_series(velocity=False)
    save_csv(s, tmp_path / "s.csv")
    header = (tmp_path / "s.csv").read_text().splitlines()[0]
    assert header == "time,shoulder.position,shoulder.effort,elbow.position,elbow.effort"
    r = load(tmp_path / "s.csv")
    assert r.velocity is None
    assert_same_samples(r, s, t_tol=0)


def test_csv_bare_single_joint_columns(tmp_path):
    (tmp_path / "j.csv").write_text("t,position,effort\n0,1,10\n0.001,2,20\n0.002,3,30\n")
    r = load(tmp_path / "j.csv")
    assert r.joints == ["joint"]
    np.testing.assert_array_equal(r.position[:, 0], [1, 2, 3])
    np.testing.assert_array_equal(r.effort[:, 0], [10, 20, 30])


def test_csv_joint_selection_and_reordering(tmp_path):
    s = two_joint_series()
    save_csv(s, tmp_path / "s.csv")
    r = load(tmp_path / "s.csv", joints=["elbow", "shoulder"])
    assert r.joints == ["elbow", "shoulder"]
    np.testing.assert_array_equal(r.position, s.position[:, ::-1])
    np.testing.assert_array_equal(r.effort, s.effort[:, ::-1])
    np.testing.assert_array_equal(r.velocity, s.velocity[:, ::-1])
    only = load(tmp_path / "s.csv", joints=["elbow"])
    assert only.joints == ["elbow"] and only.position.shape == (len(s), 1)


# ------------------------------------------------------------------------------- MAT
def test_mat_loader_reads_emps_variables(tmp_path):
    n = 20
    t = np.arange(n) * 1e-3
    qm, vir, qg = np.sin(t), np.cos(t), np.sin(t) + 0.1
    scipy.io.savemat(tmp_path / "d.mat", {"t": t[:, None], "qm": qm[:, None], "vir": vir[:, None],
                                          "qg": qg[:, None], "gtau": np.array([[35.0]]),
                                          "kp": np.array([[160.18]]), "kv": np.array([[243.45]])})
    s = load(tmp_path / "d.mat")
    assert s.joints == ["emps"]
    np.testing.assert_array_equal(s.position[:, 0], qm)
    np.testing.assert_allclose(s.effort[:, 0], 35.0 * vir, rtol=1e-15)
    np.testing.assert_array_equal(s.extras["qg"], qg)
    assert s.meta == {"gtau": 35.0, "kp": 160.18, "kv": 243.45}


def test_mat_missing_variable_is_named(tmp_path):
    scipy.io.savemat(tmp_path / "d.mat", {"t": np.arange(5.0), "qm": np.arange(5.0)})
    with pytest.raises(InputError, match=r"\['vir', 'gtau'\] missing.*\['qm', 't'\]"):
        load(tmp_path / "d.mat")


# --------------------------------------------------------------------------- rosbag2
def test_mcap_round_trip_with_meta_and_two_joints(tmp_path):
    s = two_joint_series()
    s.meta["gtau"] = 35.15065188248547
    write_joint_state_bag(tmp_path / "b", s)
    r = load(tmp_path / "b")
    assert_same_samples(r, s)
    np.testing.assert_array_equal(r.velocity, s.velocity)
    assert r.meta == {"gtau": 35.15065188248547}
    assert r.source.endswith(":/joint_states")


def test_sqlite3_bag(tmp_path):
    s = two_joint_series(velocity=False)
    write_joint_state_bag(tmp_path / "b", s, storage="sqlite3", topic="/arm/joint_states")
    assert (tmp_path / "b" / "b.db3").exists()
    assert list_topics(tmp_path / "b") == {"/arm/joint_states": JOINT_STATE}
    # The only JointState topic is used by default even if it is not /joint_states.
    r = load(tmp_path / "b")
    assert_same_samples(r, s)
    assert r.velocity is None  # empty velocity arrays: no recorded velocity


def test_ros1_bag(tmp_path):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    JS = ts.types[JOINT_STATE]
    Header, Time = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    s = two_joint_series(n=30)
    with Writer(tmp_path / "r.bag") as w:
        conn = w.add_connection("/joint_states", JOINT_STATE, typestore=ts)
        for k, tk in enumerate(s.t):
            ns = T0_NS + int(round(tk * 1e9))
            msg = JS(header=Header(seq=k, stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="base"),
                     name=list(s.joints), position=s.position[k].copy(), velocity=s.velocity[k].copy(),
                     effort=s.effort[k].copy())
            w.write(conn, ns, ts.serialize_ros1(msg, JOINT_STATE))
    r = load(tmp_path / "r.bag")
    assert_same_samples(r, s)
    np.testing.assert_array_equal(r.velocity, s.velocity)
    assert r.meta == {}


def test_name_order_changing_between_messages(tmp_path, ros2_bag, js_msgs):
    n = 12
    t = np.arange(n) * 1e-3
    a, b = 1.0 + t, -5.0 - t
    msgs = []
    for k, (ns, _) in enumerate(js_msgs(t, ["a", "b"])):
        if k % 2:  # odd messages list the joints the other way round
            msgs.append((ns, {"name": ["b", "a"], "position": [b[k], a[k]], "effort": [10 * b[k], 10 * a[k]]}))
        else:
            msgs.append((ns, {"name": ["a", "b"], "position": [a[k], b[k]], "effort": [10 * a[k], 10 * b[k]]}))
    ros2_bag(tmp_path / "b", {"/joint_states": (JOINT_STATE, msgs)})
    r = load(tmp_path / "b")
    assert r.joints == ["a", "b"]  # order of the first message
    np.testing.assert_array_equal(r.position, np.column_stack([a, b]))
    np.testing.assert_array_equal(r.effort, 10 * np.column_stack([a, b]))
    r = load(tmp_path / "b", joints=["b"])
    np.testing.assert_array_equal(r.position[:, 0], b)


def test_header_stamp_zero_uses_bag_time(tmp_path, ros2_bag, js_msgs):
    t = np.arange(10) * 2e-3
    msgs = js_msgs(t, ["j"], position=t[:, None], effort=t[:, None])
    for _, f in msgs:
        f["stamp_ns"] = 0
    ros2_bag(tmp_path / "b", {"/joint_states": (JOINT_STATE, msgs)})
    r = load(tmp_path / "b")
    np.testing.assert_allclose(r.t, t, rtol=0, atol=1e-9)


def test_header_stamp_preferred_over_bag_time(tmp_path, ros2_bag, js_msgs):
    t = np.arange(10) * 2e-3
    msgs = js_msgs(t, ["j"], position=t[:, None], effort=t[:, None])
    for k, (_, f) in enumerate(msgs):  # header stamps on a 1 ms grid, bag times on 2 ms
        f["stamp_ns"] = T0_NS + k * 1_000_000
    ros2_bag(tmp_path / "b", {"/joint_states": (JOINT_STATE, msgs)})
    np.testing.assert_allclose(load(tmp_path / "b").t, t / 2, rtol=0, atol=1e-9)


def test_separate_joint_state_effort_topic(tmp_path, ros2_bag, js_msgs):
    n = 30
    t = np.arange(n) * 1e-3
    pos = np.column_stack([t, -t])
    eff = np.column_stack([3.0 + t, 7.0 - 2 * t])
    # Effort topic: joints in the other order, stamps half a period later, one sample more.
    te = np.arange(n + 1) * 1e-3 - 0.5e-3
    eff_rev = np.column_stack([7.0 - 2 * te, 3.0 + te])
    ros2_bag(tmp_path / "b", {
        "/joint_states": (JOINT_STATE, js_msgs(t, ["a", "b"], position=pos)),  # no effort
        "/effort": (JOINT_STATE, js_msgs(te, ["b", "a"], effort=eff_rev)),
    })
    r = load(tmp_path / "b", effort_topic="/effort")
    assert r.joints == ["a", "b"] and len(r) == n
    # Linear efforts are interpolated exactly.
    np.testing.assert_allclose(r.effort, eff, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.position, pos)


def test_separate_float64_multiarray_effort_topic(tmp_path, ros2_bag, js_msgs):
    n = 30
    t = np.arange(n) * 1e-3
    pos = np.column_stack([t, -t])
    # Float64MultiArray has no header: its bag time is used. It starts 5 samples late, so the
    # first 5 joint states are outside its time range and dropped (with a note).
    te = t[5:]
    eff = np.column_stack([3.0 + te, 7.0 - 2 * te])
    farr = [(T0_NS + int(round(x * 1e9)), {"data": row}) for x, row in zip(te, eff)]
    ros2_bag(tmp_path / "b", {
        "/joint_states": (JOINT_STATE, js_msgs(t, ["a", "b"], position=pos)),
        "/effort": (FLOAT_ARRAY, farr),
    })
    r = load(tmp_path / "b", effort_topic="/effort")
    assert len(r) == n - 5
    np.testing.assert_allclose(r.t, te, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.effort, eff, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.position, pos[5:])
    assert any("5 joint-state samples" in note for note in r.notes)


def test_explicit_topic_among_several(tmp_path):
    s = two_joint_series(n=10, velocity=False)
    write_joint_state_bag(tmp_path / "b", s, topic="/left", extra_topics={"/right": ("position", 2 * s.position)})
    with pytest.raises(InputError, match="several"):
        load(tmp_path / "b")
    # /right carries position only: it needs an effort topic.
    r = load(tmp_path / "b", topic="/right", effort_topic="/left")
    np.testing.assert_array_equal(r.position, 2 * s.position)
    np.testing.assert_allclose(r.effort, s.effort, rtol=1e-15)


def test_bare_mcap_file_is_readable(tmp_path):
    s = two_joint_series(n=10)
    write_joint_state_bag(tmp_path / "b", s)
    assert_same_samples(load(tmp_path / "b" / "b.mcap"), s)


# ---------------------------------------------------------------- bundled EMPS bags
def test_emps_estimation_bag_facts(emps_estimation):
    s = emps_estimation
    assert s.joints == ["emps"] and len(s) == 24841
    assert s.t[0] == 0.0
    # 1 kHz: mean period 1 ms and no stamp far from it (no resampling would be triggered).
    assert s.dt == pytest.approx(1e-3, abs=1e-12)
    assert np.max(np.abs(np.diff(s.t) - 1e-3)) < 1e-6
    tec = s.meta.pop("tec")  # t(10) − t(9) of the MAT file: the benchmark clock period
    assert tec == pytest.approx(0.999983961e-3, abs=1e-12)
    assert s.meta == {"gtau": 35.15065188248547, "kp": 160.18, "kv": 243.45}
    assert s.velocity is None and s.notes == []
    assert s.source == f"{EMPS_ESTIMATION}:/joint_states"
    # Positions in m (the carriage travels ~0.25 m from about 0), forces in N (|F| ~ 150).
    assert -1e-4 < s.position.min() < 1e-4 and 0.2 < s.position.max() < 0.3
    assert 100.0 < np.abs(s.effort).max() < 200.0
    # The first sample is the MAT file's qm(1) bit for bit; force = gtau·vir(1).
    assert s.position[0, 0] == 7.45e-06
    assert s.effort[0, 0] == pytest.approx(89.23443221, abs=1e-8)


def test_emps_bag_topics():
    est = list_topics(EMPS_ESTIMATION)
    val = list_topics(EMPS_VALIDATION)
    assert est == {"/joint_states": JOINT_STATE, "/joint_reference": JOINT_STATE}
    assert val == {**est, "/drive_pulses": JOINT_STATE}


def test_emps_validation_bag_facts(emps_validation, emps_estimation):
    s = emps_validation
    assert s.joints == ["emps"] and len(s) == 24841
    assert s.dt == pytest.approx(1e-3, abs=1e-12)
    assert s.meta["gtau"] == 35.15065188248547
    assert not np.array_equal(s.effort, emps_estimation.effort)  # a different run

