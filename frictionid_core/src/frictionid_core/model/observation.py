"""Decimated observation data shared by every inverse dynamic model.

An inverse dynamic model contributes *rigid* columns (terms linear in the rigid-body
parameters, e.g. q̈ for a mass); friction contributes columns built from the velocity. Every
column that depends on measured signals only (q̈, q̇, sign(q̇), their asymmetric masks, 1) is
computed at full rate and then decimated with the torque (docs/reference.md#emps-decimation). Terms of
nonlinear friction models that depend on searched parameters (the Stribeck/Threlfall dip) are
evaluated at the decimated velocity.

Rows are stacked joint-major: rows ``j·Nd … (j+1)·Nd − 1`` belong to joint j.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.parallel import run_chunks
from frictionid_core.preprocess import (
    Prepared,
    Preprocessing,
    decimate,
    decimation_indices,
    thinned_rows,
    travel_rows,
    window_means,
)

VELOCITY_COLUMNS = ("V", "S", "V_pos", "S_pos", "V_neg", "S_neg", "one")
# Joints are decimated in parallel threads when each has at least this many values to filter.
PARALLEL_JOINT_VALUES = 2_000_000


@dataclass
class Observation:
    """Identification data after decimation.

    Attributes:
        joints: joint names (J).
        y: measured torque/force rows, (J·Nd,).
        rigid: rigid-body columns, (J·Nd, R).
        rigid_names: names of the rigid-body parameters (R).
        velocity: decimated velocity, (Nd, J).
        columns: per joint, decimated velocity columns: V = q̇, S = sign(q̇), and the
            asymmetric V_pos = q̇·O⁺, S_pos = sign(q̇)·O⁺, V_neg, S_neg, and the constant
            ``one`` (decimated like the others: the anti-alias filter's DC gain is 0.989); each (Nd,).
        t: decimated sample times, s (Nd,).
        preprocessing: the resolved settings that made it.
        report: what the data said about the pre-processing (see
            :func:`frictionid_core.preprocess.preprocess`; the ``_``-keys are not for JSON).
        notes: what was done to the stamps (resampling).
        used: (J·Nd,) False on the rows left out (slow rows, zeroed everywhere).
        sampled: the same rows taken at the analysis instants *without* the anti-alias filter:
            ``y`` the recorded effort, the columns the model's own (sign steps kept); what
            fit metrics compare (None without decimation, where they are these rows, and inside
            a sampled observation).
        coupling: None when the rows are joint torques; under a drive whose friction acts on the
            motors (rows = referred motor torques u = C⁻ᵀ·τ, ``joints`` = its motor names) the
            drive's C (J, J), which :meth:`joint_torques` maps back with.
        data_joints: the data joints behind the rows, in row order (default: ``joints``).
        weight: (Nd,) the weight of each instant when the pre-processing thins the rows
            (:func:`~frictionid_core.preprocess.thinned_rows`): ``y``, ``rigid`` and ``columns``
            hold weighted rows, a dip term multiplies its column by it; None: every weight 1.
        full: the same instants with every row, the slow ones too (:func:`keep_all_rows`: what
            the all-rows metrics and the dynamic friction laws use); None when not kept (the fit
            rows of a static law's observation with sampled rows).
        moving: in a ``full`` observation, (J·Nd,) the rows the observation it was kept from
            uses (the moving rows); None elsewhere.
        path, shift: (Nd, J) each row joint's travel from the previous instant, for a dynamic
            law's states (:mod:`frictionid_core.preprocess.travel`): the distance travelled along
            its denoised filtered position, and the net displacement (0 at the first instant);
            None: the states take the travel from the velocity.
        joint_weight: (J,) the weight of each row joint in a weighted least-squares fit
            (:meth:`joint_weighted`): ``y``, ``rigid`` and ``columns`` of joint j hold its rows
            times ``joint_weight[j]``; ``sampled`` and ``full`` stay unweighted (what metrics
            compare, in N·m or N). None: every joint 1.
    """

    joints: list[str]
    y: np.ndarray
    rigid: np.ndarray
    rigid_names: list[str]
    velocity: np.ndarray
    columns: list[dict[str, np.ndarray]]
    t: np.ndarray
    preprocessing: Preprocessing
    report: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    used: np.ndarray | None = None
    sampled: Observation | None = None
    coupling: np.ndarray | None = None
    data_joints: list[str] | None = None
    weight: np.ndarray | None = None
    full: Observation | None = None
    moving: np.ndarray | None = None
    path: np.ndarray | None = None
    shift: np.ndarray | None = None
    joint_weight: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.used is None:
            self.used = np.ones(self.y.size, dtype=bool)

    @property
    def n_samples(self) -> int:
        """Decimated samples per joint (Nd)."""
        return self.velocity.shape[0]

    @property
    def metric(self) -> Observation:
        """The observation fit metrics are taken on: the sampled one (recorded effort), or this
        one (unweighted) under ``metric="filtered"`` (the decimated filtered effort of the EMPS
        benchmark)."""
        return self.unweighted() if self.preprocessing.metric == "filtered" or self.sampled is None else self.sampled

    def joint_weighted(self, weight: np.ndarray | None) -> Observation:
        """This observation with the rows of joint j (``y``, ``rigid``, ``columns``) weighted by
        ``weight[j]`` (J,) instead of its present weight; None: unweighted."""
        now = np.ones(len(self.joints)) if self.joint_weight is None else self.joint_weight
        new = np.ones(len(self.joints)) if weight is None else np.asarray(weight, dtype=float)
        if new.shape != now.shape or not np.all(np.isfinite(new) & (new > 0)):
            raise FrictionIdError(f"joint weights must be {now.size} positive finite numbers, got {new}")
        if np.array_equal(new, now):
            return self
        factor = new / now
        rows = np.repeat(factor, self.n_samples)
        return replace(self, y=self.y * rows, rigid=self.rigid * rows[:, None],
                       columns=[{k: v * f for k, v in c.items()} for c, f in zip(self.columns, factor)],
                       joint_weight=None if weight is None else new)

    def unweighted(self) -> Observation:
        """This observation without joint weights (:meth:`joint_weighted` None)."""
        return self if self.joint_weight is None else self.joint_weighted(None)

    @property
    def torque_joints(self) -> list[str]:
        """The joint of each block of :meth:`joint_torques` (the data joints)."""
        return list(self.data_joints or self.joints)

    def joint_torques(self, rows: np.ndarray) -> np.ndarray:
        """Joint torques τ = Cᵀ·u of torque rows (…, J·Nd) (``y`` or predictions), joint-major in
        :attr:`torque_joints` order; the rows themselves when they are joint torques."""
        if self.coupling is None:
            return rows
        u = rows.reshape(rows.shape[:-1] + (len(self.joints), self.n_samples))
        return np.einsum("mj,...mn->...jn", self.coupling, u).reshape(rows.shape)


def keep_all_rows(obs: Observation, fit_rows: bool = False) -> None:
    """Keep a copy of the rows of ``obs``'s metric observation (:attr:`Observation.metric`: its
    sampled one, or itself without) as they are now in its ``full`` — and with ``fit_rows`` of
    ``obs`` itself too (``obs.full``, whose ``sampled`` is ``obs.sampled.full``) — every row used,
    ``moving`` holding the used rows (the same array: rows left out later are not moving). Only
    the metric rows' by default: the all-rows metrics need them, a dynamic law every fit row."""
    def copy(o: Observation, sampled: Observation | None) -> Observation:
        return replace(o, y=o.y.copy(), rigid=o.rigid.copy(), velocity=o.velocity.copy(),
                       columns=[{k: c.copy() for k, c in cols.items()} for cols in o.columns],
                       used=np.ones(o.y.size, dtype=bool), sampled=sampled, full=None, moving=o.used)

    if obs.sampled is not None:
        obs.sampled.full = copy(obs.sampled, None)
    if fit_rows or obs.sampled is None:
        obs.full = copy(obs, obs.sampled.full if obs.sampled is not None else None)


def velocity_columns(qd: np.ndarray) -> np.ndarray:
    """(N, 7) full-rate columns in VELOCITY_COLUMNS order for one joint's velocity (N,)."""
    s = np.sign(qd)
    pos = (1.0 + s) / 2.0
    neg = (1.0 - s) / 2.0
    return np.column_stack([qd, s, qd * pos, s * pos, qd * neg, s * neg, np.ones_like(qd)])


def build_observation(prepared: Prepared, joints: list[str], rigid_full: np.ndarray,
                      rigid_names: list[str], settings: Preprocessing, stride: int = 1,
                      travel_noise: np.ndarray | None = None) -> Observation:
    """Decimate torque, rigid columns (J·N, R) and velocity columns in one pass per joint, and
    sample them at the same instants without the anti-alias filter (``sampled``).

    ``rigid_full`` rows are joint-major over the full-rate prepared samples (every
    ``stride``-th, aligned to the last: see :func:`~frictionid_core.preprocess.column_stride`);
    ``settings`` are resolved. With ``settings.thin`` > 1 the fit keeps the rows of
    :func:`~frictionid_core.preprocess.thinned_rows` (weighted; those coarser than the analysis
    decimation each the mean of the samples it stands for) and ``sampled`` one in ``thin``.
    """
    n, nj = prepared.qd.shape
    r = rigid_full.shape[1]
    kept = decimation_indices(n, settings.decimate)
    select, weight, level = thinned_rows(prepared.qd[kept], prepared.qdd[kept], 1.0 / prepared.dt, settings, joints)
    metric_rows = decimation_indices(n, settings.decimate * settings.thin)  # instants of kept, one in thin
    # {decimation: (its kept rows, their rows in that decimation)}, the instants aligned to the last
    sources = {}
    for L in np.unique(level):
        at = level == L
        step = L // settings.decimate
        sources[int(L)] = (at, decimation_indices(n, L).size - 1 - (kept.size - 1 - select[at]) // step)
    ns = rigid_full.shape[0] // nj  # rigid rows per joint: every stride-th sample, the last one kept
    metric_rigid = ns - 1 - (n - 1 - metric_rows) // stride
    parts: dict[str, list] = {k: [] for k in ("y", "velocity", "rigid", "columns")}
    raw: dict[str, list] = {k: [] for k in parts}

    def decimated(small: np.ndarray, rigid: np.ndarray, factor: int, rows: np.ndarray | None = None) -> np.ndarray:
        """[τ, q̇, rigid columns, velocity columns] decimated by ``factor`` (only ``rows`` of it): the
        analysis decimation's anti-alias filter, the means of the samples a thinned row stands for
        at a coarser one (:func:`~frictionid_core.preprocess.window_means`)."""
        reduce = decimate if factor == settings.decimate else window_means
        a, b = reduce(small, factor, rows=rows), reduce(rigid, factor, stride, rows)
        return np.column_stack([a[:, :2], b, a[:, 2:]])

    def joint_rows(j: int) -> tuple[np.ndarray, np.ndarray]:
        """(fit rows, metric rows) of joint j: [τ, q̇, rigid columns, velocity columns]."""
        small = np.column_stack([prepared.tau[:, j], prepared.qd[:, j], velocity_columns(prepared.qd[:, j])])
        rigid = rigid_full[j * ns : (j + 1) * ns]
        if settings.thin > 1:
            fit = np.empty((select.size, small.shape[1] + r))
            for L, (at, rows) in sources.items():
                fit[at] = decimated(small, rigid, L, rows)
            velocity = fit[:, 1].copy()  # the velocity itself is not weighted
            fit *= weight[:, None]
            fit[:, 1] = velocity
        else:
            fit = decimated(small, rigid, settings.decimate)
        return fit, np.column_stack([small[metric_rows, :2], rigid[metric_rigid], small[metric_rows, 2:]])

    # the joints in the threads the machine has free (the filters release the GIL)
    per_joint = [None] * nj

    def joints_from(lo: int, hi: int) -> None:
        for j in range(lo, hi):
            per_joint[j] = joint_rows(j)

    run_chunks(joints_from, nj, min_items=1 if n * (r + len(VELOCITY_COLUMNS) + 2) >= PARALLEL_JOINT_VALUES else nj)
    for fit, at in per_joint:
        for out, rows in ((parts, fit), (raw, at)):
            out["y"].append(rows[:, 0])
            out["velocity"].append(rows[:, 1])
            out["rigid"].append(rows[:, 2 : 2 + r])
            out["columns"].append(dict(zip(VELOCITY_COLUMNS, rows[:, 2 + r :].T)))
    per_joint.clear()  # the per-joint rows are in parts and raw now: free them

    def observation(p: dict, t: np.ndarray) -> Observation:
        return Observation(list(joints), np.concatenate(p["y"]), np.vstack(p["rigid"]), list(rigid_names),
                           np.column_stack(p["velocity"]), p["columns"], t, settings)

    obs = observation(parts, prepared.t[kept[select]])
    if settings.thin > 1:
        obs.weight = weight
    elif travel_noise is not None:
        obs.path, obs.shift = travel_rows(prepared.q, kept, travel_noise, prepared.qd, prepared.dt)
    # without decimation or thinning: the same rows
    obs.sampled = observation(raw, prepared.t[metric_rows]) if settings.decimate > 1 or settings.thin > 1 else None
    if obs.sampled is not None and obs.path is not None:  # the same instants
        obs.sampled.path, obs.sampled.shift = obs.path, obs.shift
    return obs


def concat_observations(observations: list[Observation]) -> Observation:
    """Observations of several sources (same joints, same pre-processing) stacked into one: joint
    j's rows of every source in turn, so rows stay joint-major; ``t`` restarts with each source.

    Generic over the fields: an array with J·Nd rows is joint-major, one with Nd rows is per
    sample, per-joint column dicts are joined column by column, notes are joined, the sampled
    observations are stacked alike, the first source's report is kept, and any other field (names,
    settings, …) must be equal in every observation.
    """
    first = observations[0]
    if len(observations) == 1:
        return first
    nj = len(first.joints)
    sizes = [o.n_samples for o in observations]
    parts = {}
    for f in fields(Observation):
        values = [getattr(o, f.name) for o in observations]
        if f.name == "report":
            parts[f.name] = values[0]
        elif f.name == "notes":
            parts[f.name] = [note for v in values for note in v]
        elif f.name in ("sampled", "full"):
            parts[f.name] = None if any(v is None for v in values) else concat_observations(values)
        elif isinstance(values[0], np.ndarray) and all(v.shape[0] == nj * n for v, n in zip(values, sizes)):
            parts[f.name] = np.concatenate([v[j * n : (j + 1) * n] for j in range(nj) for v, n in zip(values, sizes)])
        elif isinstance(values[0], np.ndarray) and all(v.shape[0] == n for v, n in zip(values, sizes)):
            parts[f.name] = np.concatenate(values)
        elif f.name == "columns":
            parts[f.name] = [{k: np.concatenate([v[j][k] for v in values]) for k in values[0][j]} for j in range(nj)]
        elif all(_equal(v, values[0]) for v in values[1:]):
            parts[f.name] = values[0]
        else:
            raise FrictionIdError(f"cannot stack the observations of several sources: their '{f.name}' differ")
    return Observation(**parts)


def _equal(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b))
    return a == b
