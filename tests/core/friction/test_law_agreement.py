"""Each law's one definition (frictionid_core/friction/laws.py) gives the same friction under numpy
(FrictionModel), in the identification's compiled dip sums and in the EMPS simulator's compiled
friction: every law, symmetric and asymmetric, at v = 0, tiny, around vs / v0 and the cut-off
speed, large, on both branches.

Tolerances. The formulas are the same; the elementary functions are not: numpy's exp, pow and
tanh (SIMD on AVX-512 machines) and libm's differ by up to 2 ulp, the dip sums' exp is within
1 ulp of libm and raises (|v|/vs)^δ as e^(δ(log|v| − log vs)). Threlfall's 1 − (1 − e)/(1 − e⁻³)
and Fc·(1 − dip) turn an ulp of e into a few ulp of Fc near v = 0, and the simulator sets the
dip to 0 where it is below e^−40 (relative 4e−18). Hence a torque within 16 ulp of the sum of its
terms' sizes |Fv·v| + |Fc| + |Fs|, and a dip (≤ 1) within 16 ulp absolute.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import LAWS, FrictionLaw, all_models, get_model, kernels
from frictionid_core.friction.laws import NUMPY_OPS

ULP = np.finfo(float).eps
SPEEDS = np.concatenate([[0.0, 1e-300, 1e-12, 1e-9, 1e-6], np.geomspace(1e-4, 0.5, 60), [1.0, 10.0, 1e3]])


def candidates(model, n: int, rng) -> np.ndarray:
    """(n, k) parameters inside the default bounds, Fs above or below Fc."""
    lo, hi = model.default_bounds()
    return rng.uniform(lo, hi, (n, lo.size))


def speeds_of(model, params: np.ndarray) -> np.ndarray:
    """SPEEDS and, per candidate, its vs / v0 and its cut-off speed (law.dip_end), each ± 1e-9 relative."""
    law = model.law
    out = [SPEEDS]
    if law.dip is not None:
        nb = len(model.branch_names)
        for start in range(0, len(model.names), nb):
            table = params[:, start : start + nb].T[:, :, None]
            for s in (table[len(law.linear)], law.dip_end(table, len(law.linear))):
                out += [s.ravel() * f for f in (1.0 - 1e-9, 1.0, 1.0 + 1e-9)]
    v = np.concatenate(out)
    return np.concatenate([v, -v])


def term_sizes(model, params: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(P, N) |Fv·v| + |Fc| + |Fs|, each the larger of the two branches'."""
    def largest(name: str) -> np.ndarray:
        cols = [i for i, n in enumerate(model.names) if n.removesuffix("_pos").removesuffix("_neg") == name]
        return np.abs(params[:, cols]).max(axis=1)[:, None] if cols else np.zeros((len(params), 1))

    return largest("Fv") * np.abs(v) + largest("Fc") + largest("Fs")


@pytest.mark.parametrize("eps", [0.0, 1e-3])
@pytest.mark.parametrize("model", all_models(), ids=lambda m: m.label)
def test_simulator_friction_is_the_numpy_law(model, eps):
    params = candidates(model, 12, np.random.default_rng(sum(map(ord, model.label))))
    v = speeds_of(model, params)
    numpy_torque = model.torque(params, v, eps)
    compiled = kernels.friction_batch(model.name, model.asymmetric, eps, params, v)
    assert np.all(np.isfinite(compiled))
    np.testing.assert_array_less(np.abs(compiled - numpy_torque), 16 * ULP * term_sizes(model, params, v) + 1e-300)


@pytest.mark.parametrize("friction", [name for name, law in LAWS.items() if law.dip is not None])
def test_dip_sums_are_the_numpy_dip(friction):
    """With F = I the dip sums return the signed dip column itself (dᵀe_r = d_r), so each row is
    checked; dᵀd and dᵀy are checked against numpy's sums of that column."""
    model = get_model(friction)
    rng = np.random.default_rng(len(friction))
    params = candidates(model, 25, rng)
    theta = params[:, len(model.law.linear) :]
    speed = speeds_of(model, params)
    speed = speed[speed > 0.0]
    mask = np.where(rng.uniform(size=speed.size) < 0.5, -1.0, 1.0)
    y = rng.normal(size=speed.size)
    dd, dy, column = kernels.dip_sums(friction, theta, speed, np.log(speed), mask, np.eye(speed.size), y)
    numpy_column = model.dip(theta, speed) * mask
    np.testing.assert_allclose(column, numpy_column, rtol=0, atol=16 * ULP)
    np.testing.assert_allclose(dd, np.sum(numpy_column**2, axis=1), rtol=1e-13)
    np.testing.assert_array_less(np.abs(dy - numpy_column @ y), 1e-13 * (np.abs(numpy_column) @ np.abs(y)))


@pytest.mark.parametrize("friction", [name for name, law in LAWS.items() if law.dip is not None])
def test_dip_is_negligible_beyond_its_end(friction):
    """The simulator's cut-off: from dip_end on, the dip is below e^−40 (Threlfall: exactly 0)."""
    model = get_model(friction)
    law = model.law
    theta = candidates(model, 50, np.random.default_rng(5))[:, len(law.linear) :]
    table = theta.T[:, :, None]
    end = law.dip_end(table, 0)  # (P, 1)
    beyond = end * np.array([[1.0 + 1e-12, 2.0, 1e3]])
    with np.errstate(all="ignore"):
        dips = np.concatenate([law.dip(beyond[:, [j]], None, table, 0, *NUMPY_OPS) for j in range(3)], axis=1)
    assert np.all(dips <= (0.0 if friction == "threlfall" else np.exp(-40.0) * (1 + 1e-12)))


def test_vectorised_exponential_of_the_dip_sums_matches_libm():
    """The dip sums' exp: within 1 ulp of numpy's for x in [-708, 709], exactly 0 below, NaN kept."""
    x = np.concatenate((np.linspace(-708.0, 709.0, 400_001), np.random.default_rng(3).uniform(-3, 3, 100_000),
                        [0.0, -0.0, 1.0, -1.0]))
    ref = np.exp(x)
    np.testing.assert_array_less(np.abs(kernels.exp(x) - ref) / ref, 1.01 * ULP)
    assert kernels.exp(np.array([0.0]))[0] == 1.0
    np.testing.assert_array_equal(kernels.exp(np.array([-708.01, -745.2, -1e300, -np.inf])), 0.0)
    assert np.isnan(kernels.exp(np.array([np.nan]))[0])


def test_an_incomplete_dynamic_law_or_other_linear_parameters_is_refused():
    """The registry's checks: a dynamic law comes with everything its states need, and the compiled
    branch reads Fv, Fc[, Fs] (and a dynamic law's vs, then its pre-sliding parameters) by position."""
    stribeck, lugre = LAWS["stribeck"], LAWS["lugre"]
    with pytest.raises(FrictionIdError, match="a dynamic law has"):
        FrictionLaw("lugre", ("Fv", "Fc", "Fs"), ("vs",), stribeck.dip, stribeck.dip_end, ("sigma0",), elements=1)
    with pytest.raises(FrictionIdError, match="a dynamic law has"):
        FrictionLaw("lugre", ("Fv", "Fc"), ("vs",), stribeck.dip, stribeck.dip_end, ("sigma0",), elements=1,
                    stiffness=lugre.stiffness, damping=lugre.damping)
    with pytest.raises(FrictionIdError, match="linear parameters"):
        FrictionLaw("odd", ("Fc", "Fv"))
    with pytest.raises(FrictionIdError, match="a dip and its end"):
        FrictionLaw("odd", ("Fv", "Fc"), ("vs",))


def test_a_second_process_loads_the_compiled_kernels_from_the_cache():
    """The per-law kernels are cached (their closures hold functions by reference and a source
    digest): a new process loads them, it does not compile them again."""
    code = ("import numpy as np\n"
            "from frictionid_core.friction import kernels\n"
            "s = np.array([0.01, 0.1]); args = (np.log(s), np.ones(2), np.ones((1, 2)), np.ones(2))\n"
            "for law in ('tustin', 'stribeck'):\n"
            "    kernels.dip_sums(law, np.full((1, 2), 0.5)[:, :len(kernels.LAWS[law].nonlinear)], s, *args)\n"
            "kernels.friction_batch('stribeck', True, 0.0, np.ones((1, 10)), s)\n")
    def run() -> str:
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                              env={**os.environ, "NUMBA_DEBUG_CACHE": "1"}).stdout

    run()  # fills the cache if this checkout has none yet
    log = run()
    assert log.count("[cache] data loaded") >= 3 and "[cache] data saved" not in log, log
