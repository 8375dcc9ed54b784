"""Stick phases (left out per joint, counted in the result), per-joint cut-offs given as JOINT=HZ,
and ``validate`` choosing its data-dependent settings again from its own data."""

from __future__ import annotations

import json

import numpy as np
import pytest

from frictionid_core.cli import main as cli
from frictionid_core.errors import InputError
from frictionid_core.identification import IdentifyRequest, PreprocessingOverrides, identify, model_from_result
from frictionid_core.preprocess import Preprocessing, choose_preprocessing
from frictionid_core.timeseries import JointSeries

FV, FC = 2.0, 1.0  # N·m·s/rad, N·m
STICK = 0.03  # rad/s: below it the joint creeps, its friction rising linearly to Fc


def friction_log(stick: float, rate: float = 500.0, seconds: float = 40.0, f1: float = 0.25, seed: int = 0
                 ) -> JointSeries:
    """A friction-only joint ('a') whose speed lingers near its reversals, q̇ = sin³(2π·f1·t) rad/s
    (a fifth of the rows below 0.03 rad/s): τ = Fv·q̇ + Fc·sign(q̇), the dry part Fc·|q̇|/``stick``
    below ``stick`` (0: none); position noise 1e-6 rad, torque noise 0.01 N·m."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate)) / rate
    w = 2 * np.pi * f1
    q = (-3 * np.cos(w * t) + np.cos(3 * w * t) / 3) / (4 * w)
    qd = np.sin(w * t) ** 3
    dry = FC * np.sign(qd) if stick == 0 else FC * np.clip(qd / stick, -1.0, 1.0)
    tau = FV * qd + dry + 0.01 * rng.standard_normal(t.size)
    return JointSeries(t, ["a"], (q + 1e-6 * rng.standard_normal(t.size))[:, None], tau[:, None],
                       source=f"stick{stick:g}")


CUTOFF = 7.75  # Hz: the folds' choice on friction_log(STICK), given here so that the rule's min speed applies


@pytest.fixture(scope="module")
def sticking():
    """The creeping joint with its cut-off given: the min speed is the rule's (the folds choose it
    with the cut-off), and the stick phases are the detection's to find."""
    series = friction_log(STICK)
    return series, identify(series, IdentifyRequest(system="friction-only", friction="coulomb",
                                                    preprocessing=PreprocessingOverrides(cutoff_hz=CUTOFF))).to_dict()


def test_the_folds_min_speed_leaves_the_creep_band_out():
    """With the defaults the folds choose the min speed (5 % of the top speed, 0.049 rad/s, above
    the 0.03 rad/s creep band: every candidate predicts the rows faster than the highest, where the
    rule's 0.0005 rad/s keeps the band and predicts them 13 × worse): Fv, Fc within 0.1 %, and no
    stick phase left above it; a joint that does not creep keeps the rule's min speed."""
    r = identify(friction_log(STICK), IdentifyRequest(system="friction-only", friction="coulomb")).to_dict()
    pre = r["preprocessing"]
    assert pre["min_speed"]["a"] > STICK and "min_speed" in pre["from_data"]
    assert pre["cross_validation"]["min_speed"]["min_speed"] == pre["min_speed"]
    assert not pre.get("stick_speed") and pre["slow_rows_excluded"]["a"] > 0
    assert r["params"]["Fc"] == pytest.approx(FC, rel=1e-3) and r["params"]["Fv"] == pytest.approx(FV, rel=1e-3)
    still = identify(friction_log(0.0), IdentifyRequest(system="friction-only", friction="coulomb")).to_dict()
    speed = still["preprocessing"]["cross_validation"]["min_speed"]
    assert still["preprocessing"]["min_speed"]["a"] == speed["candidates"][0]["min_speed"]["a"] < 1e-3


def test_stick_phase_is_left_out_and_counted(sticking):
    """The creep band's rows (|q̇| < 0.03 rad/s, where the dry friction is below Fc) are found and
    left out: the stick speed lies at the band's edge (within its bins of 1 % of the rows), the rows
    are counted with a reason, and Fv, Fc come out within 1 %, where the fit with every row (the
    user's min speed turns the detection off) puts Fc several % low."""
    _, r = sticking
    pre = r["preprocessing"]
    assert pre["stick_speed"]["a"] == pytest.approx(STICK, rel=0.3)
    assert pre["stick_rows"]["a"] > 0 and "stick" in pre["stick_reason"]
    assert r["params"]["Fc"] == pytest.approx(FC, rel=0.01) and r["params"]["Fv"] == pytest.approx(FV, rel=0.01)
    kept = identify(friction_log(STICK), IdentifyRequest(system="friction-only", friction="coulomb",
                                                         preprocessing=PreprocessingOverrides(min_speed=1e-3)))
    assert not kept.preprocessing.get("stick_speed")
    assert kept.params["Fc"] < 0.97 * FC


def test_a_joint_that_does_not_stick_keeps_its_rows():
    r = identify(friction_log(0.0), IdentifyRequest(system="friction-only", friction="coulomb")).to_dict()
    assert not r["preprocessing"].get("stick_speed") and not any(r["preprocessing"].get("stick_rows", {}).values())
    assert r["params"]["Fc"] == pytest.approx(FC, rel=0.01)


def test_validate_keeps_the_stick_speeds_and_the_cutoffs_and_rechooses_the_rest(sticking):
    """On another log (another motion) the result's stick speed is kept (a property of the robot)
    and so are its cut-offs (fixed here), the settings that follow the record (decimation, trims,
    the rule's min speed) are chosen again and said so; a cut-off the user gives is set."""
    _, r = sticking
    other = friction_log(STICK, f1=0.5, seed=1)
    model, _ = model_from_result(other, r)
    report = model.obs.report
    assert "stick_speed" in report["kept"] and "cutoff_hz" in report["kept"]
    assert "cutoff_hz" not in report["rechosen"] and "min_speed" in report["rechosen"]
    assert model.obs.preprocessing.stick_speed == r["preprocessing"]["stick_speed"]
    assert model.obs.preprocessing.cutoff_hz["a"] == r["preprocessing"]["cutoff_hz"]["a"]
    model, _ = model_from_result(other, r, preprocessing=PreprocessingOverrides(cutoff_hz={"a": 7.0}))
    assert model.obs.preprocessing.cutoff_hz == {"a": 7.0} and "cutoff_hz" in model.obs.report["set"]
    assert "cutoff_hz" not in model.obs.report["rechosen"]


def test_a_result_with_one_cutoff_still_validates(sticking, tmp_path):
    """An earlier result holds a scalar cut-off and no ``cutoff_from_data``: validate reads it and,
    with the cut-off fixed by the user, uses that for every joint (on a log without creep: its
    parameters predict it to the torque noise, 0.01 N·m of about 1–4 N·m)."""
    _, r = sticking
    series = friction_log(0.0, seed=2)
    old = json.loads(json.dumps(r))
    old["preprocessing"]["cutoff_hz"] = 5.0
    for key in ("cutoff_from_data", "stick_speed", "stick_rows", "stick_reason", "record_s"):
        old["preprocessing"].pop(key, None)
    params = tmp_path / "old.json"
    params.write_text(json.dumps(old))
    csv = tmp_path / "log.csv"
    np.savetxt(csv, np.column_stack([series.t, series.position, series.effort]), delimiter=",",
               header="time,a.position,a.effort", comments="")
    out = tmp_path / "val.json"
    assert cli(["validate", str(csv), "--params", str(params), "--cutoff", "6", "--json", str(out)]) == 0
    val = json.loads(out.read_text())
    assert val["preprocessing"]["cutoff_hz"] == {"a": 6.0} and "cutoff_hz" in val["preprocessing"]["set"]
    assert val["metrics"]["relerr_pct"] < 2.0


def test_cutoff_per_joint_given_and_chosen():
    """``{joint: Hz}`` fixes those joints; the others are chosen from the data; an unknown joint is
    one error naming it."""
    two = friction_log(0.0)
    series = JointSeries(two.t, ["a", "b"], np.column_stack([two.position[:, 0], 0.5 * two.position[:, 0]]),
                         np.column_stack([two.effort[:, 0], two.effort[:, 0]]), source="two")
    settings, report = choose_preprocessing(series, Preprocessing(cutoff_hz={"a": 9.0}))
    assert settings.cutoff_hz["a"] == 9.0 and report["cutoff_from_data"] == ["b"]
    assert 0 < settings.cutoff_hz["b"] < 0.2 * 500.0
    with pytest.raises(InputError, match=r"two: cut-off given for joint\(s\) \['c'\]"):
        choose_preprocessing(series, Preprocessing(cutoff_hz={"c": 9.0}))
