"""The :class:`System` type (an inverse dynamic model without its friction) and :func:`observe`.

A system turns pre-processed signals into the full-rate rigid-body columns of the
observation matrix, says which data joints it models and how its data are pre-processed by
default (settings left None are chosen from the data: :mod:`frictionid_core.preprocess`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.friction import resets
from frictionid_core.model import Observation, build_observation, concat_observations, keep_all_rows
from frictionid_core.preprocess import (
    BRIEF_PERIODS,
    MIN_SPEED_SIGMAS,
    TRIM_PERIODS,
    Prepared,
    Preprocessing,
    TooFewSamples,
    brief_runs,
    choose_preprocessing,
    column_stride,
    cutoff_range,
    near_reversals,
    preprocess,
    resample_uniform,
    subsample,
    travel_noise,
)
from frictionid_core.timeseries import SEGMENT_GAP_PERIODS, SEGMENT_GAP_S, JointSeries

if TYPE_CHECKING:
    from frictionid_core.drive import Drive


# Values per chunk of the standard regressor (samples × joints × parameters: a few tens of MB).
_REGRESSOR_CHUNK_VALUES = 4_000_000
# A dynamic law's burn-in (:func:`burn_in_rows`) is skipped where it would take more than this
# share of its stretch's rows.
BURN_IN_SHARE = 0.1


@dataclass(frozen=True)
class RobotInfo:
    """The robot behind a robot system: its model and base parameters (of ``rows``, the
    regressor of the fit rows: the model's own, or its motor rows under a drive whose friction
    acts on the motors)."""

    model: object  # frictionid_core.robots.robot_model.RobotModel
    base: object  # frictionid_core.robots.base.BaseParameters
    rows: object = None  # frictionid_core.robots.motor_side.MotorSide, or None: joint rows

    def columns(self, p: Prepared, joints: list[str], rows: list[str] | None = None) -> np.ndarray:
        """The system's columns (:attr:`System.columns`): :meth:`base_columns` of ``p``."""
        return self.base_columns(p.q, p.qd, p.qdd, joints, rows)

    def base_columns(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, joints: list[str],
                     rows: list[str] | None = None) -> np.ndarray:
        """Base regressor rows (B·N, r) of the model joints ``rows`` (default ``joints``; B of
        them), joint-major in that order (with motor rows: row block k is the motor of
        ``rows[k]``); q, q̇, q̈ (N, J) hold every model joint in the order of ``joints`` (rad,
        rad/s, rad/s²)."""
        return self.regressor_columns(q, qd, qdd, joints, rows, self.base.reduce, self.base.rank)

    def regressor_columns(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, joints: list[str],
                          rows: list[str] | None, reduce: Callable[[np.ndarray], np.ndarray], width: int
                          ) -> np.ndarray:
        """Rows (B·N, ``width``) of ``reduce`` applied to the standard regressor of the fit rows
        ((n, nv, P) → (n, nv, width)), laid out as :meth:`base_columns`."""
        index = {j: k for k, j in enumerate(self.model.joints)}
        order = [index[j] for j in joints]
        blocks = order if rows is None else [index[j] for j in rows]
        n = q.shape[0]
        qm, qdm, qddm = (np.empty((n, self.model.nv)) for _ in range(3))
        qm[:, order], qdm[:, order], qddm[:, order] = q, qd, qdd
        out = np.empty((len(blocks) * n, width))
        # in chunks of samples: the standard regressor (N, nv, P) of a long log would take GBs
        chunk = max(64, _REGRESSOR_CHUNK_VALUES // (self.model.nv * len(self.base.names)))
        for k0 in range(0, n, chunk):
            k1 = min(n, k0 + chunk)
            if self.rows is None:  # the fit rows alone: joints held still elsewhere are locked (faster)
                Y = reduce(self.model.regressor(qm[k0:k1], qdm[k0:k1], qddm[k0:k1], rows=blocks))
                for b in range(len(blocks)):
                    out[b * n + k0 : b * n + k1] = Y[:, b, :]
                continue
            Y = reduce(self.rows.regressor(qm[k0:k1], qdm[k0:k1], qddm[k0:k1]))
            for b, m in enumerate(blocks):
                out[b * n + k0 : b * n + k1] = Y[:, m, :]
        return out


@dataclass(frozen=True)
class System:
    """An inverse dynamic model without its friction.

    Attributes:
        name: system id (``emps``, ``friction-only``, ``tx40``, ``urdf:PATH``, …).
        joints: the data joints it models: their count, the model's joint names (the data must
            hold each, through ``joint_map``), or None (any joints).
        columns: prepared signals + model joint names (data order) → rigid columns (J·N, R),
            joint-major rows. A robot system's also takes ``rows=``: the model joints whose rows
            to build (its signals then hold every model joint, those of ``rows`` among them).
        rigid_names: rigid-body parameter names (R), or with ``per_joint`` the base names of one
            joint's parameters (see :meth:`parameter_names`).
        rigid_bounds: default search bounds of those parameters (by base name with ``per_joint``).
        preprocessing: default pre-processing (None fields: chosen from the data).
        joint_map: {data joint name: model joint name} where they differ.
        robot: the robot model and base parameters of a robot system (None otherwise).
        drive: the transmission between the log and the model's joints (None: the log is on
            the joint side, in N·m and rad). With ``friction_on: motor`` the fit rows are the
            drive's motors (see :func:`observe`); a robot system's columns are then its motor rows.
        per_joint: each joint has its own ``rigid_names`` (``<joint>/J`` with several joints),
            its columns acting on its own rows only.
    """

    name: str
    joints: int | tuple[str, ...] | None
    columns: Callable[[Prepared, list[str]], np.ndarray]
    rigid_names: tuple[str, ...]
    rigid_bounds: dict[str, tuple[float, float]]
    preprocessing: Preprocessing
    joint_map: dict[str, str] = field(default_factory=dict)
    robot: RobotInfo | None = None
    per_joint: bool = False
    drive: Drive | None = None

    @property
    def motor_rows(self) -> bool:
        """True when the fit rows are the drive's motors (``friction_on: motor``)."""
        return self.drive is not None and self.drive.friction_on == "motor"

    def parameter_names(self, joints: list[str]) -> list[str]:
        """The rigid-body parameter names on data of ``joints`` (prefixed ``<joint>/`` when a
        per-joint system sees several joints, like the friction parameters)."""
        if not self.per_joint:
            return list(self.rigid_names)
        if len(joints) == 1:
            return list(self.rigid_names)
        return [f"{j}/{n}" for j in joints for n in self.rigid_names]

    def parameter_bounds(self, joints: list[str]) -> dict[str, tuple[float, float]]:
        """Default search bounds by the names of :meth:`parameter_names`."""
        names = self.parameter_names(joints)
        return {n: self.rigid_bounds[n.rsplit("/", 1)[-1]] for n in names if n.rsplit("/", 1)[-1] in self.rigid_bounds}

    def model_joints(self, joints: list[str]) -> list[str]:
        """The model's names of the data joints ``joints``."""
        return [self.joint_map.get(j, j) for j in joints]

    def check_joints(self, joints: list[str], source: str = "", held=()) -> None:
        """Raise InputError when the data joints ``joints`` (of ``source``) do not fit the system;
        the model joints ``held`` (held still) need no data."""
        where = f"{source}: " if source else ""
        if isinstance(self.joints, int):
            if len(joints) != self.joints:
                raise InputError(f"{where}system '{self.name}' models {self.joints} joint(s) but the data has "
                                 f"{len(joints)}: {list(joints)}; select with --joints")
            return
        if self.joints is None:
            return
        mapped = self.model_joints(joints)
        unknown = [j for j, m in zip(joints, mapped) if m not in self.joints]
        if unknown:
            hint = "" if self.joint_map else "; map names with --joint-map BAG=MODEL,…"
            raise InputError(f"{where}system '{self.name}': joint(s) {unknown} of the data are not in the model "
                             f"(model joints: {list(self.joints)}){hint}")
        dup = sorted({m for m in mapped if mapped.count(m) > 1})
        if dup:
            raise InputError(f"{where}system '{self.name}': several data joints map to model joint(s) {dup}")
        missing = [m for m in self.joints if m not in mapped and m not in held]
        if missing:
            hint = "; for joint 2 alone use --system tx40-j2" if self.name == "tx40" else ""
            raise InputError(f"{where}system '{self.name}' needs every joint of its model: missing from the data: "
                             f"{missing} (data joints: {list(joints)}); hold them still with --hold-missing (at 0, "
                             f"or at the drive's position_offset) or --hold JOINT=VALUE (rad or m){hint}")


def parse_joint_map(text: str | None) -> dict[str, str]:
    """``bag=model,bag2=model2`` (the ``--joint-map`` option) → {bag: model}."""
    out = {}
    for item in filter(None, (s.strip() for s in (text or "").split(","))):
        bag, sep, model = item.partition("=")
        if not sep or not bag.strip() or not model.strip():
            raise InputError(f"--joint-map item '{item}': expected BAG_NAME=MODEL_NAME[,…]")
        out[bag.strip()] = model.strip()
    return out


def observe(series: JointSeries, system: System, settings: Preprocessing | None = None, *,
            held: dict[str, float] | None = None, rows: list[str] | None = None, all_rows: bool = False
            ) -> Observation:
    """Pre-process ``series`` (unset settings chosen from its data) and build the decimated
    observation of ``system`` (``settings`` overrides the system's pre-processing), without its
    slow rows (see :func:`exclude_rows`).

    ``rows``: the data joints whose efforts are fitted (default: every data joint); a robot
    system's columns still see the motion of the others. ``held``: {model joint: position (rad
    or m)} of a robot system's joints the data lack, held still (q̇ = q̈ = 0) in its columns.
    ``all_rows``: keep the fit rows' copy with every row too
    (:func:`~frictionid_core.model.observation.keep_all_rows`: a dynamic law's model).

    A system with a drive first takes the log to the joint side (:meth:`Drive.to_joint_side`).
    With friction on the motors the rows are the referred motor torques u = C⁻ᵀ·τ, named after
    the motors, with the referred velocity w = C·q̇ as each row's friction velocity (ẇ = C·q̈);
    a motor's slow-row threshold is the largest of the joints it turns with.

    A series whose stamps have gaps (:meth:`JointSeries.segments`: a clock jump, a pause) is
    observed segment by segment, the settings resolved on the longest, and the rows stacked;
    segments too short to filter are left out, with a note.
    """
    drive = system.drive
    held = dict(held or {})
    if drive is not None:
        series = drive.to_joint_side(series, system.joint_map)
    joints = list(series.joints)
    system.check_joints(joints, series.source, held)
    rows = joints if rows is None else [j for j in joints if j in rows]
    if not rows:
        raise InputError(f"{series.source}: no joint's effort to fit (data joints {joints})")
    if system.motor_rows and (held or rows != joints):
        raise InputError(f"{series.source}: drive '{drive.name}' puts friction on the motors: the data must hold "
                         f"every joint it drives and fit them all (held: {sorted(held)}, not fitted: "
                         f"{[j for j in joints if j not in rows]})")
    if system.robot is None and rows != joints:  # independent joints: the others play no part
        series = series.select(rows)
    segments = series.segments()
    if len(segments) == 1:
        return _observe_segment(series, system, settings, held, rows, all_rows)
    return _observe_segments(series, segments, system, settings, held, rows, all_rows)


def _observe_segments(series: JointSeries, segments: list[JointSeries], system: System,
                      settings: Preprocessing | None, held: dict[str, float], rows: list[str],
                      all_rows: bool = False) -> Observation:
    """The observation of a series cut at the gaps of its stamps: each segment pre-processed
    alone (no filter runs across a gap) with the settings resolved on the longest, trimmed by
    TRIM_PERIODS / cut-off at each gap (the filters' transients, as the rule trims a record's
    ends), the observations stacked in time order; segments too short for that are left out
    (noted). What the data resolve is judged on the segments together (by the identification)."""
    longest = max(range(len(segments)), key=lambda k: len(segments[k]))
    resolved, chosen = choose_preprocessing(resample_uniform(segments[longest]), settings or system.preprocessing)
    seam = TRIM_PERIODS / cutoff_range(resolved.cutoff_hz)[0]
    observed, dropped = {}, []
    for k, segment in enumerate(segments):
        trims = {"trim_start_s": seam if k > 0 else resolved.trim_start_s,  # the log's ends: its own trims
                 "trim_end_s": seam if k < len(segments) - 1 else resolved.trim_end_s}
        try:
            observed[k] = _observe_segment(segment, system, replace(resolved, **trims), held, rows, all_rows)
        except TooFewSamples:
            if k == longest:
                raise
            dropped.append(segment)
            continue
        for o in _with_all_rows(observed[k]):
            o.preprocessing = resolved  # stacked under one setting; the seams' trims are noted
    obs = concat_observations([observed[k] for k in sorted(observed)])
    # the longest segment's report, with what the rule chose and the counts and extremes of them all
    report = dict(observed[longest].report)
    over = [o.report for o in observed.values()]
    report.update(chosen_from_data=chosen["chosen_from_data"], from_data=chosen["from_data"], fit_rows=int(obs.y.size),
                  slow_rows_excluded={j: sum(r["slow_rows_excluded"][j] for r in over)
                                      for j in report["slow_rows_excluded"]},
                  stick_rows={j: sum(r["stick_rows"][j] for r in over) for j in report["stick_rows"]},
                  reversal_rows={j: sum(r["reversal_rows"][j] for r in over) for j in report["reversal_rows"]},
                  brief_motion_rows={j: sum(r["brief_motion_rows"][j] for r in over)
                                     for j in report["brief_motion_rows"]},
                  resampled_reversal_rows={j: sum(r["resampled_reversal_rows"][j] for r in over)
                                           for j in report["resampled_reversal_rows"]},
                  burn_in_rows={j: sum(r["burn_in_rows"][j] for r in over) for j in report["burn_in_rows"]},
                  resampled_interval_s=max(r["resampled_interval_s"] for r in over),
                  reversal_acceleration={j: max(r["reversal_acceleration"][j] or 0.0 for r in over)
                                         for j in report["reversal_acceleration"]},
                  segments={"used": len(observed), "left_out": len(dropped), "trim_at_gaps_s": seam})
    for o in _with_all_rows(obs):
        o.report = report
    t0 = series.t[0]
    gaps = [(a.t[-1], b.t[0]) for a, b in zip(segments[:-1], segments[1:])]
    listed = ", ".join(f"{end - start:.4g} s after {start - t0:.6g} s" for start, end in gaps[:3])
    note = (f"{series.source}: the time stamps have {len(gaps)} gap(s) longer than {SEGMENT_GAP_PERIODS:g} sample "
            f"periods and {SEGMENT_GAP_S:g} s ({listed}{', …' if len(gaps) > 3 else ''}): {len(segments)} segments, "
            f"each filtered alone and trimmed by {seam:.3g} s at the gaps")
    if dropped:
        short = ", ".join(f"{s.t[0] - t0:.6g} s ({len(s)} samples, {s.t[-1] - s.t[0]:.4g} s)" for s in dropped[:5])
        note += (f"; {len(dropped)} too short for that left out (from {short}{', …' if len(dropped) > 5 else ''}, "
                 "s from the start)")
    obs.notes.insert(0, note)
    return obs


def _with_all_rows(obs: Observation) -> list[Observation]:
    """``obs``, its sampled observation and their copies with every row (those there are)."""
    out = [o for o in (obs, obs.sampled) if o is not None]
    return out + [o.full for o in out if o.full is not None]


def _observe_segment(series: JointSeries, system: System, settings: Preprocessing | None,
                     held: dict[str, float], rows: list[str], all_rows: bool = False) -> Observation:
    """:func:`observe` of a series without gaps, on the joint side; TooFewSamples names its source."""
    try:
        return _observe_gapless(series, system, settings, held, rows, all_rows)
    except TooFewSamples as exc:
        if str(exc).startswith(f"{series.source}:"):
            raise
        raise TooFewSamples(f"{series.source}: {exc}") from None


def _observe_gapless(series: JointSeries, system: System, settings: Preprocessing | None,
                     held: dict[str, float], rows: list[str], all_rows: bool = False) -> Observation:
    drive = system.drive
    joints = list(series.joints)
    prepared, resolved, report, notes = preprocess(series, settings or system.preprocessing)
    # a robot regressor is smooth in the filtered signals: computed at a fraction of the rate
    stride = column_stride(1.0 / prepared.dt, resolved) if system.robot is not None else 1
    signals = subsample(prepared, stride)
    if system.robot is not None:
        still = np.zeros((signals.q.shape[0], len(held)))
        signals = replace(signals, q=np.hstack([signals.q, still + np.array(list(held.values()))]),
                          qd=np.hstack([signals.qd, still]), qdd=np.hstack([signals.qdd, still]))
        rigid = system.columns(signals, system.model_joints(joints) + list(held), rows=system.model_joints(rows))
    else:
        rigid = system.columns(signals, system.model_joints(joints))
    report["rigid_column_stride"] = stride
    if rows != joints:
        pick = [joints.index(j) for j in rows]
        prepared = replace(prepared, q=prepared.q[:, pick], qd=prepared.qd[:, pick], qdd=prepared.qdd[:, pick],
                           tau=prepared.tau[:, pick])
    row_names = rows
    min_speed = np.array([resolved.min_speed[j] for j in rows])
    # a dynamic law's states start at rest below this: the min speed, or its noise rule when a smaller one is given
    rest_speed = np.maximum(min_speed, [MIN_SPEED_SIGMAS * (report["velocity_noise"].get(j) or 0.0) for j in rows])
    noise = travel_noise(report, resolved, rows, 1.0 / prepared.dt) if all_rows else None  # a dynamic law's travel
    if system.motor_rows:
        prepared = replace(prepared, q=drive.motor_velocity(prepared.q), qd=drive.motor_velocity(prepared.qd),
                           qdd=drive.motor_velocity(prepared.qdd), tau=drive.referred_motor_torque(prepared.tau))
        row_names = drive.motor_names()
        min_speed = np.array([min_speed[drive.C[m] != 0.0].max() for m in range(len(joints))])
        rest_speed = np.array([rest_speed[drive.C[m] != 0.0].max() for m in range(len(joints))])
        if noise is not None:  # a motor's position C·q: the joints' independent noises combined
            noise = np.sqrt((drive.C**2) @ noise**2)
    obs = build_observation(prepared, row_names, rigid, system.parameter_names(rows), resolved, stride, noise)
    obs.report, obs.notes = report, notes
    slow = np.abs(obs.velocity) < min_speed
    stick_speed = np.array([(resolved.stick_speed or {}).get(j, 0.0) for j in row_names])
    stick = ~slow & (np.abs(obs.velocity) < stick_speed)
    slow |= stick
    if system.motor_rows:
        obs.coupling, obs.data_joints = drive.C, joints
    brief_periods = resolved.brief_periods
    if brief_periods is None:  # a static law's (a dynamic law models small motions)
        brief_periods = 0.0 if all_rows else BRIEF_PERIODS
    brief = ~slow & (min_speed > 0.0) & brief_motion_rows(obs, slow, resolved, brief_periods)  # min speed 0: every row
    slow |= brief
    reversal = ~slow & reversal_rows(obs, slow, resolved)
    slow |= reversal
    smeared = ~slow & resampled_reversal_rows(obs, report["resampled_interval_s"])
    slow |= smeared
    for o in (obs, obs.sampled):
        if o is None:
            continue
        if system.motor_rows:
            o.coupling, o.data_joints = drive.C, joints
        o.report = report
    keep_all_rows(obs, all_rows)
    for o in (obs, obs.sampled):
        if o is not None:  # the sampled rows are instants of the fit's (all of them, or one in ``thin``)
            exclude_rows(o, slow if o is obs else slow[np.searchsorted(obs.t, o.t)])
    burn_in = np.zeros_like(slow)
    if all_rows:  # a dynamic law's states run through its burn-in, which neither cost nor metrics count
        burn_in = burn_in_rows(obs.full.velocity, obs.full.t, rest_speed)
        for o in (obs.full, obs.full.sampled):
            if o is not None:
                exclude_rows(o, burn_in if o is obs.full else burn_in[np.searchsorted(obs.t, o.t)],
                             keep_velocity=True)
    report["min_speed_rows"] = dict(zip(row_names, map(float, min_speed)))
    report["rest_speed_rows"] = dict(zip(row_names, map(float, rest_speed)))
    report["slow_rows_excluded"] = dict(zip(row_names, map(int, slow.sum(axis=0))))  # stick rows included
    report["stick_rows"] = dict(zip(row_names, map(int, stick.sum(axis=0))))
    report["reversal_rows"] = dict(zip(row_names, map(int, reversal.sum(axis=0))))
    report["brief_motion_rows"] = dict(zip(row_names, map(int, brief.sum(axis=0))))
    report["resampled_reversal_rows"] = dict(zip(row_names, map(int, smeared.sum(axis=0))))
    report["burn_in_rows"] = dict(zip(row_names, map(int, burn_in.sum(axis=0))))
    report["fit_rows"] = int(obs.y.size)  # every joint's rows (thinned: see Preprocessing.thin)
    return obs


def reversal_rows(obs: Observation, left_out: np.ndarray, settings: Preprocessing) -> np.ndarray:
    """(Nd, J) the rows of ``obs`` within ``settings.reversal_periods`` periods of their joint's
    cut-off of a change of its sign of motion (rows ``left_out`` count as at rest), in each stretch
    of ``obs`` alone (:func:`_per_stretch`)."""
    if not settings.reversal_periods:
        return np.zeros_like(left_out)
    return _per_stretch(obs, left_out, settings,
                        lambda v, t, fc: near_reversals(v, t, fc, settings.reversal_periods))


def _per_stretch(obs: Observation, left_out: np.ndarray, settings: Preprocessing, rows) -> np.ndarray:
    """``rows(velocity, t, cutoffs)`` (the rows ``left_out`` at rest) of each stretch of ``obs`` (a
    source or a segment: its stamps step back or jump by more than a thinned row's spacing) stacked; a
    motor's rows take the lowest cut-off of the joints it turns with, a joint without a cut-off of its
    own the highest."""
    given = settings.cutoff_hz
    joints = list(obs.data_joints or obs.joints)
    cutoffs = (np.array([given.get(j, max(given.values())) for j in joints]) if isinstance(given, dict)
               else np.full(len(joints), float(given)))
    if obs.coupling is not None:
        cutoffs = np.array([cutoffs[obs.coupling[m] != 0.0].min() for m in range(len(obs.joints))])
    velocity = np.where(left_out, 0.0, obs.velocity)
    step = np.diff(obs.t)
    rate = obs.report.get("analysis_rate_hz") if obs.report else None
    period = 1.0 / rate if rate else float(np.median(step)) if step.size else 1.0
    seam = (step <= 0.0) | (step > 1.5 * period * max(obs.preprocessing.thin, 1))
    cuts = np.concatenate([[0], np.flatnonzero(seam) + 1, [len(obs.t)]])
    return np.vstack([rows(velocity[a:b], obs.t[a:b], cutoffs) for a, b in zip(cuts[:-1], cuts[1:])])


def brief_motion_rows(obs: Observation, left_out: np.ndarray, settings: Preprocessing,
                      periods: float) -> np.ndarray:
    """(Nd, J) the rows of ``obs`` in a run of one sign of motion shorter than ``periods`` periods of
    their joint's cut-off (rows ``left_out`` count as at rest: :func:`~frictionid_core.preprocess.brief_runs`),
    in each stretch of ``obs`` alone (:func:`_per_stretch`)."""
    if not periods:
        return np.zeros_like(left_out)
    return _per_stretch(obs, left_out, settings, lambda v, t, fc: brief_runs(v, t, fc, periods))


def resampled_reversal_rows(obs: Observation, interval_s: float) -> np.ndarray:
    """(Nd, J) the rows of ``obs`` within ``interval_s`` (the longest stamp interval of a log
    resampled onto a uniform grid; 0: none) of a change of their joint's sign of motion, in time
    (the rows of a thinned observation are not evenly spaced), that instant taken midway between
    the two rows around it: their effort was interpolated across the step the friction takes
    there, so no friction law predicts them (on a 500 Hz log jittered by ±20 %, such rows sent
    de, pso and aco to a Stribeck dip of a row or two, δ at its bound). Each stretch of ``obs``
    alone, as :func:`reversal_rows`."""
    out = np.zeros(obs.velocity.shape, dtype=bool)
    if interval_s <= 0.0 or len(obs.t) < 2:
        return out
    t = obs.t
    step = np.diff(t)
    period = float(np.median(step))
    same = (step > 0.0) & (step <= 1.5 * period * max(obs.preprocessing.thin, 1))  # no seam between the rows
    for j in range(len(obs.joints)):
        sign = np.sign(obs.velocity[:, j])
        flips = np.flatnonzero((sign[1:] != sign[:-1]) & same)
        if not flips.size:
            continue
        at = 0.5 * (t[flips] + t[flips + 1])
        reach = interval_s + 0.5 * step[flips]  # the instant is known to half a row
        k = np.clip(np.searchsorted(at, t), 1, at.size - 1) if at.size > 1 else np.zeros(t.size, dtype=int)
        for near in (k - 1, k) if at.size > 1 else (k,):
            out[:, j] |= np.abs(t - at[near]) <= reach[near]
    return out


def burn_in_rows(velocity: np.ndarray, t: np.ndarray, rest_speed: np.ndarray) -> np.ndarray:
    """(Nd, J) a dynamic law's burn-in on rows of velocities (Nd, J) at times ``t`` (Nd,), s: each
    joint's rows from a restart of the states (:func:`~frictionid_core.friction.states.resets`) to
    its first reversal, the first row faster than its ``rest_speed`` (J,) against the way it first
    moved. The states start at their sliding value or at rest, a guess of a history the log does
    not hold; after a reversal they are the motion's. None where the reversal takes more than
    BURN_IN_SHARE of the stretch's rows (the guess is then the better evidence)."""
    out = np.zeros(velocity.shape, dtype=bool)
    starts = np.flatnonzero(resets(t))
    for a, b in zip(starts, np.append(starts[1:], t.size)):
        way = np.sign(velocity[a:b]) * (np.abs(velocity[a:b]) > rest_speed)  # (n, J): -1, 0, +1
        for j in range(velocity.shape[1]):
            moved = np.flatnonzero(way[:, j])
            if moved.size == 0:
                continue
            back = np.flatnonzero(way[:, j] == -way[moved[0], j])
            if back.size and back[0] <= BURN_IN_SHARE * (b - a):
                out[a : a + back[0], j] = True
    return out


def exclude_rows(obs: Observation, rows: np.ndarray, keep_velocity: bool = False) -> None:
    """Leave out the rows where ``rows`` (Nd, J) is True: zero their torque, every column and,
    unless ``keep_velocity`` (a dynamic law's states run through them), the velocity (they then
    add nothing to any least-squares cost) and mark them unused.

    Rows slower than the min speed go: near standstill and reversals the sign of a noisy
    velocity is unreliable, and one wrong sign is a 2·Fc outlier."""
    nd = obs.n_samples
    for j in range(len(obs.joints)):
        slow = rows[:, j]
        if not slow.any():
            continue
        index = j * nd + np.flatnonzero(slow)
        obs.y[index] = 0.0
        obs.rigid[index] = 0.0
        obs.used[index] = False
        if not keep_velocity:
            obs.velocity[slow, j] = 0.0
        for col in obs.columns[j].values():
            col[slow] = 0.0
