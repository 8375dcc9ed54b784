"""The dynamic laws (LuGre, generalized Maxwell-slip): the compiled kernel against the same
functions stepped under numpy, against a fine reference integration of the ODE (scipy Radau at
tight tolerance) from 50 Hz to 5 kHz, their sliding limit (the static Stribeck law with δ = 2),
Dahl's closed form, stiff bristles at a coarse rate, and the restart after a gap.

Tolerances. Kernel and numpy run the same arithmetic but for libm's and numpy's exp (≤ 2 ulp)
over thousands of steps of a contracting map: 1e-12 of the force scale. The discretisation takes
the velocity linear between samples and the level's change as a linear forcing: a second-order
error, measured against the reference below as 0.0141, 1.46e-4 and 1.46e-6 N·m (Fs = 3 N·m) at 50,
500 and 5000 Hz; the bounds leave a factor 2.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.friction.kernels import state_rows
from frictionid_core.friction.states import StateFriction, resets

LUGRE = np.array([0.5, 2.0, 3.0, 0.05, 2000.0, 5.0])  # Fv, Fc, Fs, vs, σ0, σ1
GMS = np.array([0.5, 2.0, 3.0, 0.05, 4000.0, 1000.0, 250.0, 60.0])  # Fv, Fc, Fs, vs, k1..k4


def velocity(t: np.ndarray) -> np.ndarray:
    """Reversals at two speeds and a dwell at rest (0.2 rad/s sine, 1.5 s still, a slower sine)."""
    return np.where(t < 2.0, 0.3 * np.sin(np.pi * t), np.where(t < 3.5, 0.0, 0.05 * np.sin(2 * np.pi * (t - 3.5))))


def params_of(model) -> np.ndarray:
    p = LUGRE if model.name == "lugre" else GMS[: 4 + model.elements]
    return np.concatenate([p, 1.2 * p]) if model.asymmetric else p


MODELS = [get_model("lugre"), get_model("lugre", True), get_model("gms"), get_model("gms", True, 2),
          get_model("gms", False, 1)]


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.label)
def test_the_kernel_is_the_numpy_stepping_of_the_law(model):
    p = params_of(model)
    t = np.arange(0.0, 5.0, 1e-3)
    v = velocity(t) + np.random.default_rng(1).normal(0.0, 2e-3, t.size)  # noisy reversals and rest
    compiled = model.torque(p, v, t=t)
    state = StateFriction(model, p[None])
    stepped = np.array([state.step(v[k : k + 1], t[k] - t[k - 1] if k else 0.0)[0] for k in range(t.size)])
    assert np.all(np.isfinite(compiled))
    np.testing.assert_allclose(compiled, stepped, rtol=0, atol=1e-12 * np.abs(p[:3]).sum() * 10)
    both = model.torque(np.vstack([p, p * 1.01]), v, t=t)  # a population: each row its own
    np.testing.assert_array_equal(both[0], compiled)


def lugre_reference(t: np.ndarray) -> np.ndarray:
    """LuGre along :func:`velocity` by Radau at rtol 1e-10, from its sliding state at rest (0)."""
    fv, fc, fs, vs, s0, s1 = LUGRE

    def rate(time, z):
        v = float(velocity(np.array([time]))[0])
        g = fc + (fs - fc) * np.exp(-((v / vs) ** 2))
        return [v - s0 * abs(v) * z[0] / g]

    sol = solve_ivp(rate, (0.0, t[-1]), [0.0], method="Radau", rtol=1e-10, atol=1e-14, max_step=1e-3,
                    dense_output=True)
    z = sol.sol(t)[0]
    v = velocity(t)
    g = fc + (fs - fc) * np.exp(-((v / vs) ** 2))
    return fv * v + s0 * z + s1 * (v - s0 * np.abs(v) * z / g)


@pytest.mark.parametrize(("rate_hz", "bound"), [(50, 0.03), (500, 3e-4), (5000, 3e-6)])  # N·m
def test_the_kernel_follows_a_fine_reference_integration(rate_hz, bound):
    """Against Radau at rtol 1e-10 (dwell at 2-3.5 s: the held bristle force), max error / Fs."""
    t = np.arange(0.0, 4.5, 1.0 / rate_hz)
    error = np.abs(get_model("lugre").torque(LUGRE, velocity(t), t=t) - lugre_reference(t)).max()
    assert error < bound


def exact_travel(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(path, shift) of :func:`velocity`'s motion from each sample to the next (0 at the first),
    integrated at 1 MHz."""
    fine = np.arange(0.0, t[-1] + 1e-9, 1e-6)
    v = velocity(fine)
    q = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * 1e-6)])
    cum = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(q)))])
    k = np.round(t / 1e-6).astype(int)
    return np.concatenate([[0.0], np.diff(cum[k])]), np.concatenate([[0.0], np.diff(q[k])])


@pytest.mark.parametrize(("rate_hz", "bound"), [(50, 0.004), (500, 3e-4), (5000, 3e-6)])  # N·m
def test_the_kernel_along_a_measured_travel_follows_the_reference(rate_hz, bound):
    """The identification's path: each step's distance the measured one (a reversal between two
    samples split as the velocities say, a step across the dip followed in pieces), against Radau.
    Measured 0.0020, 1.46e-4 and 1.46e-6 N·m at 50, 500 and 5000 Hz (the velocity path: 0.0141 at
    50 Hz, where the dip is crossed within a step)."""
    t = np.arange(0.0, 4.5, 1.0 / rate_hz)
    reset = np.zeros(t.size, dtype=bool)
    reset[0] = True
    travel = tuple(a[None] for a in exact_travel(t)) + (np.zeros(1),)
    f = state_rows("lugre", False, 1, LUGRE[None], velocity(t)[None], np.zeros(1, dtype=int), t, reset, travel)[0]
    assert np.abs(f - lugre_reference(t)).max() < bound


def test_along_a_measured_travel_a_start_below_the_rest_speed_is_at_rest():
    """A log that starts still (its velocity noise below the joint's rest speed) starts with the
    states at 0, not at the sliding state of the noise's sign (Fs on every row until the first motion)."""
    t = np.arange(0.0, 1.0, 1e-3)
    v = np.full(t.size, 1e-5)
    travel = (np.zeros((1, t.size)), np.zeros((1, t.size)), np.array([1e-4]))
    f = state_rows("lugre", False, 1, LUGRE[None], v[None], np.zeros(1, dtype=int), t, resets(t), travel)[0]
    assert np.abs(f).max() < LUGRE[0] * 1e-5 + LUGRE[5] * 2e-5
    assert get_model("lugre").torque(LUGRE, v, t=t)[0] > LUGRE[2] * 0.99  # the velocity path: sliding at Fs


def test_stiff_bristles_at_50_hz_stay_bounded_and_reach_the_static_law():
    """σ0 = 1e9 N·m/rad at 50 Hz (an explicit step would blow up by 1e7 per step): the force stays
    within the sliding bound and, sliding, is the static Stribeck law with δ = 2."""
    p = LUGRE.copy()
    p[4] = 1e9
    t = np.arange(0.0, 4.5, 0.02)
    v = velocity(t)
    f = get_model("lugre").torque(p, v, t=t)
    sliding = np.abs(v) > 0.05
    static = get_model("stribeck").torque(np.array([p[0], p[1], p[2], p[3], 2.0]), v)
    damping = p[5] * np.abs(v)  # σ1·ż: |ż| ≤ 2|v|
    assert np.all(np.abs(f - p[0] * v) <= p[2] + 2 * damping + 1e-9)
    np.testing.assert_allclose(f[sliding], static[sliding], rtol=1e-9, atol=p[5] * 1e-6)


def test_dahl_is_the_one_element_maxwell_slip_case():
    """gms with one element and Fs = Fc is Dahl's law: from rest at constant speed the friction is
    Fv·v + Fc·(1 − e^(−σ0·x/Fc)) along the travel x (exact for any step)."""
    fc, k = 2.0, 500.0
    p = np.array([0.3, fc, fc, 0.05, k])
    t = np.arange(0.0, 0.1, 0.01)
    v = np.full(t.size, 0.1)
    v[0] = 0.0  # at rest, then moving: the first step's travel is 0.1·h/2 (velocity linear in between)
    x = np.concatenate([[0.0], 0.1 * (t[1:] - t[1] / 2)])
    np.testing.assert_allclose(get_model("gms", elements=1).torque(p, v, t=t),
                               0.3 * v + fc * (1.0 - np.exp(-k * x / fc)), rtol=1e-12)


def test_a_gap_restarts_the_states_at_their_sliding_values():
    t = np.concatenate([np.arange(0.0, 1.0, 1e-3), 5.0 + np.arange(0.0, 1.0, 1e-3)])
    v = np.full(t.size, -0.2)
    v[:1000] = 0.2
    assert np.flatnonzero(resets(t)).tolist() == [0, 1000]
    f = get_model("lugre").torque(LUGRE, v, t=t)
    sliding = LUGRE[0] * -0.2 - (LUGRE[1] + (LUGRE[2] - LUGRE[1]) * np.exp(-(0.2 / LUGRE[3]) ** 2))
    assert f[1000] == pytest.approx(sliding, rel=1e-12)  # no transient across the gap: restarted sliding


def test_a_dynamic_law_needs_times_and_its_parameter_count():
    model = get_model("lugre")
    with pytest.raises(FrictionIdError, match="needs the samples' times"):
        model.torque(LUGRE, np.ones(3))
    with pytest.raises(FrictionIdError, match="takes 6 parameters"):
        model.torque(LUGRE[:5], np.ones(3), t=np.arange(3.0))
    with pytest.raises(FrictionIdError, match="only the gms law takes a number of elements"):
        get_model("lugre", elements=3)
    with pytest.raises(FrictionIdError, match="1 to 16"):
        get_model("gms", elements=0)
    assert get_model("gms", elements=2).names == ("Fv", "Fc", "Fs", "vs", "k1", "k2")
    assert get_model("gms", True, 1).label == "gms-1-asym"
