"""``--friction auto`` (identification/law_choice.py): the law fitted on each half predicts the other
on the same rows; the simplest wins unless a richer one predicts clearly better without a
parameter at its bound."""

from __future__ import annotations

import json

import numpy as np
import pytest

import frictionid_core as fid
from frictionid_core.cli import main
from frictionid_core.identification import IdentifyRequest
from frictionid_core.identification.law_choice import nonlinear_at_bound
from frictionid_core.io import save_csv
from frictionid_core.timeseries import JointSeries
from support.data import dynamic_friction_log

TRUTHS = {"coulomb": {"Fv": 0.8, "Fc": 1.5},
          "stribeck": {"Fv": 0.8, "Fc": 1.5, "Fs": 2.2, "vs": 0.03, "delta": 2.0},
          "lugre": {"Fv": 0.8, "Fc": 1.5, "Fs": 2.2, "vs": 0.03, "sigma0": 3000.0, "sigma1": 6.0}}


@pytest.mark.slow
@pytest.mark.parametrize("law", sorted(TRUTHS))
def test_auto_finds_the_law_of_the_data(law):
    """Measured (seed 0): Coulomb truth 1.25 % (Stribeck 1.26 %, δ at its bound); Stribeck truth
    1.08 % against Coulomb's 13.1 %; LuGre truth 13.3 % against Stribeck's 33.4 %."""
    r = fid.identify(dynamic_friction_log(TRUTHS[law], law, seed=0),
                     IdentifyRequest(system="joint", friction="auto"))
    assert r.friction == law and r.law_choice["chosen"] == law and not r.law_choice["gravity"]
    assert r.request.friction == "auto"  # the saved request chooses again
    scores = {(c["friction"], c["gravity"]): c["cv_relerr_pct"] for c in r.law_choice["candidates"]}
    assert scores[(law, False)] == min(s for (f, g), s in scores.items() if f == law)
    for name, value in TRUTHS[law].items():
        if name in ("Fv", "Fc", "Fs"):
            assert r.params[name] == pytest.approx(value, rel=0.05), name


def pendulum(seed: int = 0) -> JointSeries:
    """A joint under gravity: 0.05·q̈ + Coulomb (0.7, 0.4) + 3·sin(q + 0.5) + 0.1, 500 Hz, 30 s."""
    t = np.arange(0.0, 30.0, 1.0 / 500.0)
    w = 2 * np.pi * 0.3
    q = 0.8 * np.sin(w * t) + 0.3 * np.sin(2.3 * w * t)
    qd = 0.8 * w * np.cos(w * t) + 0.3 * 2.3 * w * np.cos(2.3 * w * t)
    qdd = -0.8 * w**2 * np.sin(w * t) - 0.3 * (2.3 * w) ** 2 * np.sin(2.3 * w * t)
    tau = 0.05 * qdd + 0.7 * qd + 0.4 * np.sign(qd) + 3.0 * np.sin(q + 0.5) + 0.1
    tau += np.random.default_rng(seed).normal(0.0, 0.01, t.size)
    return JointSeries(t, ["j"], q[:, None], tau[:, None], source="pendulum")


@pytest.mark.slow
def test_auto_takes_the_gravity_terms_a_loaded_joint_needs(tmp_path, capsys):
    data = pendulum()
    save_csv(data, tmp_path / "p.csv")
    assert main(["identify", str(tmp_path / "p.csv"), "--system", "joint", "--friction", "auto",
                 "--json", str(tmp_path / "r.json")]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("friction chosen by"))
    assert "coulomb + gravity" in line
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["friction"] == "coulomb" and r["law_choice"]["gravity"] is True
    assert r["params"]["g_sin"] == pytest.approx(3.0 * np.cos(0.5), rel=0.02)
    assert main(["validate", str(tmp_path / "p.csv"), "--params", str(tmp_path / "r.json")]) == 0


def test_a_shape_parameter_at_its_bound_is_named():
    request = IdentifyRequest(system="joint", friction="stribeck")
    fit = fid.identify(dynamic_friction_log(TRUTHS["stribeck"], "stribeck", seed=1, seconds=10.0),
                       IdentifyRequest(system="joint", friction="stribeck", solver="lm"))
    assert nonlinear_at_bound(fit, request) == []
    at = type(fit)(**{**fit.__dict__, "params": {**fit.params, "vs": 0.5, "delta": 0.3000001}})
    assert nonlinear_at_bound(at, request) == ["vs", "delta"]
