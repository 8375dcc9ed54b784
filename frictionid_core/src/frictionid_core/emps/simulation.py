"""Closed-loop simulation of the EMPS, the benchmark's reference model (docs/reference.md#emps-simulation).

Discrete position controller (period T) with velocity feedback, one-sample delay and ±10 V
saturation; plant M·q̈ = gtau·(u + pulses) − τ_f(q̇) − offset integrated by RK4 with
``substeps`` steps per period (the benchmark's Simulink run: ode45, MaxStep T/10)::

    qf(k)    = 0.5·q(k) + 0.5·q(k−1)
    q̇_est(k) = (qf(k) − qf(k−1)) / T
    u_c(k)   = kv·(kp·(qg(k) − q(k)) − q̇_est(k))          V
    u(k)     = sat(u_c(k−1), ±10 V)                        held over [t(k), t(k+1))

Two clocks:

* ``benchmark``: the benchmark's Simulink run. Constant period tec = t(10) − t(9) (1-based),
  qg linearly interpolated at k·tec, the pulses a continuous-time signal (linear
  interpolation of (t, pulses) inside each period), start at rest at q = 0. Simulated sample k
  is compared with the sample recorded at t(k), so the comparison drifts with the clock
  error (≈0.4 ms at the end of the estimation run). Reproduces the published figures
  (thesis Table 6.12: 0.013752 % / 0.0080248 % with the reference parameters).
* ``true`` (default): period t(k+1) − t(k) of the recorded stamps, qg(k) and pulses(k) at
  t(k) (pulses held over the period, as the drive input vir(k) recorded with them), start
  from the measured state: q(0) = qm(0), q̇(0) from the first three samples, controller
  history consistent with it, u(0) = the recorded drive voltage.

Metrics (as the benchmark script): relative errors 100·‖y − ŷ‖/‖y‖ (%) from sample 50
(1-based) on; the measured position is qm after the zero-phase Butterworth (order 4, 100 Hz),
measured velocity/acceleration its central differences; simulated velocity/acceleration
are the plant's own; force = gtau·(u + pulses) against the recorded gtau·vir.

Parameter vector: ``M`` (kg), the friction model's parameters, then ``offset`` (N;
symmetric models only), as written by ``frictionid identify``. A population (P, k) is
simulated in one call by a numba kernel (vectorised across members, chunks of members in the
threads that :mod:`frictionid_core.parallel` allows).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numba import njit

from frictionid_core.emps.clocks import CLOCKS
from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.friction import SOURCE_DIGEST, FrictionModel, dip_ends, get_model, law_parts, members_friction
from frictionid_core.parallel import run_chunks
from frictionid_core.preprocess import central_difference, lowpass_position
from frictionid_core.timeseries import JointSeries

SATURATION_V = 10.0
SKIP = 49  # samples left out of the metrics (the benchmark's n_border = 50, 1-based)
CUTOFF_HZ = 100.0  # Butterworth on the measured position (5 × the 20 Hz loop bandwidth)
ORDER = 4
REFERENCE_TOPIC = "/joint_reference"
PULSES_TOPIC = "/drive_pulses"
METRIC_KEYS = ("position_relerr_pct", "velocity_relerr_pct", "acceleration_relerr_pct", "force_relerr_pct")

MIN_CHUNK_MEMBERS = 8  # members per thread: the kernel vectorises across them


# ---------------------------------------------------------------------------- data
@dataclass
class EmpsData:
    """One EMPS run (all arrays (N,), SI units).

    Attributes:
        t: sample stamps, s.
        qm: measured position, m.
        qg: reference position, m.
        force: recorded drive force gtau·vir, N (vir includes the pulses when there are any).
        pulses: voltage added after saturation, V, or None.
        gtau: drive gain, N/V. kp: position gain, 1/s. kv: velocity gain, V·s/m.
        tec: the benchmark clock's period, s, when known better than the stamps tell
            (meta ``tec``; default t(10) − t(9)).
    """

    t: np.ndarray
    qm: np.ndarray
    qg: np.ndarray
    force: np.ndarray
    gtau: float
    kp: float
    kv: float
    pulses: np.ndarray | None = None
    source: str = ""
    tec: float | None = None

    def __post_init__(self) -> None:
        for name in ("t", "qm", "qg", "force") + (("pulses",) if self.pulses is not None else ()):
            arr = np.asarray(getattr(self, name), dtype=float).ravel()
            if arr.size != np.size(self.t):
                raise InputError(f"{self.source}: EMPS signal '{name}' has {arr.size} samples "
                                 f"for {np.size(self.t)} stamps")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{self.source}: EMPS signal '{name}' has NaN/inf samples")
            setattr(self, name, arr)
        if self.t.size < 10:
            raise InputError(f"{self.source}: {self.t.size} samples are too few to simulate the EMPS")
        if np.any(np.diff(self.t) <= 0):
            raise InputError(f"{self.source}: time stamps must increase strictly")

    @classmethod
    def from_series(cls, series: JointSeries) -> EmpsData:
        """From a JointSeries carrying extras ``qg`` (and ``pulses``) and meta gtau, kp, kv."""
        missing = [k for k in ("gtau", "kp", "kv") if k not in series.meta]
        if missing or "qg" not in series.extras:
            raise InputError(f"{series.source}: an EMPS simulation needs the reference qg and gtau, kp, kv; "
                             f"missing {missing + ([] if 'qg' in series.extras else ['qg'])}")
        pulses = series.extras.get("pulses")
        return cls(series.t, series.position[:, 0], np.ravel(series.extras["qg"]), series.effort[:, 0],
                   float(series.meta["gtau"]), float(series.meta["kp"]), float(series.meta["kv"]),
                   None if pulses is None else np.ravel(pulses), series.source, series.meta.get("tec"))


def load_emps(source: str | Path) -> EmpsData:
    """Load an EMPS run from its MAT file or its bag (topics /joint_states, /joint_reference
    (qg in position) and, on the validation run, /drive_pulses (pulses in effort))."""
    path = Path(source)
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    if path.suffix.lower() == ".mat":
        from frictionid_core.io import load_emps_mat

        return EmpsData.from_series(load_emps_mat(path))
    from frictionid_core.io import check_series, list_topics, load_bag

    topics = list_topics(path)
    if REFERENCE_TOPIC not in topics:
        raise InputError(f"{path}: no {REFERENCE_TOPIC} topic (the position set-point qg)")
    extras = {"qg": (REFERENCE_TOPIC, "position")}
    if PULSES_TOPIC in topics:
        extras["pulses"] = (PULSES_TOPIC, "effort")
    return EmpsData.from_series(check_series(load_bag(path, extras=extras)))


def _as_data(data) -> EmpsData:
    if isinstance(data, EmpsData):
        return data
    if isinstance(data, JointSeries):
        return EmpsData.from_series(data)
    return load_emps(data)


# -------------------------------------------------------------------------- kernel
# Members of the population sit in the innermost loops (structure of arrays) so that the
# compiler vectorises across them; chunks of members run in parallel threads. The friction is
# the law's own (frictionid_core.friction.kernels.members_friction), compiled into a kernel per law.
@functools.cache
def _simulation_kernel(friction: str):
    """The simulator compiled for the law ``friction`` (numba caches one kernel per law)."""
    dip, dip_end, n_linear = law_parts(friction)
    digest = SOURCE_DIGEST

    @njit(cache=True, nogil=True)
    def simulate_chunk(asym, eps, th, mass, off, gtau, kp, kv, sat, periods, t_ctrl, qg, ext, pulse_k,
                       q0, v0, q_prev0, qf_prev0, u0, nsub, full, out_q, out_v, out_a, out_u):  # pragma: no cover
        """Simulate m members (columns of th (kf, m), mass (m,), off (m,)) over the N samples.

        ext: (N−1, 2·nsub+1) external voltage at the half sub-steps of each period, or (0, 0);
        pulse_k: (N,) external voltage at the samples. Writes q (m, N) and, if full, v, a, u;
        a diverging member (|q| ≥ 1e6 m or NaN) gets NaN from then on.
        """
        digest  # noqa: B018 - a cell of the closure: part of the cache key (see friction.kernels)
        m = mass.shape[0]
        n = qg.shape[0]
        has_ext = ext.shape[0] > 0
        cut = dip_ends(dip_end, n_linear, asym, th)
        inv_m = 1.0 / mass
        q = np.full(m, q0)
        v = np.full(m, v0)
        q_prev = np.full(m, q_prev0)
        qf_prev = np.full(m, qf_prev0)
        uc = np.full(m, u0)
        u_now = np.empty(m)
        fu = np.empty(m)
        f = np.empty(m)
        a1 = np.empty(m)  # RK4 stages
        a2 = np.empty(m)
        a3 = np.empty(m)
        v2 = np.empty(m)
        v3 = np.empty(m)
        v4 = np.empty(m)
        for k in range(n):
            alive = 0
            for i in range(m):
                if not abs(q[i]) < 1e6:
                    q[i] = np.nan
                    v[i] = np.nan
                else:
                    alive += 1
                out_q[i, k] = q[i]
                u_now[i] = min(max(uc[i], -sat), sat)
                fu[i] = gtau * u_now[i]
                qf = 0.5 * q[i] + 0.5 * q_prev[i]
                uc[i] = kv * (kp * (qg[k] - q[i]) - (qf - qf_prev[i]) / t_ctrl)
                q_prev[i] = q[i]
                qf_prev[i] = qf
            if k == n - 1:
                if full:
                    members_friction(dip, n_linear, asym, eps, th, off, cut, v, f)
                    for i in range(m):
                        out_v[i, k] = v[i]
                        out_u[i, k] = u_now[i]
                        out_a[i, k] = (fu[i] + gtau * pulse_k[k] - f[i]) * inv_m[i]
                break
            if alive == 0:
                out_q[:, k + 1 :] = np.nan
                if full:
                    out_v[:, k:] = np.nan
                    out_a[:, k:] = np.nan
                    out_u[:, k:] = np.nan
                break
            h = periods[k] / nsub
            for s in range(nsub):
                j = 2 * s
                e1 = gtau * ext[k, j] if has_ext else 0.0
                e2 = gtau * ext[k, j + 1] if has_ext else 0.0
                e4 = gtau * ext[k, j + 2] if has_ext else 0.0
                members_friction(dip, n_linear, asym, eps, th, off, cut, v, f)
                for i in range(m):
                    a1[i] = (fu[i] + e1 - f[i]) * inv_m[i]
                    v2[i] = v[i] + 0.5 * h * a1[i]
                members_friction(dip, n_linear, asym, eps, th, off, cut, v2, f)
                for i in range(m):
                    a2[i] = (fu[i] + e2 - f[i]) * inv_m[i]
                    v3[i] = v[i] + 0.5 * h * a2[i]
                members_friction(dip, n_linear, asym, eps, th, off, cut, v3, f)
                for i in range(m):
                    a3[i] = (fu[i] + e2 - f[i]) * inv_m[i]
                    v4[i] = v[i] + h * a3[i]
                members_friction(dip, n_linear, asym, eps, th, off, cut, v4, f)
                if full and s == 0:  # outputs at the sample: state, held input, acceleration
                    for i in range(m):
                        out_v[i, k] = v[i]
                        out_u[i, k] = u_now[i]
                        out_a[i, k] = a1[i]
                for i in range(m):
                    a4 = (fu[i] + e4 - f[i]) * inv_m[i]
                    q[i] += h / 6.0 * (v[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i])
                    v[i] += h / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4)

    return simulate_chunk


# ----------------------------------------------------------------------- simulator
@dataclass
class EmpsSimulation:
    """A simulated run. Signals are (N,) for one parameter set, (P, N) for a population.

    Attributes:
        clock: "true" or "benchmark".
        t: simulation sample times, s (N,).
        q: position, m. velocity: m/s. acceleration: m/s².
        voltage: controller output after saturation, V (without the pulses).
        force: drive force gtau·(voltage + pulses), N.
        metrics: the 4 relative errors (%), floats (one set) or (P,) arrays.
        names, params: parameter names and values ((k,) or (P, k)).
    """

    clock: str
    t: np.ndarray
    q: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    voltage: np.ndarray
    force: np.ndarray
    metrics: dict
    names: tuple[str, ...]
    params: np.ndarray
    settings: dict = field(default_factory=dict)


class EmpsSimulator:
    """The EMPS closed loop on one run, ready to simulate populations of parameter sets.

    Args:
        data: EmpsData, a JointSeries with extras qg (and pulses) and meta gtau/kp/kv, or a
            path (MAT file or bag).
        friction: friction law (``coulomb``, ``threlfall``, ``tustin``, ``stribeck``) or a FrictionModel.
        asymmetric: separate parameters for v > 0 and v < 0 (ignored if friction is a model).
        clock: ``true`` (default) or ``benchmark`` (see the module docstring).
        substeps: RK4 steps per controller period (10 = the benchmark's MaxStep tec/10).
        offset: include the constant ``offset`` parameter (default: symmetric models only).
        eps: > 0 smooths sign(v) as tanh(v/eps), m/s (default 0: hard sign, sign(0) = 0).
        pulses: how the pulses enter the plant: ``linear`` (continuous-time interpolation),
            ``hold`` (pulses(k) held over the period); default linear on the benchmark clock,
            hold on the true clock.
        tec: benchmark-clock period, s (default: the data's ``tec``, else t(10) − t(9)).
        skip: samples left out of the metrics and the cost (default 49).
    """

    def __init__(self, data, friction: str | FrictionModel = "coulomb", asymmetric: bool = False, *,
                 clock: str = "true", substeps: int = 10, offset: bool | None = None, eps: float = 0.0,
                 pulses: str | None = None, tec: float | None = None, skip: int = SKIP,
                 saturation: float = SATURATION_V) -> None:
        self.data = d = _as_data(data)
        self.friction = friction if isinstance(friction, FrictionModel) else get_model(friction, asymmetric)
        if self.friction.is_dynamic:
            raise FrictionIdError(f"the EMPS simulator takes a static friction law, not {self.friction.label} (its "
                                  "states are not carried through the simulator's stages)")
        if clock not in CLOCKS:
            raise FrictionIdError(f"unknown clock '{clock}'; choose one of {', '.join(CLOCKS)}")
        if int(substeps) < 1:
            raise FrictionIdError(f"substeps must be at least 1, got {substeps}")
        pulses = pulses or ("linear" if clock == "benchmark" else "hold")
        if pulses not in ("linear", "hold"):
            raise FrictionIdError(f"unknown pulse input '{pulses}'; choose linear or hold")
        n = d.t.size
        if not 0 <= skip < n - 2:
            raise FrictionIdError(f"skip = {skip} leaves no samples of {n} to compare")
        self.clock, self.substeps, self.eps = clock, int(substeps), float(eps)
        self.skip, self.saturation = int(skip), float(saturation)
        self.offset = (not self.friction.asymmetric) if offset is None else bool(offset)
        self.names = ("M",) + self.friction.names + (("offset",) if self.offset else ())
        period = float((d.t[-1] - d.t[0]) / (n - 1))  # nominal period: the measured signals' step
        if clock == "benchmark":
            self.tec = float(tec if tec is not None else d.tec if d.tec is not None else d.t[9] - d.t[8])
            self.t = d.t[0] + self.tec * np.arange(n)
            self.periods = np.full(n - 1, self.tec)
            self.t_ctrl = self.tec
            self.qg = np.interp(self.t, d.t, d.qg)
            self.initial = (0.0, 0.0, 0.0, 0.0, 0.0)  # q, v, q(−1), qf(−1), u(0): at rest at q = 0
        else:
            self.tec = None
            self.t = d.t.copy()
            self.periods = np.diff(d.t)
            self.t_ctrl = period
            self.qg = d.qg.copy()
            q0 = d.qm[0]
            v0 = (-3.0 * d.qm[0] + 4.0 * d.qm[1] - d.qm[2]) / (d.t[2] - d.t[0])
            u0 = d.force[0] / d.gtau - (d.pulses[0] if d.pulses is not None else 0.0)
            self.initial = (q0, v0, q0 - v0 * period, q0 - 1.5 * v0 * period, u0)
        self.pulse_input = pulses if d.pulses is not None else None
        self.ext, self.pulse_at_samples = self._external(pulses)
        # measured references, as the benchmark script: Butterworth on qm, central differences
        fs = 1.0 / period
        self.q_ref = lowpass_position(d.qm[:, None], fs, CUTOFF_HZ, ORDER)[:, 0]
        self.v_ref = central_difference(self.q_ref, period)
        self.a_ref = central_difference(self.v_ref, period)
        w = slice(self.skip, None)
        self._norms = {key: float(np.linalg.norm(ref[w])) for key, ref in
                       zip(METRIC_KEYS, (self.q_ref, self.v_ref, self.a_ref, d.force))}

    # ------------------------------------------------------------------ inputs
    def _external(self, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """Pulse voltage at the half sub-steps of each period ((N−1, 2·substeps+1)) and at the samples."""
        d, n = self.data, self.t.size
        if d.pulses is None or not np.any(d.pulses):
            return np.zeros((0, 0)), np.zeros(n)
        frac = np.arange(2 * self.substeps + 1) / (2 * self.substeps)
        if mode == "linear":
            times = self.t[:-1, None] + self.periods[:, None] * frac[None, :]
            return np.interp(times, d.t, d.pulses), np.interp(self.t, d.t, d.pulses)
        held = np.interp(self.t, d.t, d.pulses) if self.clock == "benchmark" else d.pulses.copy()
        return np.repeat(held[:-1, None], frac.size, axis=1), held

    # -------------------------------------------------------------- parameters
    @property
    def k(self) -> int:
        """Number of parameters."""
        return len(self.names)

    def as_array(self, params) -> np.ndarray:
        """Parameters as (P, k): from a {name: value} dict, a (k,) or a (P, k) array."""
        if isinstance(params, dict):
            missing = [n for n in self.names if n not in params]
            if missing:
                raise FrictionIdError(f"parameters {missing} missing for the EMPS with "
                                      f"{self.friction.label} friction; expected {list(self.names)}")
            params = [float(params[n]) for n in self.names]
        p = np.atleast_2d(np.asarray(params, dtype=float))
        if p.ndim != 2 or p.shape[1] != self.k:
            raise FrictionIdError(f"the EMPS with {self.friction.label} friction takes {self.k} parameters "
                                  f"{list(self.names)}, got shape {np.shape(params)}")
        return np.ascontiguousarray(p)

    # -------------------------------------------------------------- simulation
    def _run(self, p: np.ndarray, full: bool):
        P, n = p.shape[0], self.t.size
        nf = len(self.friction.names)
        theta_t = p[:, 1 : 1 + nf].T
        off = p[:, -1] if self.offset else np.zeros(P)
        out_q = np.empty((P, n))
        shape = (P, n) if full else (0, 0)
        out_v, out_a, out_u = np.empty(shape), np.empty(shape), np.empty(shape)
        d = self.data
        simulate_chunk = _simulation_kernel(self.friction.name)

        def run(lo: int, hi: int) -> None:
            rows = slice(lo, hi) if full else slice(0, 0)
            simulate_chunk(self.friction.asymmetric, self.eps, np.ascontiguousarray(theta_t[:, lo:hi]),
                            p[lo:hi, 0].copy(), off[lo:hi].copy(), d.gtau, d.kp, d.kv, self.saturation,
                            self.periods, self.t_ctrl, self.qg, self.ext, self.pulse_at_samples, *self.initial,
                            self.substeps, full, out_q[lo:hi], out_v[rows], out_a[rows], out_u[rows])

        with np.errstate(all="ignore"):
            run_chunks(run, P, min_items=MIN_CHUNK_MEMBERS)
        return out_q, out_v, out_a, out_u

    def simulate(self, params) -> EmpsSimulation:
        """Simulate one parameter set ({name: value} or (k,)) or a population (P, k)."""
        single = isinstance(params, dict) or np.ndim(params) == 1
        p = self.as_array(params)
        q, v, a, u = self._run(p, full=True)
        force = self.data.gtau * (u + self.pulse_at_samples[None, :])
        w = slice(self.skip, None)
        metrics = {}
        for key, sim, ref in zip(METRIC_KEYS, (q, v, a, force), (self.q_ref, self.v_ref, self.a_ref, self.data.force)):
            err = 100.0 * np.linalg.norm(sim[:, w] - ref[None, w], axis=1) / self._norms[key]
            metrics[key] = float(err[0]) if single else err
        pick = (lambda x: x[0]) if single else (lambda x: x)
        settings = {"clock": self.clock, "substeps": self.substeps, "pulses": self.pulse_input,
                    "tec": self.tec, "skip": self.skip, "friction": self.friction.name,
                    "asymmetric": self.friction.asymmetric}
        return EmpsSimulation(self.clock, self.t, pick(q), pick(v), pick(a), pick(u), pick(force), metrics,
                              self.names, pick(p), settings)

    def position(self, params) -> np.ndarray:
        """Simulated position only, (P, N) m (the fast path)."""
        return self._run(self.as_array(params), full=False)[0]

    def position_residuals(self, params) -> np.ndarray:
        """Measured − simulated position over the compared samples: (k,) → (n,), or (P, k) → (P, n), m."""
        single = np.ndim(params) == 1 and not isinstance(params, dict)
        r = self.q_ref[None, self.skip :] - self.position(params)[:, self.skip :]
        return r[0] if single else r

    def position_cost(self, params) -> np.ndarray:
        """Sum of squared position errors, m², for a population (P, k) → (P,) (NaN if diverged).

        relative error (%) = 100·sqrt(cost)/‖q_ref‖; see :meth:`position_relerr`."""
        r = self.position_residuals(self.as_array(params))
        return np.einsum("pn,pn->p", r, r)

    def position_relerr(self, params) -> np.ndarray:
        """Position relative error, %, for a population (P, k) → (P,)."""
        return 100.0 * np.sqrt(self.position_cost(params)) / self._norms["position_relerr_pct"]


def simulate_emps(data, params, friction: str | FrictionModel = "coulomb", asymmetric: bool = False, *,
                  clock: str = "true", **options) -> EmpsSimulation:
    """Simulate the EMPS closed loop for ``params`` (dict, (k,) or (P, k)); see :class:`EmpsSimulator`."""
    return EmpsSimulator(data, friction, asymmetric, clock=clock, **options).simulate(params)


def simulate_identification(data, result: dict, *, clock: str = "true", substeps: int = 10,
                            tec: float | None = None) -> EmpsSimulation:
    """Simulate the parameters of a ``frictionid identify`` result (its JSON as a dict) with the
    simulator's ``clock``, ``substeps`` and ``tec`` (:class:`EmpsSimulator`)."""
    try:
        system, friction, values = result["system"], result["friction"], result["params"]
        asym = bool(result["asymmetric"])
    except (KeyError, TypeError) as exc:
        raise FrictionIdError(f"parameter file lacks {exc}; "
                              "expected the JSON written by 'frictionid identify'") from None
    if system != "emps":
        raise FrictionIdError(f"only the EMPS can be simulated; the parameters are for system '{system}'")
    sim = EmpsSimulator(data, friction, asym, clock=clock, offset="offset" in values,
                        substeps=substeps, tec=tec)
    return sim.simulate(values)
