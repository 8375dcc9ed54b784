"""Rows that are no samples, in every loader: broken rows (NaN/inf, values beyond any measurement,
stamps off the log's time line) skipped, repeated rows (recorded twice, same stamp other values,
stale: republished under a new stamp while the joints move) dropped, each kind with one warning
naming how many and where; what is a sample (a log at rest, a short piece after a pause, a clock
set back) kept; the time unit judged on the rows that are samples."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.io

from frictionid_core.errors import InputError
from frictionid_core.io import check_series, load, save_csv, write_joint_state_bag
from frictionid_core.io.rows import off_the_time_line
from frictionid_core.timeseries import JointSeries

LAYOUT = """header: false
time: {column: 0}
joints: [a, b]
position: [1, 2]
velocity: [3, 4]
effort: [5, 6]
"""


def arm(n: int = 3000, seed: int = 0, rate: float = 1000.0, t0: float = 0.0) -> JointSeries:
    """Two joints in motion (two sines each), noisy positions, velocities and efforts."""
    rng = np.random.default_rng(seed)
    t = t0 + np.arange(n) / rate
    w = 2 * np.pi * np.array([[0.7, 1.9], [0.5, 1.3]])
    q = np.column_stack([0.5 * np.sin(w[k, 0] * t) + 0.1 * np.sin(w[k, 1] * t + k) for k in range(2)])
    qd = np.column_stack([0.5 * w[k, 0] * np.cos(w[k, 0] * t) + 0.1 * w[k, 1] * np.cos(w[k, 1] * t + k)
                          for k in range(2)])
    e = 3 * qd + 2 * np.sign(qd)
    return JointSeries(t, ["a", "b"], q + 1e-5 * rng.standard_normal(q.shape), e + 0.05 * rng.standard_normal(e.shape),
                       qd + 1e-3 * rng.standard_normal(qd.shape), source="arm")


def checked(series: JointSeries, **kwargs) -> tuple[JointSeries, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = check_series(series, **kwargs)
    return out, [str(w.message) for w in caught]


def loaded(path, **kwargs) -> tuple[JointSeries, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = load(path, **kwargs)
    return out, [str(w.message) for w in caught if issubclass(w.category, UserWarning)]


def rows_of(s: JointSeries) -> np.ndarray:
    return np.column_stack([s.t, s.position[:, 0], s.position[:, 1], s.velocity[:, 0], s.velocity[:, 1],
                            s.effort[:, 0], s.effort[:, 1]])


def write_rows(path, rows: np.ndarray) -> None:
    path.write_text("\n".join(",".join(f"{v:.17g}" for v in row) for row in rows) + "\n")


# ------------------------------------------------------------------------ broken rows
def test_garbage_rows_at_the_top_are_skipped_and_the_time_unit_judged_on_the_rest(tmp_path):
    """The real UR10e log ur-20_02_19_15harm50secLoad.csv, in small: its first row is a sample, the next
    nine are garbage (stamps −0.12, 0.79, 0, 2.7e154, 47.6 s and zeros, values of 1e282) before the log
    at 3048 s; it was refused as "time stamps up to 2.68e+154 s are not seconds", a wrong diagnosis."""
    s = arm(t0=3048.059)
    good = rows_of(s)
    first = good[0].copy()
    first[0] = 3047.693  # a sample 0.37 s before the rest: in order, kept
    garbage = np.zeros((9, 7))
    garbage[:, 0] = [-0.1231, 0.7932, 0.0, 2.68e154, -0.0323, 47.5563, 0.0, 0.0, 0.0]
    garbage[0, 1:] = 253.0
    garbage[1, 1] = -1.125e282
    garbage[6, 4] = -1.38e290
    write_rows(tmp_path / "ur.csv", np.vstack([first, garbage, good]))
    (tmp_path / "layout.yaml").write_text(LAYOUT)
    out, warned = loaded(tmp_path / "ur.csv", layout=tmp_path / "layout.yaml")
    np.testing.assert_array_equal(out.t, np.concatenate([[3047.693], s.t]))
    np.testing.assert_array_equal(out.position[1:], s.position)
    assert warned == [f"{tmp_path / 'ur.csv'}: 9 broken row(s) skipped (garbage, not samples): 3 with a value NaN, "
                      "inf or beyond ±1e+15 (the first: line 3, field 'position', joint 'a': -1.125e+282); 6 with a "
                      "time stamp off the log's time line (out of order with the rows around it, or isolated from "
                      "them: the first: line 2, stamp -0.1231 s); at line 2, line 3, line 4 and 6 more"]
    with pytest.raises(InputError, match=r"ur.csv: broken row at line 2: its time stamp -0.1231 s is off the log's "
                                         r"time line; without --strict-rows broken rows are skipped with a warning"):
        load(tmp_path / "ur.csv", layout=tmp_path / "layout.yaml", strict_rows=True)


def test_stamps_in_another_unit_are_still_a_unit_problem():
    s = arm(300)
    s.t = s.t * 1e9 + 1.7e18  # ns since the epoch, read as s
    with pytest.raises(InputError, match=r"^arm: time stamps around 1.7e\+18 s are not seconds; a layout gives the "
                                         r"time's unit with 'time: \{column: …, scale: …\}' \(1e-9 for ns\)$"):
        check_series(s)


def test_a_stamp_from_another_epoch_at_either_end_is_skipped():
    s = arm(500, t0=1.7e9)
    t = s.t.copy()
    t[0], t[-1] = 0.0, 4.2e9  # a driver's first message stamped 0, a last one far in the future
    out, warned = checked(JointSeries(t, s.joints, s.position, s.effort, s.velocity, source="epoch"))
    np.testing.assert_array_equal(out.t, s.t[1:-1])
    assert len(warned) == 1 and warned[0].startswith("epoch: 2 broken row(s) skipped (garbage, not samples): 2 with a "
                                                     "time stamp off the log's time line")
    assert warned[0].endswith("the first: sample 0, stamp 0 s); at sample 0, sample 499")


def test_rows_with_nan_or_absurd_values_are_skipped_a_field_made_of_them_refused():
    s = arm(400)
    s.effort[[50, 60], 0] = 1.7976931348623157e308
    s.velocity[70, 1] = np.nan
    out, warned = checked(s)
    assert len(out) == 397 and np.isfinite(out.effort).all() and np.isfinite(out.velocity).all()
    assert warned == ["arm: 3 broken row(s) skipped (garbage, not samples): 3 with a value NaN, inf or beyond ±1e+15 "
                      "(the first: sample 50, field 'effort', joint 'a': 1.79769e+308); at sample 50, sample 60, "
                      "sample 70"]
    s.effort[100:350, 1] = np.inf
    with pytest.raises(InputError, match=r"^arm: 250 NaN/inf samples in field 'effort' \(joint 'b': 250 of 400, first "
                                         r"at t = 0.1 s\)$"):
        check_series(s)


def test_more_broken_rows_than_good_ones_refuse_the_log():
    s = arm(400)
    s.position[::2, 0] = np.inf
    s.effort[1::4, 1] = np.nan
    with pytest.raises(InputError, match=r"^arm: not a log: 300 of its 400 rows are broken \(300 with a value NaN"):
        check_series(s)


def test_what_is_on_the_time_line_stays():
    t = np.arange(100) * 0.01
    assert not off_the_time_line(t).any()
    # a short piece between two pauses, and a clock set back 2 s into the samples already recorded
    piece = np.concatenate([t, 5 + t[:4], 10 + t, 8 + t])
    assert not off_the_time_line(piece).any()
    # the same short piece out of order (before the log it sits in), isolated 60 s before its start
    out_of_order = off_the_time_line(np.concatenate([t, -3 + t[:4], 10 + t]))
    assert out_of_order.tolist() == [False] * 100 + [True] * 4 + [False] * 100
    assert off_the_time_line(np.concatenate([-60 + t[:3], t])).tolist() == [True] * 3 + [False] * 100


def test_a_wrong_stamp_whose_values_are_in_line_is_interpolated_not_dropped():
    s = arm(2000)
    t = s.t.copy()
    t[700] = 1e4
    out, warned = checked(JointSeries(t, s.joints, s.position, s.effort, s.velocity, source="glitch"))
    np.testing.assert_allclose(out.t, s.t, rtol=0, atol=1e-12)
    assert warned == ["glitch: 1 time stamp(s) out of line with both neighbours (first at sample 700) replaced by "
                      "interpolation between them"]


# ---------------------------------------------------------------------- repeated rows
def repeated(s: JointSeries) -> tuple[JointSeries, dict]:
    """``s`` with a copy of row 500 (same stamp and values), row 900 recorded twice with other values,
    and stale rows: 1300 and 1301 carry the values of 1299, 2000 those of 1999 (new stamps)."""
    idx = np.concatenate([np.arange(0, 501), [500], np.arange(501, 901), [900], np.arange(901, len(s))])
    out = s.take(idx)
    out.position, out.effort, out.velocity = out.position.copy(), out.effort.copy(), out.velocity.copy()
    out.effort[902] += 1.0  # the second row of stamp 0.9 s
    for k, src in ((1302, 1301), (1303, 1301), (2002, 2001)):  # rows of s 1300, 1301, 2000 ← 1299, 1299, 1999
        out.position[k], out.velocity[k], out.effort[k] = out.position[src], out.velocity[src], out.effort[src]
    return out, {"kept": np.setdiff1d(np.arange(len(s)), [1300, 1301, 2000])}


def test_copies_conflicts_and_stale_rows_are_dropped_with_one_warning():
    s = arm()
    raw, expect = repeated(s)
    out, warned = checked(raw)
    np.testing.assert_array_equal(out.t, s.t[expect["kept"]])
    np.testing.assert_array_equal(out.effort, s.effort[expect["kept"]])  # the first of stamp 0.9 s kept
    assert warned == ["arm: 5 repeated row(s) dropped: 1 with the time stamp and values of the row before (recorded "
                      "twice); 1 with the time stamp of the row before but other values (the first kept); 3 stale: "
                      "the values of the row before under a new time stamp while the joints move (a driver "
                      "republishing its last sample); at sample 501 (0.5 s), sample 902 (0.9 s), sample 1302 (1.3 s) "
                      "and 2 more from the start"]
    with pytest.raises(InputError, match=r"arm: time stamps not strictly increasing: 0 go backwards, 2 duplicated"):
        check_series(raw, strict_time=True)


@pytest.mark.parametrize("storage", ["csv", "layout", "bag", "mat"])
def test_every_loader_drops_repeated_rows_and_names_them(tmp_path, storage):
    s = arm()
    raw, expect = repeated(s)
    if storage == "csv":
        save_csv(raw, tmp_path / "log.csv")
        path, kwargs, where = tmp_path / "log.csv", {}, "line 503 (0.5 s), line 904 (0.9 s), line 1304 (1.3 s)"
    elif storage == "layout":
        write_rows(tmp_path / "log.csv", rows_of(raw))
        (tmp_path / "layout.yaml").write_text(LAYOUT)
        path, kwargs = tmp_path / "log.csv", {"layout": tmp_path / "layout.yaml"}
        where = "line 502 (0.5 s), line 903 (0.9 s), line 1303 (1.3 s)"
    elif storage == "bag":
        path, kwargs = write_joint_state_bag(tmp_path / "log", raw), {}
        where = "sample 501 (0.5 s), sample 902 (0.9 s), sample 1302 (1.3 s)"
    else:  # the EMPS MAT format: one joint, position qm, force gtau·vir, no velocity
        scipy.io.savemat(tmp_path / "log.mat", {"t": raw.t[:, None], "qm": raw.position[:, :1],
                                                "vir": raw.effort[:, :1] / 2.0, "gtau": np.array([[2.0]])})
        path, kwargs = tmp_path / "log.mat", {}
        where = "sample 501 (0.5 s), sample 902 (0.9 s), sample 1302 (1.3 s)"
    out, warned = loaded(path, **kwargs)
    note = [w for w in warned if "repeated row(s) dropped" in w]
    assert len(note) == 1 and f"; at {where} and 2 more from the start" in note[0]
    assert note[0].startswith(f"{path}{':/joint_states' if storage == 'bag' else ''}: 5 repeated row(s) dropped: 1 ")
    np.testing.assert_allclose(out.t, s.t[expect["kept"]], rtol=0, atol=1e-9)


def test_rows_repeated_at_rest_or_by_a_slow_quantised_joint_are_samples():
    """A noise-free or quantised log repeats itself where nothing moves, and where a joint creeps one
    encoder count every few samples: those rows are kept."""
    t = np.arange(4000) * 1e-3
    q = np.where(t < 1.0, np.sin(np.pi * t) ** 2, 0.0) + np.where(t > 3.0, np.sin(np.pi * (t - 3.0)) ** 2, 0.0)
    rest = JointSeries(t, ["a"], q, 5.0 * np.round(q, 2), source="rest")  # 2 s at rest, exactly
    out, warned = checked(rest)
    assert len(out) == len(rest) and warned == []
    creep = JointSeries(t, ["a"], np.floor(t * 300) * 1e-3, np.ones(t.size), source="creep")  # a count every 3.3 ms
    out, warned = checked(creep)
    assert len(out) == len(creep) and warned == []


def test_a_stale_row_of_a_noisy_log_is_dropped_however_slow_the_joint():
    """A driver republishes its last sample while the joint creeps out of a reversal at 1.6 % of its top
    speed (0.05 rad/s, 50 µrad per sample — 50 times its position noise): with noise on every channel a
    whole row never repeats by itself, so the row is stale and dropped (kept, it put a 50 µrad step
    back in time, whose second difference is 50 rad/s², into the acceleration)."""
    rng = np.random.default_rng(3)
    t = np.arange(3000) * 1e-3
    q = np.sin(np.pi * t) + 1e-6 * rng.standard_normal(t.size)  # top speed π rad/s; reversal at 0.5 s
    e = np.cos(np.pi * t) + 0.01 * rng.standard_normal(t.size)
    k = 516  # |q̇| = π·|cos(0.516 π)| = 0.05 rad/s
    q[k], e[k] = q[k - 1], e[k - 1]
    out, warned = checked(JointSeries(t, ["a"], q[:, None], e[:, None], source="slow"))
    np.testing.assert_array_equal(out.t, np.delete(t, k))
    assert warned == ["slow: 1 repeated row(s) dropped: 1 stale: the values of the row before under a new time stamp "
                      "while the joints move (a driver republishing its last sample); at sample 516 (0.516 s) from "
                      "the start"]
