"""Synthetic logs with a known friction truth, made independently of the code under test.

Nothing here calls frictionid's friction laws or kernels: the motion is analytic (sums of
sinusoids, smooth ramps and constant-velocity plateaus, each segment starting and ending at
rest), a dynamic law's element states are integrated by this module's own fixed-step
fourth-order Runge–Kutta at ``substeps`` points per sample (compiled with numba; checked
against scipy's Radau in tests/core/identification/test_dynamic_convergence.py), and the
static Stribeck law is written out here. Only :class:`~frictionid_core.timeseries.JointSeries`,
the container, comes from the product.

* :func:`presliding_motion`: a one-joint motion with fast and slow reversals, dwells,
  back-and-forth micro-motions of 0.1–3 mrad (pre-sliding: shorter than a few break-away
  deflections) and constant-velocity plateaus over the Stribeck range, at a given rate.
* :func:`dynamic_log`: τ = J·q̈ + friction + offset + noise of a LuGre, Maxwell-slip (GMS) or
  Stribeck truth along such a motion, noise as a share of the clean torque's RMS.
* :func:`tx40_j2_like_log`: TX40 joint-2-like logs (the thesis joint-2 model, a Fourier
  excitation, a Stribeck truth), with jittered stamps.

Laws (docs/reference.md#dynamic-friction): level g(v) = Fc + (Fs − Fc)·e^(−(|v|/vs)²),
ż_i = v − |v|·z_i·n·k_i/g, F = Fv·v + Σ k_i·z_i + σ1·Σ ż_i (LuGre: n = 1, k_1 = σ0; GMS: σ1 = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from frictionid_core.timeseries import JointSeries

G = 9.81


# ----------------------------------------------------------------------------- motion
@dataclass(frozen=True)
class Segment:
    """One piece of motion, at rest at both ends. ``kind``: ``sines`` (v = Σ c_k·sin(ω_k·τ)),
    ``plateau`` (a quintic-smoothstep ramp to ``speed`` over ``ramp`` s, hold, ramp back) or ``rest``."""

    kind: str
    duration: float
    coef: tuple[float, ...] = ()
    omega: tuple[float, ...] = ()
    speed: float = 0.0
    ramp: float = 0.0

    def evaluate(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q − q(0), q̇, q̈) at local times ``tau`` in [0, duration]."""
        tau = np.asarray(tau, dtype=float)
        if self.kind == "rest":
            z = np.zeros_like(tau)
            return z, z, z
        if self.kind == "sines":
            q, v, a = np.zeros_like(tau), np.zeros_like(tau), np.zeros_like(tau)
            for c, w in zip(self.coef, self.omega):
                if w == 0.0:
                    continue
                v += c * np.sin(w * tau)
                a += c * w * np.cos(w * tau)
                q += c * (1.0 - np.cos(w * tau)) / w
            return q, v, a
        # plateau: up over [0, r] (v = V·S(τ/r), S the quintic smoothstep: q̈ and its rate continuous),
        # hold, down over [T − r, T]
        r, big_v, T = self.ramp, self.speed, self.duration
        hold = T - 2.0 * r
        up = np.clip(tau, 0.0, r) / r
        down = np.clip(tau - r - hold, 0.0, r) / r
        mid = np.clip(tau - r, 0.0, hold)

        def s_q(x):  # ∫S: r·(2.5x⁴ − 3x⁵ + x⁶)
            return r * (2.5 * x**4 - 3.0 * x**5 + x**6)

        q = big_v * (s_q(up) + mid + np.where(tau > r + hold, r * down - s_q(down), 0.0))
        s_up = 10 * up**3 - 15 * up**4 + 6 * up**5
        s_down = 10 * down**3 - 15 * down**4 + 6 * down**5
        v = big_v * np.where(tau < r, s_up, np.where(tau <= r + hold, 1.0, 1.0 - s_down))
        a_up = 30 * up**2 - 60 * up**3 + 30 * up**4
        a_down = 30 * down**2 - 60 * down**3 + 30 * down**4
        a = big_v / r * np.where(tau < r, a_up, np.where(tau <= r + hold, 0.0, -a_down))
        return q, v, a

    @property
    def travel(self) -> float:
        return float(self.evaluate(np.array([self.duration]))[0][0])


def windowed_sine(peak_speed: float, cycles: int, frequency: float) -> Segment:
    """v = peak·sin(ωτ)·sin²(πτ/T) over T = cycles/frequency: whole cycles, smoothly windowed."""
    T = cycles / frequency
    w, big_w = 2 * np.pi * frequency, 2 * np.pi / T
    return Segment("sines", T, (0.5 * peak_speed, -0.25 * peak_speed, -0.25 * peak_speed),
                   (w, w + big_w, w - big_w))


def micro_motion(amplitude: float, cycles: int, frequency: float) -> Segment:
    """Back-and-forth of about ±``amplitude`` rad (peak displacement from the mean) at ``frequency``."""
    return windowed_sine(amplitude * 2 * np.pi * frequency, cycles, frequency)


def plateau(speed: float, hold: float, ramp: float) -> Segment:
    return Segment("plateau", hold + 2 * ramp, speed=speed, ramp=ramp)


@dataclass(frozen=True)
class Motion:
    """Segments one after the other; q continuous (each starts where the last ended)."""

    segments: tuple[Segment, ...]

    @property
    def duration(self) -> float:
        return float(sum(s.duration for s in self.segments))

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        q, v, a = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
        ends = np.cumsum([s.duration for s in self.segments])
        starts = ends - np.array([s.duration for s in self.segments])
        bases = np.concatenate([[0.0], np.cumsum([s.travel for s in self.segments])])
        which = np.minimum(np.searchsorted(ends, t, side="right"), len(self.segments) - 1)
        for k in np.unique(which):
            at = which == k
            s = self.segments[k]
            dq, dv, da = s.evaluate(np.minimum(t[at] - starts[k], s.duration))
            q[at], v[at], a[at] = bases[k] + dq, dv, da
        return q, v, a


def presliding_motion(seed: int, seconds: float = 30.0, top_speed: float = 0.6, vs: float = 0.05,
                      rate: float = 1000.0) -> Motion:
    """A randomised one-joint motion (seeded): sweeps (reversals at 0.02 … ``top_speed`` rad/s),
    micro-motions of 0.1–3 mrad, plateaus at ±(0.2 … 8) × ``vs`` (both directions) and dwells,
    in a shuffled order, about ``seconds`` long. Frequencies stay below rate/20 (the log can
    follow them)."""
    rng = np.random.default_rng(seed)
    f_max = rate / 20.0
    pieces: list[list[Segment]] = []
    for peak in np.geomspace(0.02, top_speed, 4) * rng.uniform(0.8, 1.2, 4):
        f = min(rng.uniform(0.3, 1.2), f_max)
        pieces.append([windowed_sine(float(peak) * rng.choice([-1, 1]), int(rng.integers(2, 4)), f),
                       Segment("rest", float(rng.uniform(0.3, 0.8)))])
    for amp in np.geomspace(1e-4, 3e-3, 4) * rng.uniform(0.8, 1.2, 4):
        f = min(rng.uniform(0.5, 3.0), f_max)
        pieces.append([micro_motion(float(amp) * rng.choice([-1, 1]), int(rng.integers(2, 5)), f),
                       Segment("rest", float(rng.uniform(0.2, 0.6)))])
    for share in np.geomspace(0.2, 8.0, 5) * rng.uniform(0.85, 1.15, 5):
        speed = float(share * vs)
        hold = float(np.clip(0.05 / speed, 0.4, 1.2))  # at least 0.05 rad of travel where slow enough
        ramp = max(0.15, 40.0 / rate)  # at least 40 samples: a log at this rate follows the stop
        pieces.append([plateau(speed, hold, ramp), Segment("rest", 0.3), plateau(-speed, hold, ramp),
                       Segment("rest", 0.3)])
    order = rng.permutation(len(pieces))
    segments = [Segment("rest", 0.5)] + [s for i in order for s in pieces[i]]
    total = sum(s.duration for s in segments)
    while total < seconds:  # fill with further sweeps
        f = min(rng.uniform(0.3, 1.0), f_max)
        peak = float(np.exp(rng.uniform(np.log(0.02), np.log(top_speed))))
        extra = [windowed_sine(peak * rng.choice([-1, 1]), 2, f), Segment("rest", 0.5)]
        segments += extra
        total += sum(s.duration for s in extra)
    return Motion(tuple(segments))


# ----------------------------------------------------------------------------- laws
def stribeck_level(speed, Fc, Fs, vs, delta):
    return Fc + (Fs - Fc) * np.exp(-((np.abs(speed) / vs) ** delta))


def stribeck_friction(v, p: dict) -> np.ndarray:
    """Fv·v + [Fc + (Fs − Fc)·e^(−(|v|/vs)^δ)]·sign(v)."""
    v = np.asarray(v, dtype=float)
    return p["Fv"] * v + stribeck_level(v, p["Fc"], p["Fs"], p["vs"], p["delta"]) * np.sign(v)


@njit(cache=True)
def _rk4_states(v_nodes, v_mid, h, z0, nk, Fc, Fs, vs):  # pragma: no cover - compiled
    """Element states at every node: v at the nodes (M+1,) and midpoints (M,), step h; element
    stiffnesses × n in ``nk`` (n,); returns z (M+1, n)."""
    m = v_mid.size
    n = nk.size
    out = np.empty((m + 1, n))
    z = z0.copy()
    out[0] = z
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    for s in range(m):
        va, vm, vb = v_nodes[s], v_mid[s], v_nodes[s + 1]
        ga = Fc + (Fs - Fc) * math.exp(-(va / vs) ** 2)
        gm = Fc + (Fs - Fc) * math.exp(-(vm / vs) ** 2)
        gb = Fc + (Fs - Fc) * math.exp(-(vb / vs) ** 2)
        for i in range(n):
            k1[i] = va - abs(va) * z[i] * nk[i] / ga
            k2[i] = vm - abs(vm) * (z[i] + 0.5 * h * k1[i]) * nk[i] / gm
            k3[i] = vm - abs(vm) * (z[i] + 0.5 * h * k2[i]) * nk[i] / gm
            k4[i] = vb - abs(vb) * (z[i] + h * k3[i]) * nk[i] / gb
            z[i] += h * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]) / 6.0
        out[s + 1] = z
    return out


def element_states(motion: Motion, t: np.ndarray, stiffness: np.ndarray, p: dict, substeps: int = 200,
                   chunk: int = 2000) -> np.ndarray:
    """States z (N, n) at uniform sample times ``t`` (from 0), integrated by RK4 with ``substeps``
    steps per sample period along the analytic velocity, from rest (z = 0 at t = 0, where the
    motion is at rest)."""
    stiffness = np.asarray(stiffness, dtype=float)
    n = stiffness.size
    nk = n * stiffness
    dt = float(t[1] - t[0])
    h = dt / substeps
    out = np.empty((t.size, n))
    z = np.zeros(n)
    out[0] = z
    for lo in range(0, t.size - 1, chunk):
        hi = min(lo + chunk, t.size - 1)
        fine = t[lo] + h * np.arange((hi - lo) * substeps + 1)
        _, v_nodes, _ = motion.evaluate(fine)
        _, v_mid, _ = motion.evaluate(fine[:-1] + 0.5 * h)
        zs = _rk4_states(v_nodes, v_mid, h, z, nk, p["Fc"], p["Fs"], p["vs"])
        out[lo + 1 : hi + 1] = zs[substeps::substeps]
        z = zs[-1].copy()
    return out


def law_stiffness(law: str, p: dict) -> tuple[np.ndarray, float]:
    """(element stiffnesses, σ1) of a dynamic law's parameters."""
    if law == "lugre":
        return np.array([p["sigma0"]]), p["sigma1"]
    ks = [p[k] for k in sorted((k for k in p if k[0] == "k" and k[1:].isdigit()), key=lambda k: int(k[1:]))]
    return np.array(ks), 0.0


def dynamic_friction(law: str, p: dict, motion: Motion, t: np.ndarray, substeps: int = 200) -> np.ndarray:
    """The friction of ``law`` (lugre, gms, stribeck) with parameters ``p`` along ``motion`` at the
    uniform sample times ``t``."""
    _, v, _ = motion.evaluate(t)
    if law == "stribeck":
        return stribeck_friction(v, p)
    k, sigma1 = law_stiffness(law, p)
    z = element_states(motion, t, k, p, substeps)
    g = p["Fc"] + (p["Fs"] - p["Fc"]) * np.exp(-((v / p["vs"]) ** 2))
    zdot = v[:, None] - np.abs(v)[:, None] * z * (k.size * k)[None] / g[:, None]
    return p["Fv"] * v + z @ k + sigma1 * zdot.sum(axis=1)


def rk4_substeps(law: str, p: dict, rate: float, top_speed: float) -> int:
    """RK4 steps per sample: h·λ ≤ 0.02 for the fastest decay λ = n·k·|v|/g (local error ~1e-10 of
    a step's change), at least 10."""
    if law == "stribeck":
        return 1
    k, _ = law_stiffness(law, p)
    lam = k.size * float(k.max()) * 1.5 * top_speed / min(p["Fc"], p["Fs"])
    return max(10, int(np.ceil(lam / (0.02 * rate))))


def dynamic_log(law: str, p: dict, *, seed: int = 0, rate: float = 1000.0, seconds: float = 30.0,
                inertia: float = 0.8, offset: float = 0.3, noise_share: float = 0.005, position_noise: float = 1e-6,
                top_speed: float = 0.6, motion: Motion | None = None, motion_seed: int | None = None,
                joint: str = "j", substeps: int | None = None) -> tuple[JointSeries, dict]:
    """(log, truth) of one joint τ = J·q̈ + F + offset + noise along :func:`presliding_motion`
    (``motion_seed``, default ``seed``) at ``rate``: torque noise ``noise_share`` × the clean
    torque's RMS, position noise ``position_noise`` rad. The truth holds J, the law's parameters,
    the offset and the noise levels."""
    motion = motion or presliding_motion(seed if motion_seed is None else motion_seed, seconds,
                                         top_speed, p.get("vs", 0.05), rate)
    t = np.arange(0.0, motion.duration, 1.0 / rate)
    q, _, a = motion.evaluate(t)
    steps = substeps or rk4_substeps(law, p, rate, top_speed)
    clean = inertia * a + dynamic_friction(law, p, motion, t, steps) + offset
    rng = np.random.default_rng(10_000 + seed)
    sigma = noise_share * float(np.sqrt(np.mean(clean**2)))
    tau = clean + sigma * rng.standard_normal(t.size)
    qn = q + position_noise * rng.standard_normal(t.size)
    truth = {"J": inertia, **p, "offset": offset, "torque_noise": sigma, "position_noise": position_noise,
             "rate_hz": rate, "law": law, "seed": seed}
    series = JointSeries(t, [joint], qn[:, None], tau[:, None], source=f"synthetic {law} (seed {seed}, {rate:g} Hz)")
    return series, truth


# ------------------------------------------------------------- TX40 joint-2-like logs
# The thesis joint-2 model's effective values of the bundled TX40 (bags/tx40_truth.json) and one
# joint-2 Fourier excitation (harmonics of 0.1 Hz, rad/s), q = q0 + Σ a_l/ω_l·sin − b_l/ω_l·cos.
TX40_J2 = {"ZZ": 1.3648, "MX": 2.8868, "MY": 0.0399, "offset": 0.2}
TX40_J2_FRICTION = {"Fv": 5.6948, "Fc": 7.8301, "Fs": 7.97, "vs": 0.05}  # docs/reference.md#tx40-friction
_J2_A = (-0.4820, -0.3418, 0.3040, 0.5274, 0.2085)
_J2_B = (-0.0148, -0.4372, -0.5830, -0.1026, 0.3716)
_J2_WF = 2 * np.pi / 10.0


def j2_fourier(t: np.ndarray, q0: float = 1.339, wf: float = _J2_WF, ramp: float = 2.0, duration: float = 20.0
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, q̇, q̈) of the joint-2 excitation, faded in and out over ``ramp`` s (a quintic smoothstep
    on the deviation from the start pose: at rest at both ends)."""
    t = np.asarray(t, dtype=float)
    wl = wf * np.arange(1, len(_J2_A) + 1)
    a, b = np.array(_J2_A), np.array(_J2_B)
    s, c = np.sin(np.outer(t, wl)), np.cos(np.outer(t, wl))
    dev = s @ (a / wl) - c @ (b / wl) + np.sum(b / wl)
    d1 = c @ a + s @ b
    d2 = (c * wl) @ b - (s * wl) @ a
    up, down = np.clip(t / ramp, 0, 1), np.clip((duration - t) / ramp, 0, 1)
    x = np.minimum(up, down)
    sign = np.where(up <= down, 1.0, -1.0)
    w = 10 * x**3 - 15 * x**4 + 6 * x**5
    w1 = sign * 30 * x**2 * (1 - x) ** 2 / ramp
    w2 = 60 * x * (1 - x) * (1 - 2 * x) / ramp**2
    return q0 + w * dev, w1 * dev + w * d1, w2 * dev + 2 * w1 * d1 + w * d2


def tx40_j2_like_log(delta: float, *, seed: int = 0, rate: float = 500.0, jitter: float = 0.2, seconds: float = 20.0,
                     friction: dict | None = None, torque_noise: float = 0.05, position_noise: float = 1e-6,
                     joint: str = "joint_2") -> tuple[JointSeries, dict]:
    """(log, truth) of TX40 joint 2 alone, τ = ZZ·q̈ − g·MX·cos θ + g·MY·sin θ + Stribeck(δ) + offset
    + noise, θ = q − π/2, along :func:`j2_fourier`, stamped at ``rate`` with a uniform jitter of
    ± ``jitter`` periods (each sample taken at its own stamp)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    n = int(seconds * rate)
    t = np.arange(n) * dt + jitter * dt * rng.uniform(-1.0, 1.0, n)
    t[0], t[-1] = 0.0, (n - 1) * dt
    t = np.clip(t, 0.0, seconds)
    q, qd, qdd = j2_fourier(t, duration=seconds)
    p = {**TX40_J2_FRICTION, **(friction or {}), "delta": delta}
    theta = q - np.pi / 2
    clean = (TX40_J2["ZZ"] * qdd - G * TX40_J2["MX"] * np.cos(theta) + G * TX40_J2["MY"] * np.sin(theta)
             + stribeck_friction(qd, p) + TX40_J2["offset"])
    tau = clean + torque_noise * rng.standard_normal(n)
    qn = q + position_noise * rng.standard_normal(n)
    truth = {**{k: TX40_J2[k] for k in ("ZZ", "MX", "MY", "offset")}, **p, "torque_noise": torque_noise}
    return JointSeries(t, [joint], qn[:, None], tau[:, None], source=f"tx40-j2-like (δ {delta}, seed {seed})"), truth
