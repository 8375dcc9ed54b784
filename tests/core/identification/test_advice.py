"""A warning's advice, followed, never brings the same warning back: each warning that names a way
out (a flag to pass) is raised on data built for it, its advice is followed as written, and the
warning is gone. (The noise-dominated acceleration's ``--cutoff JOINT=HZ``, followed, is held in
tests/core/preprocess/test_rule.py; the loaders' warnings name no flag.)"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from frictionid_core.identification import IdentifyRequest, PreprocessingOverrides, identify
from frictionid_core.io import load
from frictionid_core.timeseries import JointSeries
from support.data import BAGS, emps_like, one_way_series


def warned(result, head: str) -> list[str]:
    return [w for w in result.warnings if head in w]


def two_sines(seconds: float = 20.0, seed: int = 0, friction=None) -> JointSeries:
    """One joint, τ = 0.5 q̈ + 3 q̇ + friction(q̇) (+ 0.02 N·m noise), q two sines (0.3, 0.9 Hz)."""
    t = np.arange(int(seconds * 1000)) * 1e-3
    w1, w2 = 2 * np.pi * 0.3, 2 * np.pi * 0.9
    q = 0.5 * np.sin(w1 * t) + 0.2 * np.sin(w2 * t + 0.3)
    qd = 0.5 * w1 * np.cos(w1 * t) + 0.2 * w2 * np.cos(w2 * t + 0.3)
    qdd = -0.5 * w1**2 * np.sin(w1 * t) - 0.2 * w2**2 * np.sin(w2 * t + 0.3)
    rng = np.random.default_rng(seed)
    tau = 0.5 * qdd + 3.0 * qd + friction(qd) + 0.02 * rng.standard_normal(t.size)
    return JointSeries(t, ["j"], q + 1e-6 * rng.standard_normal(t.size), tau, source="two sines")


def stribeck(fs: float, fc: float, vs: float):
    return lambda v: (fc + (fs - fc) * np.exp(-(v / vs) ** 2)) * np.sign(v)


def test_a_parameter_at_a_bound_is_gone_once_the_bounds_are_widened():
    s = emps_like(n=6000)  # Fv = 200
    tight = identify(s, IdentifyRequest(system="emps", bounds={"Fv": (0.0, 100.0)}))
    (w,) = warned(tight, "at a search bound")
    assert "Fv (upper 100)" in w and "widen the bounds (--bounds NAME=LO:HI)" in w
    wide = identify(s, IdentifyRequest(system="emps", bounds={"Fv": (0.0, 1000.0)}))
    assert warned(wide, "at a search bound") == [] and wide.params["Fv"] == pytest.approx(200.0, rel=0.01)


def test_a_parameter_held_at_zero_is_let_go_by_the_bounds_it_names():
    s = two_sines(friction=lambda v: 1.0 * np.sign(v) - 5.0 * v)  # Fv = 3 − 5 = −2
    held = identify(s, IdentifyRequest(system="joint"))
    (w,) = warned(held, "held at 0, their physical bound")
    assert w.endswith(": Fv, Fc; --bounds NAME=LO:HI lets one go")  # Fc pulled down by Fv held
    free = identify(s, IdentifyRequest(system="joint", bounds={"Fv": (-10.0, 10.0)}))
    assert warned(free, "held at 0") == [] and free.params["Fv"] == pytest.approx(-2.0, rel=0.01)
    assert free.params["Fc"] == pytest.approx(1.0, rel=0.02)


def test_static_friction_below_coulomb_is_gone_with_the_coulomb_law():
    s = two_sines(friction=stribeck(10.0, 20.0, 0.1))  # friction rising out of standstill
    law = identify(s, IdentifyRequest(system="joint", friction="stribeck", solver="lm"))
    (w,) = warned(law, "static friction below the Coulomb level")
    assert w.endswith("if unexpected, compare with --friction coulomb")
    assert warned(identify(s, IdentifyRequest(system="joint", friction="coulomb")), "Coulomb level") == []


def test_a_one_way_move_is_quiet_once_the_offset_is_fixed_as_named():
    s = one_way_series()
    free = identify(s, IdentifyRequest(system="emps"))
    (direction,) = warned(free, "moves in one direction only")
    (unresolved,) = warned(free, "the data do not resolve")
    assert direction.endswith("fix one, e.g. --fix offset=0")
    # a system without a URDF is not told to hold them at the URDF values
    assert "--prior urdf" not in unresolved and "fix them with --fix NAME=VALUE" in unresolved
    fixed = identify(s, IdentifyRequest(system="emps", fixed={"offset": 0.0}))
    assert fixed.warnings == []


def test_an_asymmetric_law_on_a_one_way_move_follows_its_advice_to_quiet():
    s = one_way_series()
    asym = identify(s, IdentifyRequest(system="emps", asymmetric=True))
    (w,) = warned(asym, "moves in one direction only")
    assert w.endswith("Fv_neg, Fc_neg are not identifiable; use a symmetric friction law (no --asymmetric)")
    sym = identify(s, IdentifyRequest(system="emps"))
    assert warned(sym, "not identifiable; use a symmetric friction law") == []
    fixed = identify(s, IdentifyRequest(system="emps", asymmetric=True, fixed={"Fv_neg": 0.0, "Fc_neg": 0.0}))
    assert warned(fixed, "the data do not resolve") == []


def test_a_dip_finer_than_the_rates_set_names_rates_that_follow_it():
    """At 3 Hz and 50 Hz the dip (vs 0.02) comes out 4 × too wide; the rates its estimate asks for
    show it finer still, so the warning names the rates that a fit at them confirms."""
    s = two_sines(friction=stribeck(30.0, 20.0, 0.02))
    coarse = identify(s, IdentifyRequest(system="joint", friction="stribeck", solver="lm",
                                         preprocessing=PreprocessingOverrides(cutoff_hz=3.0, decimate=20)))
    (w,) = warned(coarse, "vs and δ come out biased")
    decimate, cutoff = re.search(r"use --decimate (\d+) --cutoff ([0-9.]+)$", w).groups()
    fine = identify(s, IdentifyRequest(system="joint", friction="stribeck", solver="lm",
                                       preprocessing=PreprocessingOverrides(cutoff_hz=float(cutoff),
                                                                            decimate=int(decimate))))
    assert warned(fine, "vs and δ come out biased") == []
    assert fine.params["vs"] == pytest.approx(0.02, rel=0.02) and fine.params["Fs"] == pytest.approx(30.0, rel=0.01)


def efforts_against_the_axis() -> JointSeries:
    a = emps_like(n=6000, M=2.0, Fv=5.0, Fc=1.0, offset=0.1)
    b = emps_like(n=6000, M=1.0, Fv=3.0, Fc=0.5, offset=-0.1)
    noise = 0.01 * np.random.default_rng(0).standard_normal((6000, 2))
    return JointSeries(a.t, ["a", "b"], np.column_stack([a.position[:, 0], 1.3 * b.position[:, 0]]),
                       np.column_stack([a.effort[:, 0], -b.effort[:, 0]]) + noise, source="signs")


def test_an_effort_against_its_axis_is_quiet_with_the_drive_it_names():
    s = efforts_against_the_axis()
    logged = identify(s, IdentifyRequest(system="joint", effort_sign="as-logged"))
    (w,) = warned(logged, "logged with the sign opposite")
    assert "a drive with joints: [a, b], effort_scale: [1, -1] (or --effort-sign auto) fits it so" in w
    drive = identify(s, IdentifyRequest(system="joint", drive={"joints": ["a", "b"], "effort_scale": [1, -1]}))
    assert drive.warnings == []
    # auto says what it did and that as-logged keeps the signs: that gives the other warning, not this one
    auto = identify(s, IdentifyRequest(system="joint"))
    assert [w for w in auto.warnings if "--effort-sign as-logged keeps the log's signs" in w]
    assert not [w for w in logged.warnings if "--effort-sign as-logged keeps" in w]


def test_implausible_links_lose_the_advice_once_it_is_followed():
    """1.5 s of the TX40 excitation leave the links undetermined: the plain fit advises --consistent;
    the fit that follows it (with or without --prior urdf) holds what the data do not determine at the
    model, so a link it still finds implausible is one the data put there: the warning names the model
    to check, no flag (which would bring the same warning back)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = load(BAGS / "tx40_excitation")
    plain = identify(s, IdentifyRequest(system="tx40", window=(0.0, 1.5)))
    advised = warned(plain, "--consistent holds what the data do not determine at the model")
    assert advised and all("(reconstructed from the base parameters)" in w for w in advised)
    for prior in (None, "urdf"):
        followed = identify(s, IdentifyRequest(system="tx40", window=(0.0, 1.5), consistent=True, prior=prior))
        assert warned(followed, "--consistent holds") == []
        for w in warned(followed, "is implausible against the robot model"):
            assert w.endswith("check the robot model against the robot (a tool or payload on the arm, the URDF's "
                              "units)") and ("even under --prior urdf (weight 1)" in w) == (prior == "urdf")
