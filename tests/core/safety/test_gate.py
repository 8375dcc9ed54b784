"""The safety gate of online re-identification (frictionid_core.safety.review): a candidate replaces
the active parameters only when screened and better on held-back data."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from frictionid_core.identification import IdentifyRequest, IdentifyResult, identify
from frictionid_core.safety import review
from frictionid_core.timeseries import JointSeries

FV, FC = 2.0, 0.5  # friction of the gate's synthetic joint [N·m·s/rad, N·m]


def _joint(seconds: float, seed: int) -> JointSeries:
    """One joint at 1 kHz under Fv·v + Fc·sign(v) + 0.01 N·m noise (a slow sine)."""
    t = np.arange(int(seconds * 1000)) * 1e-3
    q = 0.3 * np.sin(2 * np.pi * 0.5 * t)
    v = 0.3 * np.pi * np.cos(2 * np.pi * 0.5 * t)
    tau = FV * v + FC * np.sign(v) + 0.01 * np.random.default_rng(seed).standard_normal(t.size)
    return JointSeries(t, ["j"], q[:, None], tau[:, None], velocity=v[:, None])


@pytest.fixture(scope="module")
def fitted():
    """(identified result, held-back slice): friction-only fit on 4 s, a fresh 2 s slice."""
    return identify(_joint(4.0, 1), IdentifyRequest(system="friction-only")), _joint(2.0, 2)


def _with(result: IdentifyResult, **params) -> IdentifyResult:
    return replace(result, params={**result.params, **params})


def test_gate_accepts_a_better_set_and_rejects_a_worse_one(fitted):
    good, held = fitted
    assert good.params["Fc"] == pytest.approx(FC, abs=0.01)
    worse = _with(good, Fc=3.0 * FC)
    d = review(worse, good, held)
    assert d.accepted and d.candidate_rmse < d.current_rmse
    assert d.candidate_rmse < 0.02  # the noise is 0.01 N·m
    d = review(good, worse, held)
    assert not d.accepted and "rejected" in d.reason
    assert d.candidate_rmse == pytest.approx(2 * FC, rel=0.05)  # the Coulomb error everywhere
    assert not review(good, good, held).accepted  # not better: kept
    assert review(None, good, held).accepted  # nothing active yet


@pytest.mark.parametrize("value, word", [(math.nan, "not finite"), (math.inf, "not finite"), (-2.0, "negative"),
                                         (2e3, "|value| <= 1000")])
def test_gate_rejects_non_finite_and_huge_parameters(fitted, value, word):
    good, held = fitted
    d = review(None, _with(good, Fv=value), held, max_abs=1e3)
    assert not d.accepted and word in d.reason and "Fv" in d.reason


def test_online_split_holds_back_the_newest_share():
    from frictionid_ros.identification import split

    fit, held = split(_joint(4.0, 3), 0.25)
    assert len(fit.t) == 3000 and len(held.t) == 1000 and held.t[0] > fit.t[-1]
