"""Linear least squares on the EMPS benchmark (acceptance figures) and on synthetic data.

Reference figures: Janot, Gautier, Brunot (2019), EMPS benchmark, IDIM-LS with Coulomb +
viscous friction and an offset, estimation data; our implementation reproduces them to every
printed digit, so the tolerances below only absorb platform rounding.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.io

from frictionid_core.cli import main
from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import IdentifyRequest, identify, validate
from frictionid_core.model.least_squares import least_squares
from support.data import EMPS_ESTIMATION, EMPS_VALIDATION, REPO

REF = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "offset": -3.1648}
REF_STD = {"M": 0.1085, "Fv": 1.146, "Fc": 0.1012, "offset": 0.0444}
REF_ASYM = {"M": 95.1540, "Fv_pos": 166.7061, "Fc_pos": 20.1440, "Fv_neg": 240.4236, "Fc_neg": 20.6277}


def check_coulomb(params, std, metrics):
    assert list(params) == ["M", "Fv", "Fc", "offset"]
    for k in ("M", "Fv", "Fc"):
        assert params[k] == pytest.approx(REF[k], rel=0.005), k
    assert params["offset"] == pytest.approx(REF["offset"], rel=0.02)
    for k, s in REF_STD.items():
        # σ are quoted to 3–4 digits: 1 % covers the rounding of the reference.
        assert std[k] == pytest.approx(s, rel=0.01), k
    assert metrics["relerr_pct"] == pytest.approx(4.08, abs=0.05)
    assert metrics["cond"] == pytest.approx(26.0, abs=0.5)


def check_asymmetric(params, metrics):
    assert list(params) == list(REF_ASYM)  # no offset: collinear with the two Coulomb columns
    for k, v in REF_ASYM.items():
        assert params[k] == pytest.approx(v, rel=0.01), k
    assert metrics["relerr_pct"] == pytest.approx(3.11, abs=0.05)


# ------------------------------------------------------------------ library API
@pytest.fixture(scope="module")
def coulomb(emps_estimation):
    return identify(emps_estimation, IdentifyRequest(system="emps", friction="coulomb", solver="ls"))


def test_emps_coulomb_ls(coulomb):
    check_coulomb(coulomb.params, coulomb.std, coulomb.metrics)
    # 24841 samples − 49 trimmed, decimated by 10.
    assert coulomb.metrics["samples"] == 2480
    assert coulomb.metrics["r2"] > 0.998


def test_emps_asymmetric_coulomb_ls(emps_estimation):
    r = identify(emps_estimation, IdentifyRequest(system="emps", friction="coulomb", asymmetric=True, solver="ls"))
    check_asymmetric(r.params, r.metrics)
    assert set(r.std) == set(REF_ASYM)


def test_emps_cross_test_on_validation(coulomb, emps_validation):
    m = validate(emps_validation, coulomb.to_dict())
    assert m["relerr_pct"] == pytest.approx(5.98, abs=0.1)
    # The cross-test error is worse than the fit error on the estimation data.
    assert m["relerr_pct"] > coulomb.metrics["relerr_pct"]


def test_emps_validation_data_give_different_estimates(coulomb, emps_validation):
    r = identify(emps_validation, IdentifyRequest(system="emps", friction="coulomb", solver="ls"))
    assert r.params["M"] != pytest.approx(coulomb.params["M"], rel=1e-4)
    # Same physical axis: the mass agrees within a few %.
    assert r.params["M"] == pytest.approx(coulomb.params["M"], rel=0.05)


# ------------------------------------------------------------------------- CLI
@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """The acceptance commands, each run once on the bundled bags."""
    d = tmp_path_factory.mktemp("cli")
    codes = {
        "sym": main(["identify", str(EMPS_ESTIMATION), "--system", "emps", "--friction", "coulomb",
                     "--solver", "ls", "--json", str(d / "r.json")]),
        "asym": main(["identify", str(EMPS_ESTIMATION), "--system", "emps", "--friction", "coulomb",
                      "--asymmetric", "--solver", "ls", "--json", str(d / "ra.json")]),
    }
    codes["val"] = main(["validate", str(EMPS_VALIDATION), "--params", str(d / "r.json"),
                         "--json", str(d / "v.json")])
    return codes, d


def test_cli_identify_emps_bag(cli_runs):
    codes, d = cli_runs
    assert codes["sym"] == 0
    r = json.loads((d / "r.json").read_text())
    assert (r["system"], r["friction"], r["asymmetric"], r["solver"]) == ("emps", "coulomb", False, "ls")
    assert r["source"] == f"{EMPS_ESTIMATION}:/joint_states"
    check_coulomb(r["params"], r["std"], r["metrics"])


def test_cli_identify_emps_bag_asymmetric(cli_runs):
    codes, d = cli_runs
    assert codes["asym"] == 0
    r = json.loads((d / "ra.json").read_text())
    assert r["asymmetric"] is True
    check_asymmetric(r["params"], r["metrics"])


def test_cli_validate_emps_bag(cli_runs):
    codes, d = cli_runs
    assert codes["val"] == 0
    v = json.loads((d / "v.json").read_text())
    assert v["metrics"]["relerr_pct"] == pytest.approx(5.98, abs=0.1)
    assert v["source"] == f"{EMPS_VALIDATION}:/joint_states"


def test_make_demo_prints_the_readme_block(tmp_path, monkeypatch, capsys):
    """The two commands of ``make demo`` print what the README shows, to every digit."""
    readme = (REPO / "README.md").read_text()
    shown = readme.split("```\nemps · coulomb", 1)[1].split("```", 1)[0]
    demo = [line.split("$(VENV)/bin/frictionid ", 1)[1].split() for line in (REPO / "Makefile").read_text().splitlines()
            if line.startswith("\t$(VENV)/bin/frictionid ")][:2]
    assert [d[0] for d in demo] == ["identify", "validate"], demo
    (tmp_path / "bags").symlink_to(REPO / "bags")
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    assert all(main(argv) == 0 for argv in demo)
    assert capsys.readouterr().out == "emps · coulomb" + shown


def test_mat_file_gives_the_bag_figures(emps_estimation, tmp_path):
    """The bag holds the MAT samples: a MAT file rebuilt from it identifies identically."""
    s = emps_estimation
    gtau = s.meta["gtau"]
    col = lambda a: np.asarray(a, dtype=float).reshape(-1, 1)
    scipy.io.savemat(tmp_path / "DATA_EMPS.mat", {
        "t": col(s.t), "qm": col(s.position[:, 0]), "vir": col(s.effort[:, 0] / gtau),
        "gtau": np.array([[gtau]]), "kp": np.array([[s.meta["kp"]]]), "kv": np.array([[s.meta["kv"]]])})
    assert main(["identify", str(tmp_path / "DATA_EMPS.mat"), "--json", str(tmp_path / "m.json")]) == 0
    m = json.loads((tmp_path / "m.json").read_text())
    assert m["source"] == str(tmp_path / "DATA_EMPS.mat")
    check_coulomb(m["params"], m["std"], m["metrics"])
    bag = identify(s)
    for k, v in bag.params.items():
        # effort = gtau·(effort/gtau) differs by at most an ulp: same figures to ~1e-12.
        assert m["params"][k] == pytest.approx(v, rel=1e-9), k


# ------------------------------------------------------------------ synthetic data
def test_synthetic_coulomb_parameters_recovered(synthetic):
    r = identify(synthetic(M=50.0, Fv=120.0, Fc=8.0, offset=2.0), IdentifyRequest(system="emps", friction="coulomb"))
    # Noise-free data; the residual error (~1 % relerr) comes from the protocol itself: the
    # untrimmed last samples (one-sided differences, filter edges) and sign(q̇) at reversals.
    assert r.params["M"] == pytest.approx(50.0, rel=0.005)
    assert r.params["Fv"] == pytest.approx(120.0, rel=0.005)
    assert r.params["Fc"] == pytest.approx(8.0, rel=0.01)
    assert r.params["offset"] == pytest.approx(2.0, rel=0.05)


def test_synthetic_asymmetric_absorbs_the_offset(synthetic):
    # τ = Fc·sign(v) + offset is Fc_pos = Fc + offset for v > 0 and Fc_neg = Fc − offset for v < 0.
    r = identify(synthetic(Fc=20.0, offset=-3.0), IdentifyRequest(system="emps", friction="coulomb", asymmetric=True))
    assert r.params["Fc_pos"] == pytest.approx(17.0, rel=0.01)
    assert r.params["Fc_neg"] == pytest.approx(23.0, rel=0.01)
    assert r.params["Fv_pos"] == pytest.approx(200.0, rel=0.01)
    assert r.params["Fv_neg"] == pytest.approx(200.0, rel=0.01)


def test_least_squares_statistics():
    rng = np.random.default_rng(5)
    X = rng.standard_normal((200, 3)) * [1.0, 10.0, 0.1]
    theta = np.array([2.0, -1.0, 30.0])
    y = X @ theta + 0.01 * rng.standard_normal(200)
    fit = least_squares(X, y)
    ref, *_ = np.linalg.lstsq(X, y, rcond=None)
    np.testing.assert_allclose(fit.coef, ref, rtol=1e-10)
    e = y - X @ ref
    std = np.std(e, ddof=1) * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))
    np.testing.assert_allclose(fit.std, std, rtol=1e-8)
    assert fit.cond == pytest.approx(np.linalg.cond(X), rel=1e-10)


def test_least_squares_rank_deficient_names_columns():
    rng = np.random.default_rng(6)
    X = rng.standard_normal((50, 2))
    X = np.column_stack([X, X[:, 0] + X[:, 1]])
    with pytest.raises(FrictionIdError, match=r"rank-deficient.*\['c'\]"):
        least_squares(X, rng.standard_normal(50), ["a", "b", "c"])
