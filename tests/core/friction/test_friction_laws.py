"""The 8 friction models against the formulas of docs/reference.md#friction-models, written here independently,
per candidate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import FRICTIONS, LAWS, all_models, get_model, smooth_sign
from frictionid_core.friction.laws import NUMPY_OPS
from frictionid_core.identification import build_model
from frictionid_core.model.least_squares import least_squares

NAMES = {
    "coulomb": ("Fv", "Fc"),
    "threlfall": ("Fv", "Fc", "v0"),
    "tustin": ("Fv", "Fc", "Fs", "vs"),
    "stribeck": ("Fv", "Fc", "Fs", "vs", "delta"),
}
DYNAMIC_NAMES = {
    "lugre": ("Fv", "Fc", "Fs", "vs", "sigma0", "sigma1"),
    "gms": ("Fv", "Fc", "Fs", "vs", "k1", "k2", "k3", "k4"),
}


def sgn(v: float) -> float:
    return 0.0 if v == 0.0 else math.copysign(1.0, v)


def level(friction: str, p: dict, a: float) -> float:
    """Friction level at speed a = |v| ≥ 0 of one branch (the part multiplied by sign(v))."""
    if friction == "coulomb":
        return p["Fc"]
    if friction == "threlfall":
        g = (1.0 - math.exp(-3.0 * a / p["v0"])) / (1.0 - math.exp(-3.0)) if a <= p["v0"] else 1.0
        return p["Fc"] * g
    if friction == "tustin":
        return p["Fc"] + (p["Fs"] - p["Fc"]) * math.exp(-a / p["vs"])
    if friction == "stribeck":
        return p["Fc"] + (p["Fs"] - p["Fc"]) * math.exp(-((a / p["vs"]) ** p["delta"]))
    raise AssertionError(friction)


def spec_torque(friction: str, asymmetric: bool, p: dict, v: float) -> float:
    """docs/reference.md#friction-models, one candidate, one velocity."""
    if not asymmetric:
        return p["Fv"] * v + level(friction, p, abs(v)) * sgn(v)
    if v > 0:
        pp = {k[:-4]: x for k, x in p.items() if k.endswith("_pos")}
        return pp["Fv"] * v + level(friction, pp, v)
    if v < 0:
        pn = {k[:-4]: x for k, x in p.items() if k.endswith("_neg")}
        return -level(friction, pn, -v) - pn["Fv"] * abs(v)
    return 0.0


def random_params(model, n: int, rng) -> np.ndarray:
    """(n, k) parameters drawn inside plausible ranges (Fs above or below Fc)."""
    ranges = {"Fv": (0.0, 300.0), "Fc": (1.0, 50.0), "Fs": (1.0, 80.0), "vs": (1e-3, 0.05),
              "v0": (1e-3, 0.05), "delta": (0.5, 3.0)}
    cols = [rng.uniform(*ranges[n_.removesuffix("_pos").removesuffix("_neg")], n) for n_ in model.names]
    return np.column_stack(cols)


V = np.concatenate([
    [0.0, 1e-9, -1e-9, 1e-4, -1e-4, 0.05, -0.05, 0.2, -0.2],
    np.linspace(-0.1, 0.1, 41),
])


@pytest.mark.parametrize("model", all_models(), ids=lambda m: m.label)
def test_vectorised_torque_equals_spec_formula(model):
    rng = np.random.default_rng(sum(map(ord, model.label)))  # deterministic per model
    P = random_params(model, 6, rng)
    # Put some velocities exactly at each candidate's threlfall v0 (the branch boundary).
    v = V.copy()
    for name in ("v0", "v0_pos"):
        if name in model.names:
            v0 = P[:, model.names.index(name)]
            v = np.concatenate([v, v0, v0 * (1 - 1e-9), v0 * (1 + 1e-9)])
    if "v0_neg" in model.names:
        v = np.concatenate([v, -P[:, model.names.index("v0_neg")]])
    out = model.torque(P, v)
    assert out.shape == (6, v.size)
    ref = np.array([[spec_torque(model.name, model.asymmetric, dict(zip(model.names, row)), x) for x in v]
                    for row in P])
    # Same formulas, different evaluation order: agreement to rounding (forces up to ~100 N).
    np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12)
    # A 1-D parameter vector gives one row.
    np.testing.assert_allclose(model.torque(P[2], v), ref[2], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("model", all_models(), ids=lambda m: m.label)
def test_parameter_names(model):
    base = NAMES[model.name]
    if model.asymmetric:
        assert model.names == tuple(n + "_pos" for n in base) + tuple(n + "_neg" for n in base)
        assert "offset" not in model.names
    else:
        assert model.names == base
    assert set(model.units()) == set(model.names)


def test_all_models_are_the_eight_combinations():
    labels = [m.label for m in all_models()]
    assert len(labels) == 8 and len(set(labels)) == 8
    assert set(FRICTIONS) == {"coulomb", "threlfall", "tustin", "stribeck", "lugre", "gms"}
    assert all(not m.law.is_dynamic for m in all_models())
    assert [m.is_linear for m in all_models()] == [True, True] + [False] * 6


def test_the_registry_is_the_one_description_of_each_law():
    """Names, parameters (linear first), and a dip with its end exactly when the law has
    nonlinear parameters (the compiled kernels' agreement with the numpy law: test_law_agreement)."""
    assert FRICTIONS == tuple(LAWS) and all(law.name == name for name, law in LAWS.items())
    for name, law in LAWS.items():
        assert law.params == {**NAMES, **DYNAMIC_NAMES}[name] == law.linear + law.nonlinear + law.params[
            len(law.linear) + len(law.nonlinear):]
        assert set(law.linear) <= {"Fv", "Fc", "Fs"} and not set(law.nonlinear) & {"Fv", "Fc", "Fs"}
        assert (law.dip is None) == (law.dip_end is None) == (not law.nonlinear)
        assert law.is_dynamic == (name in DYNAMIC_NAMES)
    with pytest.raises(FrictionIdError, match="coulomb model has no nonlinear part"):
        get_model("coulomb").dip(np.ones((1, 1)), np.ones(3))


@pytest.mark.parametrize("model", [m for m in all_models() if not m.is_linear], ids=lambda m: m.label)
def test_dip_is_the_law_dip_and_vanishes_with_speed(model):
    """FrictionModel.dip is the registry's dip: 1 at v = 0 (the level is Fs, or 0 without Fs),
    decreasing with speed below vs or v0 (0.01 here), vanishing far beyond it."""
    law = model.law
    theta = np.array([[0.01] + [1.5] * (len(law.nonlinear) - 1)])
    a = np.array([0.0, 0.001, 0.005, 0.009, 10.0])
    d = model.dip(theta, a)[0]
    np.testing.assert_array_equal(d, law.dip(a[None, :], None, theta.T[:, :, None], 0, *NUMPY_OPS)[0])
    assert d[0] == 1.0 and np.all(np.diff(d[:4]) < 0) and d[-1] < 1e-12


@pytest.mark.parametrize("model", all_models(), ids=lambda m: m.label)
def test_zero_velocity_gives_zero_torque(model):
    P = random_params(model, 4, np.random.default_rng(0))
    np.testing.assert_array_equal(model.torque(P, np.zeros(3)), 0.0)
    np.testing.assert_array_equal(model.torque(P, np.zeros(3), eps=1e-3), 0.0)


@pytest.mark.parametrize("model", all_models(), ids=lambda m: m.label)
def test_smoothed_sign_is_continuous_and_tends_to_hard_sign(model):
    P = random_params(model, 4, np.random.default_rng(1))
    eps = 1e-4
    tiny = np.array([-1e-12, 1e-12])
    hard = model.torque(P, tiny)
    soft = model.torque(P, tiny, eps=eps)
    if model.name == "threlfall":
        # g(0) = 0: the Threlfall model is continuous at 0 even with the hard sign.
        assert np.all(np.abs(hard[:, 1] - hard[:, 0]) < 1e-6)
    else:
        # The hard sign jumps by 2·Fs (Fs ≥ 1 here) across 0 ...
        assert np.all(np.abs(hard[:, 1] - hard[:, 0]) > 1.0)
    # ... the smoothed one by at most 2·max(Fs, Fc)·1e-12/eps ≤ 1.6e-6 (Fs, Fc ≤ 80).
    assert np.all(np.abs(soft[:, 1] - soft[:, 0]) < 2e-6)
    # Far from 0 (|v| ≥ 400·eps, tanh = 1 to double precision) it equals the hard-sign model.
    far = np.array([-0.2, -0.05, 0.05, 0.2])
    np.testing.assert_allclose(model.torque(P, far, eps=eps), model.torque(P, far), rtol=1e-12, atol=1e-12)


def test_smooth_sign_function():
    v = np.array([-1.0, -1e-3, 0.0, 1e-3, 1.0])
    np.testing.assert_array_equal(smooth_sign(v), [-1, -1, 0, 1, 1])
    np.testing.assert_allclose(smooth_sign(v, 1e-3), np.tanh(v / 1e-3))


@pytest.mark.parametrize("model", all_models(), ids=lambda m: m.label)
def test_default_bounds(model):
    lo, hi = model.default_bounds()
    assert lo.shape == hi.shape == (len(model.names),)
    assert np.all(lo < hi)
    for name, low in zip(model.names, lo):
        if name.startswith(("vs", "v0", "delta")):
            assert low > 0.0  # shape parameters must stay away from 0 (division)


def test_tustin_with_fs_equal_fc_is_coulomb():
    v = np.linspace(-0.1, 0.1, 101)
    cou = get_model("coulomb").torque(np.array([[200.0, 20.0]]), v)
    tus = get_model("tustin").torque(np.array([[200.0, 20.0, 20.0, 0.01]]), v)
    np.testing.assert_allclose(tus, cou, rtol=1e-14, atol=1e-12)


def test_wrong_parameter_count_and_unknown_law():
    with pytest.raises(FrictionIdError, match="takes 2 parameters"):
        get_model("coulomb").torque(np.ones(3), np.zeros(4))
    with pytest.raises(FrictionIdError, match="unknown friction model 'dahl'"):
        get_model("dahl")


# ------------------------------------------------------- nesting on the EMPS data
@pytest.fixture(scope="module")
def emps_models(emps_estimation):
    return (build_model(emps_estimation, "emps", "coulomb", False),
            build_model(emps_estimation, "emps", "tustin", False))


def test_identification_model_tustin_with_fs_equal_fc_equals_coulomb(emps_models):
    cou, tus = emps_models
    assert cou.names == ["M", "Fv", "Fc", "offset"]
    assert tus.names == ["M", "Fv", "Fc", "Fs", "vs", "offset"]
    x_c = np.array([95.1, 203.5, 20.4, -3.16])
    for vs in (1e-3, 0.01, 0.1):
        x_t = np.array([95.1, 203.5, 20.4, 20.4, vs, -3.16])
        np.testing.assert_allclose(tus.predict(x_t), cou.predict(x_c), rtol=1e-12, atol=1e-9)


def test_variable_projection_tustin_cost_not_above_coulomb_ls(emps_models):
    cou, tus = emps_models
    fit = least_squares(cou.design(), cou.obs.y)
    r = cou.obs.y - cou.design() @ fit.coef
    ls_cost = float(r @ r)
    # Coulomb through variable projection (no nonlinear parameter) equals the QR solution.
    _, c = cou.solve_linear(np.zeros((1, cou.k)))
    assert c[0] == pytest.approx(ls_cost, rel=1e-9)
    theta = np.zeros((5, tus.k))
    theta[:, tus.names.index("vs")] = [1e-4, 1e-3, 5e-3, 2e-2, 0.1]
    full, costs = tus.solve_linear(theta)
    # The tustin family contains coulomb (its Fc and Fs columns span sign(v)): never worse.
    assert np.all(costs <= ls_cost * (1 + 1e-10))
    np.testing.assert_array_equal(full[:, tus.names.index("vs")], theta[:, tus.names.index("vs")])
    # Returned costs are those of the returned parameters.
    np.testing.assert_allclose(tus.batch_cost(full), costs, rtol=1e-9)
    # As vs → 0 the Stribeck term vanishes: the coulomb cost is recovered.
    _, c0 = tus.solve_linear(np.array([[0, 0, 0, 0, 1e-12, 0]], dtype=float))
    assert c0[0] == pytest.approx(ls_cost, rel=1e-9)
