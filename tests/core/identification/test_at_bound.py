"""A parameter at a bound is not an identified value: listed in ``at_bound``, no σ, marked in the table
(issue 38, item 2)."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.cli._common import print_table
from frictionid_core.friction import FrictionModel
from frictionid_core.identification import (
    IdentifyRequest,
    IdentifyResult,
    PreprocessingOverrides,
    SolverOptions,
    identify,
    nonlinear_at_bound,
)
from frictionid_core.identification.at_bound import bounds_reached
from frictionid_core.io import save_csv
from frictionid_core.timeseries import JointSeries

STRIBECK = {"Fv": 2.0, "Fc": 1.0, "Fs": 1.6, "vs": 0.05, "delta": 1.0}
# The dip sits at vs = 0.05 rad/s: a search held to vs ≥ 0.1 ends at that bound.
ABOVE_THE_DIP = {"vs": (0.1, 0.5)}
# 100 Hz analysis (the dip of these slow reversals spans many samples; the rates are not the point here)
DIP_RATES = PreprocessingOverrides(cutoff_hz=100.0, decimate=10)


def friction_series(seconds: float, params: dict = STRIBECK, noise: float = 0.01, seed: int = 0) -> JointSeries:
    """Friction-only data at 1 kHz: τ = stribeck(q̇) + 0.1 + white noise of σ ``noise``, q̇ = 0.5·cos(ωt)
    rad/s, ω = 2π·0.15 Hz."""
    t = np.arange(int(seconds * 1000)) * 1e-3
    law = FrictionModel("stribeck")
    w = 2 * np.pi * 0.15
    qd = 0.5 * np.cos(w * t)
    effort = law.torque([params[n] for n in law.names], qd) + 0.1
    effort = effort + noise * np.random.default_rng(seed).standard_normal(t.size)
    return JointSeries(t, ["j1"], (0.5 / w * np.sin(w * t))[:, None], effort[:, None], source="friction")


def stribeck_request(**kw) -> IdentifyRequest:
    return IdentifyRequest(system="friction-only", friction="stribeck", solver=SolverOptions("hybrid"),
                           preprocessing=DIP_RATES, **kw)


@pytest.fixture(scope="module")
def series():
    return friction_series(20.0)


def test_a_nonlinear_parameter_at_its_search_bound_has_no_sigma(series):
    r = identify(series, stribeck_request(bounds=ABOVE_THE_DIP))
    assert r.params["vs"] == pytest.approx(0.1, rel=1e-9)
    assert r.at_bound == {"vs": 0.1}
    assert math.isnan(r.std["vs"]) and math.isnan(r.std_robust["vs"])
    # the others keep a σ, taken with vs held (known), and are not at a bound
    others = [n for n in r.params if n != "vs"]
    assert all(np.isfinite(r.std[n]) and r.std[n] > 0 for n in others)
    assert all(np.isfinite(r.std_robust[n]) and r.std_robust[n] > 0 for n in others)
    assert r.nonlinear_at_bound() == ["vs"] == nonlinear_at_bound(r.to_dict())
    assert any(w.startswith("parameter(s) at a search bound: vs (lower 0.1)") and "no σ" in w for w in r.warnings)
    # the JSON keeps it and reads it back
    again = IdentifyResult.from_dict(json.loads(json.dumps(r.to_dict())))
    assert again.at_bound == {"vs": 0.1} and again.nonlinear_at_bound() == ["vs"]
    table = io.StringIO()
    print_table(r.to_dict(), table)
    line = next(s for s in table.getvalue().splitlines() if s.startswith("vs "))
    assert line.split() == ["vs", "at", "bound", "0.1", "—", "—"]


def test_an_interior_optimum_is_no_bound(series):
    r = identify(series, stribeck_request())
    assert r.params["vs"] == pytest.approx(0.05, rel=0.05)
    assert r.at_bound == {} and r.nonlinear_at_bound() == []
    assert all(np.isfinite(r.std[n]) for n in r.params)
    assert "at bound" not in _table(r)


def test_a_level_held_at_the_sign_constraint_is_at_bound_not_nonlinear():
    """Coulomb data with a negative level: the closed form holds Fc at 0, its physical bound."""
    s = friction_series(20.0, params={"Fv": 2.0, "Fc": -0.3, "Fs": -0.3, "vs": 0.05, "delta": 1.0})
    r = identify(s, IdentifyRequest(system="friction-only", friction="coulomb", solver="ls"))
    assert r.at_bound == {"Fc": 0.0} and r.params["Fc"] == 0.0
    assert math.isnan(r.std["Fc"]) and math.isnan(r.std_robust["Fc"]) and np.isfinite(r.std["Fv"])
    assert r.nonlinear_at_bound() == []
    assert any(w.startswith("parameter(s) held at 0, their physical bound") and "Fc" in w for w in r.warnings)
    assert "at bound 0" in _table(r)


def test_the_command_line_marks_it(series, tmp_path, capsys):
    csv = tmp_path / "f.csv"
    save_csv(series, csv)
    out = tmp_path / "r.json"
    assert main(["identify", str(csv), "--system", "friction-only", "--friction", "stribeck", "--solver", "hybrid",
                 "--cutoff", "100", "--decimate", "10", "--bounds", "vs=0.1:0.5", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert any(line.split() == ["vs", "at", "bound", "0.1", "—", "—"] for line in printed.splitlines())
    data = json.loads(out.read_text())
    assert data["at_bound"] == {"vs": 0.1} and math.isnan(data["std"]["vs"])
    assert nonlinear_at_bound(data) == ["vs"]


def test_bounds_reached_judges_against_sigma_and_the_closed_form():
    names = ["a", "b", "c", "d", "fixed"]
    values = np.array([0.5, 0.49, 0.0, 0.3, 1.0])
    std = {"a": 0.1, "b": 0.05, "c": 1e-6, "d": 0.01}
    lower, upper = np.array([0.0, 0.0, 0.0, 0.0, 1.0]), np.array([0.5, 0.5, 1.0, 1.0, 1.0])
    # a exactly at its upper bound; b 0.2 σ from it (an estimate); c held by the closed form whatever its σ;
    # d inside; a fixed parameter is never at a bound
    assert bounds_reached(names, values, std, lower, upper, held={"c"}) == {"a": 0.5, "c": 0.0}
    assert bounds_reached(names, values, {**std, "b": 0.2}, lower, upper) == {"a": 0.5, "b": 0.5, "c": 0.0}


def _table(result) -> str:
    out = io.StringIO()
    print_table(result.to_dict(), out)
    return out.getvalue()
