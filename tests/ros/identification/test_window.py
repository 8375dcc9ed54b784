"""The data window of an identification: selection, effort alignment, gap check, limits."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

from frictionid_core.errors import InputError
from support.node_parts import (
    NS,
    PERIOD,
    T0,
    feed,
    make_inputs,
    motion,
    node_config,
    select_window,
    stamp_time,
)


def test_window_selection_by_span_and_stamp_range(tmp_path):
    cfg = node_config(tmp_path, min_samples=50)
    inputs = make_inputs(cfg)
    stamps, q, tau = feed(inputs)
    sel = select_window(cfg, inputs)  # the whole buffer, joints in the node's order
    s = sel.series
    assert len(s) == 1000 and s.joints == ["a", "b"] and sel.notes == [] and s.velocity is None
    assert (sel.start_ns, sel.end_ns) == (stamps[0], stamps[-1]) and s.t[0] == 0.0
    np.testing.assert_array_equal(s.position, q)
    np.testing.assert_array_equal(s.effort, tau)
    np.testing.assert_allclose(s.t, np.arange(1000) * 1e-3, rtol=0, atol=1e-12)
    sel = select_window(cfg, inputs, window_seconds=0.5, joints=["b"])  # stamps >= newest - 0.5 s
    assert len(sel.series) == 501 and sel.start_ns == stamps[499] and sel.series.joints == ["b"]
    np.testing.assert_array_equal(sel.series.position[:, 0], q[499:, 1])
    sel = select_window(cfg, inputs, window_start=stamp_time(int(stamps[100])), window_end=stamp_time(int(stamps[299])))
    assert (len(sel.series), sel.start_ns, sel.end_ns) == (200, stamps[100], stamps[299])
    with pytest.raises(InputError,
                       match=r"too little data: 11 joint-state samples in the last 0.01 s \(need at least 50\)"):
        select_window(cfg, inputs, window_seconds=0.01)


def test_window_refuses_empty_fields_and_nan(tmp_path):
    cfg = node_config(tmp_path)
    inputs = make_inputs(cfg)
    with pytest.raises(InputError, match=r"too little data: no joint states buffered on '/joint_states'"):
        select_window(cfg, inputs)
    feed(inputs, effort=False)
    with pytest.raises(InputError, match=r"empty effort: field 'effort' is empty or shorter than 'name' in 1000 of "
                                         r"1000 .*set the parameter 'effort_topic'"):
        select_window(cfg, inputs)
    inputs.clear()
    feed(inputs, n=300)
    m = JointState(name=["a", "b"], position=[np.nan, 0.0], effort=[0.0, 0.0])
    m.header.stamp = stamp_time(T0 + 300 * PERIOD)
    inputs.joint_state(m, 0)
    sel = select_window(cfg, inputs)  # a broken message is skipped and said, not the window refused
    assert len(sel.series) == 300 and any("1 broken row(s) skipped" in n and "field 'position', joint 'a': nan" in n
                                          for n in sel.notes)
    for k in range(301, 700):
        m = JointState(name=["a", "b"], position=[np.nan, 0.0], effort=[0.0, 0.0])
        m.header.stamp = stamp_time(T0 + k * PERIOD)
        inputs.joint_state(m, 0)
    with pytest.raises(InputError, match=r"400 NaN/inf samples in field 'position' \(joint 'a': 400 of 700"):
        select_window(cfg, inputs)


def test_window_gap_check(tmp_path):
    lost = set(range(100, 130)) | set(range(600, 620))  # 50 of 1000 in 2 gaps: 5 %
    for limit, refused in ((4.9, True), (5.0, False)):
        cfg = node_config(tmp_path, max_missing_pct=limit)
        inputs = make_inputs(cfg)
        feed(inputs, skip=lost)
        if refused:
            with pytest.raises(InputError, match=r"gaps in the stamps of the joint states in the last 30 s: about 50 "
                                                 r"of 1000 samples \(5.00 %\) lost or late \(2 gaps, longest 31.0 "
                                                 r"ms.*max_missing_pct = 4.9 %"):
                select_window(cfg, inputs)
        else:
            assert select_window(cfg, inputs).notes == [
                "joint states in the last 30 s: about 50 of 1000 samples (5.00 %) "
                "lost or late (2 gaps, longest 31.0 ms at a 1 ms period)"]


def test_window_effort_topic_by_stamp(tmp_path):
    """A JointState effort topic: interpolated at the joint-state stamps; joint states before its
    first message are dropped with a note."""
    cfg = node_config(tmp_path, effort_topic="effort", min_samples=100)
    inputs = make_inputs(cfg)
    stamps, q, _ = feed(inputs, effort=False)
    te = stamps[200:] + PERIOD // 2  # starts at joint state 201 (stamp + 0.5 ms), joints reversed
    for t_ns in te:
        m = JointState(name=["b", "a"], effort=[3.0 - 2e-9 * (t_ns - T0), 1e-9 * (t_ns - T0)])
        m.header.stamp = stamp_time(int(t_ns))
        inputs.effort(m, 0)
    sel = select_window(cfg, inputs)
    s = sel.series
    assert len(s) == 799 and sel.start_ns == stamps[201]
    assert sel.notes == ["201 joint-state samples outside the time range of effort topic '/effort' dropped"]
    x = 1e-9 * (stamps[201:] - T0)  # linear efforts are interpolated exactly
    np.testing.assert_allclose(s.effort, np.column_stack([x, 3.0 - 2 * x]), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(s.position, q[201:])
    with pytest.raises(InputError, match=r"too little data: effort topic '/effort' overlaps only 199 of 400 .*need at "
                                         r"least 200"):
        select_window(node_config(tmp_path, effort_topic="effort", min_samples=200), inputs,
                      window_start=stamp_time(int(stamps[0])), window_end=stamp_time(int(stamps[399])))


def test_window_unstamped_effort_by_receipt_time(tmp_path):
    """A Float64MultiArray effort topic has no stamp: paired with the joint states by receipt
    time, whatever the joint-state stamps (here a simulated clock at 1000 s)."""
    cfg = node_config(tmp_path, effort_topic="effort", effort_topic_type="float64_multi_array")
    inputs = make_inputs(cfg)
    _, q, _, tau = motion(500)
    rx = T0 + np.arange(500) * PERIOD + 50_000  # received 50 µs after the effort of the same sample
    for k in range(500):
        m = JointState(name=["a", "b"], position=q[k].tolist())
        m.header.stamp = stamp_time(1000 * NS + k * PERIOD)
        inputs.joint_state(m, int(rx[k]))
        inputs.effort(Float64MultiArray(data=tau[k].tolist()), int(rx[k]) - 50_000)
    sel = select_window(cfg, inputs)
    assert len(sel.series) == 499 and sel.start_ns == 1000 * NS  # the last one is after the last effort
    w = 0.95  # effort k + 0.05 (k+1): 50 µs of the 1 ms period toward the next sample
    np.testing.assert_allclose(sel.series.effort, w * tau[:499] + (1 - w) * tau[1:], rtol=0, atol=1e-12)
    inputs.effort(Float64MultiArray(data=[1.0]), 0)
    assert inputs.rejected == 1  # 1 value for 2 joints


def test_window_longer_than_the_limit_is_refused(tmp_path):
    cfg = node_config(tmp_path, max_window_seconds=0.5, min_samples=50)
    inputs = make_inputs(cfg)
    stamps, _, _ = feed(inputs)  # 1 s of data
    assert len(select_window(cfg, inputs).series) == 501  # the whole buffer: its newest 0.5 s
    with pytest.raises(InputError, match=r"window of 0.999 s in window_start..window_end is over the limit "
                                         r"max_window_seconds = 0.5 s"):
        select_window(cfg, inputs, window_start=stamp_time(int(stamps[0])))  # an open range
