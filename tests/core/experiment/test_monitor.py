"""What stops a running experiment (frictionid_core.experiment.monitor) and the judgement of its
recording (frictionid_core.experiment.judgement)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from frictionid_core import InputError
from frictionid_core.experiment import Monitor, Thresholds, judge

JOINTS = ["a", "b"]
LIMIT = np.array([10.0, np.inf])


def rows(n=5, err=0.0, effort=(1.0, 1.0)):
    t = 100.0 + np.arange(n) * 1e-3
    q_ref = np.zeros((n, 2))
    q = q_ref.copy()
    q[-1, 1] = err
    return t, q, np.tile(effort, (n, 1)), q_ref


def test_within_the_thresholds_nothing_stops_and_the_worst_is_kept():
    m = Monitor(JOINTS, LIMIT, Thresholds())
    assert m.check(*rows(err=0.049, effort=(9.0, 500.0))) is None  # joint b: no effort limit
    f = m.figures()
    assert f["max_tracking_error"] == {"a": 0.0, "b": pytest.approx(0.049)}
    assert f["max_effort_ratio"] == {"a": pytest.approx(0.9), "b": 0.0} and f["samples"] == 5


def test_a_tracking_error_stops_first_at_its_sample():
    m = Monitor(JOINTS, LIMIT, Thresholds(tracking_rad=0.01))
    abort = m.check(*rows(err=0.02))
    assert abort.kind == "tracking" and abort.t == pytest.approx(100.004)
    assert abort.text.startswith("tracking error of b 0.02 beyond 0.01")


def test_an_effort_beyond_the_limit_stops_but_one_at_the_limit_does_not():
    """A drive saturating at its limit is not beyond it; 1e-9 over it is."""
    m = Monitor(JOINTS, LIMIT, Thresholds())
    assert m.check(*rows(effort=(10.0, 0.0))) is None
    abort = m.check(*rows(effort=(-10.000001, 0.0)))
    assert abort.kind == "effort" and "effort of a -10 beyond 1 × its limit 10" in abort.text


def test_a_missing_position_or_effort_stops():
    m = Monitor(JOINTS, LIMIT, Thresholds())
    t, q, e, r = rows()
    q[2, 0] = np.nan
    assert m.check(t, q, e, r).kind == "tracking"
    t, q, e, r = rows()
    e[1, 0] = np.nan
    abort = m.check(t, q, e, r)
    assert abort.kind == "effort" and "not measured" in abort.text


def test_silence_is_measured_from_the_last_receipt():
    m = Monitor(JOINTS, LIMIT, Thresholds(silence_s=0.25))
    assert m.silent(10.2, since=10.0) is None  # nothing yet, but the watch began 0.2 s ago
    assert m.silent(10.3, since=10.0).kind == "silence"
    m.check(*rows(), rx=np.array([10.25] * 5))
    assert m.silent(10.45, since=10.0) is None
    abort = m.silent(10.6, since=10.0)
    assert abort.kind == "silence" and "none for 0.35 s" in abort.text


@pytest.mark.parametrize("field", ["tracking_rad", "effort_ratio", "silence_s"])
def test_thresholds_must_be_positive(field):
    with pytest.raises(InputError, match=field):
        Thresholds(**{field: 0.0})


def test_judge_against_the_noise_floor():
    assert judge({"relerr_pct": 0.45, "noise_floor_pct": 0.4}, 1.2).accepted
    v = judge({"relerr_pct": 0.6, "noise_floor_pct": 0.4}, 1.2)
    assert not v.accepted and v.reason == "validation 0.6 % = 1.5 × its noise floor 0.4 % > 1.2 ×"
    assert not judge({"relerr_pct": 0.45, "noise_floor_pct": 0.4}, 1.2, max_relerr_pct=0.3).accepted
    assert not judge({"relerr_pct": 0.45, "noise_floor_pct": math.nan}, 1.2).accepted
    with pytest.raises(InputError):
        judge({"relerr_pct": 1.0, "noise_floor_pct": 1.0}, 0.0)
