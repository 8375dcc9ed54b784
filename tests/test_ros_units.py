"""frictionid_ros building blocks without ROS: name mapping, ring buffer, results file, feed-forward."""

from __future__ import annotations

import array
import json
import threading
import time

import numpy as np
import pytest

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_ros import buffer
from frictionid_ros.buffer import JointRing, NameMap, put
from frictionid_ros.config import PARAMETERS, make_config
from frictionid_ros.feedforward import FeedForward
from frictionid_ros.store import JointParams, Results, read_results, split_identification, write_results


def test_name_map_reorders_and_caches():
    m = NameMap(["a", "b"])
    assert m.index(["a", "b"]) is None  # identity: copied as is
    idx = m.index(["x", "b", "a"])
    assert list(idx) == [2, 1]
    assert m.index(["x", "b", "a"]) is idx  # cached
    with pytest.raises(KeyError, match=r"lacks joint\(s\) \['b'\]"):
        m.index(["a"])
    row = np.empty(2)
    assert put(row, array.array("d", [9.0, 2.0, 1.0]), idx, 3) and list(row) == [1.0, 2.0]
    assert not put(row, array.array("d"), idx, 3) and np.isnan(row).all()  # empty field


def test_ring_keeps_the_newest_rows_in_order():
    r = JointRing(["a"], capacity=4)
    for k in range(6):
        i = r.begin()
        r.t_ns[i], r.position[i] = k, k
        r.commit()
    w = r.snapshot()
    assert list(w.t_ns) == [2, 3, 4, 5] and list(w.position[:, 0]) == [2, 3, 4, 5]
    assert r.total == 6 and r.count == 4
    r.clear()
    assert len(r.snapshot()) == 0


@pytest.mark.parametrize("head", [0, 1, 5, 9])
def test_ring_snapshot_copies_in_chunks_across_the_wrap(monkeypatch, head):
    monkeypatch.setattr(buffer, "SNAPSHOT_CHUNK_ROWS", 3)  # chunks that straddle the end of the ring
    r = JointRing(["a", "b"], capacity=10)
    for k in range(10 + head):
        i = r.begin()
        r.t_ns[i], r.rx_ns[i], r.position[i], r.velocity[i], r.effort[i], r.flags[i] = k, -k, k, 2 * k, 3 * k, k % 3
        r.commit()
    w = r.snapshot()
    expect = np.arange(head, 10 + head)
    assert list(w.t_ns) == list(expect) and list(w.rx_ns) == list(-expect) and list(w.flags) == list(expect % 3)
    assert (w.position == expect[:, None]).all() and (w.effort == 3 * expect[:, None]).all()


def test_ring_snapshot_never_blocks_the_writer_and_drops_overwritten_rows(monkeypatch):
    """A writer thread appends as fast as it can while snapshots are copied: every row of every
    snapshot is one whole sample, in order; rows the writer reached during a copy are left out,
    which can only happen because the writer got the lock while the copy ran."""
    monkeypatch.setattr(buffer, "SNAPSHOT_CHUNK_ROWS", 64)
    r = JointRing(["a", "b", "c"], capacity=5000)
    stop = threading.Event()

    def writer():
        k = 0
        while not stop.is_set():
            with r.lock:
                i = r.begin()
                r.t_ns[i], r.position[i], r.effort[i] = k, k, -k
                r.commit()
            k += 1

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    try:
        while r.count < r.capacity:
            time.sleep(0.001)
        short = 0
        for _ in range(200):
            w = r.snapshot()
            assert (w.position == w.t_ns[:, None]).all() and (w.effort == -w.t_ns[:, None]).all()
            assert (np.diff(w.t_ns) == 1).all()
            short += len(w) < r.capacity
    finally:
        stop.set()
        thread.join()
    assert short > 0  # the writer wrote during copies


def _ident(joints, params):
    return {"system": "friction-only", "friction": "coulomb", "asymmetric": False, "solver": "ls", "source": "x",
            "joints": joints, "params": params, "std": {k: 0.1 for k in params},
            "metrics": {"relerr_pct": 1.0, "r2": 0.99, "samples": 200}, "wall_s": 0.01}


def test_results_file_round_trip_and_plain_identify_json(tmp_path):
    d = _ident(["a", "b"], {"a/Fv": 1.0, "a/Fc": 0.5, "b/Fv": 2.0, "b/Fc": 0.25, "a/offset": 0.0, "b/offset": 0.1})
    per = split_identification(d, stamp_ns=7)
    assert per["b"].params == {"Fv": 2.0, "Fc": 0.25, "offset": 0.1} and per["a"].samples == 100
    path = write_results(tmp_path / "sub" / "p.json", Results(per, d, 1, 2, 300, 7))
    back = read_results(path)
    assert back.per_joint["b"].params == per["b"].params and back.window_samples == 300
    assert json.loads(path.read_text())["params"] == d["params"]  # Identification.to_dict() schema on top
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps(d))
    assert read_results(plain).per_joint["a"].params["Fc"] == 0.5
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_ident(["a"], {"Fv": 1.0})))
    with pytest.raises(FrictionIdError, match=r"\['Fc'\] missing"):
        read_results(bad)
    assert not list((tmp_path / "sub").glob("*.tmp"))  # atomic write leaves no temporary file


def test_feedforward_equals_the_core_model_per_joint():
    ff = FeedForward(["a", "b", "c", "d"], eps=0.02)
    params = {
        "a": JointParams("a", "x", "coulomb", False, "ls", {"Fv": 1.0, "Fc": 0.5}),
        "b": JointParams("b", "x", "tustin", True, "de", {"Fv_pos": 1, "Fc_pos": 0.4, "Fs_pos": 0.6, "vs_pos": 0.01,
                                                          "Fv_neg": 2, "Fc_neg": 0.3, "Fs_neg": 0.5, "vs_neg": 0.02}),
        "c": JointParams("c", "x", "coulomb", False, "ls", {"Fv": 3.0, "Fc": 0.1, "offset": 9.0}),
    }
    assert ff.set_params(params) == [] and ff.active == ("a", "b", "c")
    v = np.array([0.05, -0.01, -0.3, 1.0])
    got = ff.torque(v)
    for i, j in enumerate("abc"):
        model, theta = params[j].friction_vector()
        assert got[i] == pytest.approx(model.torque(np.array(theta), v[i : i + 1], eps=0.02)[0], rel=1e-14)
    assert got[3] == 0.0  # no parameters: no torque
    assert got[2] == pytest.approx(get_model("coulomb").torque([3.0, 0.1], [-0.3], eps=0.02)[0])  # no offset
    assert ff.torque(np.array([np.nan, 0.0, 0.0, 0.0]))[0] == 0.0  # unknown velocity: no torque


def test_config_validation():
    defaults = {k: v[0] for k, v in PARAMETERS.items()}
    assert make_config(defaults).capacity == 30001
    for change, needle in [({"system": "scara"}, "scara"), ({"solver": "x"}, "solver"),
                           ({"qos": "fast"}, "qos"), ({"buffer_seconds": 0.0}, "buffer_seconds"),
                           ({"joints": ["a", "a"]}, "duplicated"),
                           ({"realtime_priority": "fast"}, "realtime_priority' must be auto, off or a priority"),
                           ({"realtime_priority": 100}, "realtime_priority"),
                           ({"realtime_priority": 10.0}, "realtime_priority")]:
        with pytest.raises(FrictionIdError, match=needle):
            make_config({**defaults, **change})
    # realtime_priority: a string or an integer (YAML 20 or "20")
    for value, want in (("auto", "auto"), ("off", 0), (0, 0), (20, 20), ("20", 20)):
        assert make_config({**defaults, "realtime_priority": value}).realtime_priority == want
