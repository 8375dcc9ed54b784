"""What a fit takes from each source (:func:`plan_fit`): the joints whose efforts it fits, the model
joints it holds still, and the joints whose logged signals it cannot use.

* **Rows.** The request's joints (default: every data joint) are the rows fitted where their motion
  excites their columns. A robot system also keeps the source's other model joints: their motion
  enters the fitted joints' dynamics.
* **Unexcited joints** (:func:`~frictionid_core.identification.joint_signals.unexcited_joints`): in a
  source where a joint's motion is noise or a tremble (its range below a hundredth of the fit's
  motion scale), its effort is not fitted and it gets no friction of its own (as a joint without a
  usable effort); a robot system keeps its logged motion in the other joints' dynamics — a tremble
  of a few mrad at several Hz shakes its neighbours (held still at its median position instead, the
  simulated arms of the accuracy corpus validated at 4.7 × the noise floor against 1.2 ×) — and holds
  it still at its logged (median) position only when it does not move at all (noise). Such a
  joint is named in a warning (:attr:`FitPlan.unexcited`). A joint swept in one source and
  trembling in the others (joint-wise sweeps) is fitted where it is swept. A joint that a fit finds
  never faster than its min speed (its velocity noise above its motion), beside joints that are, is
  planned again the same way (``slow``).
* **Held joints** (robot systems, :class:`Holds`): a model joint the source lacks stays still at a
  position (q̇ = q̈ = 0 in the regressor): ``hold`` names it with its position (a logged column of
  it is then not used), ``hold_missing`` holds every absent one at 0 (at the drive's
  ``position_offset`` when the drive lists it). The robot's base parameters are then those of
  that regressor (:func:`~frictionid_core.systems.robot.restricted_system`).
* **No usable effort** (:func:`~frictionid_core.identification.joint_signals.no_effort_joints`): a
  joint that moves while its effort carries no information by its own signal-to-noise ratio (or
  reads one value most of the time) is left out of the rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.identification.joint_signals import moving_joints, no_effort_joints, unexcited_joints
from frictionid_core.preprocess import MOVING_FACTOR
from frictionid_core.systems import System, restricted_system
from frictionid_core.timeseries import JointSeries


@dataclass(frozen=True)
class Holds:
    """How a robot fit treats model joints the data lack (positions in rad or m).

    Attributes:
        values: {model joint: position} held in every source (a logged column of it is not used).
        missing: hold every other model joint absent from a source (at ``previous``'s value, the
            drive's ``position_offset``, or 0).
        previous: {model joint: position} of a former fit (a result's ``held_joints``): where
            such a joint is absent, it is held there.
    """

    values: dict[str, float] = field(default_factory=dict)
    missing: bool = False
    previous: dict[str, float] = field(default_factory=dict)

    def resolve(self, system: System, present: list[str]) -> dict[str, float]:
        """{model joint: position} held on data holding the model joints ``present``: the
        explicit holds, then each absent joint that ``previous`` or ``missing`` holds (the
        others stay missing: the system's joint check names them)."""
        held = dict(self.values)
        offsets = {}
        if system.drive is not None:
            offsets = dict(zip(system.drive.joints, system.drive.position_offset))
        for joint in system.joints if isinstance(system.joints, tuple) else ():
            if joint in present or joint in held:
                continue
            if joint in self.previous:
                held[joint] = float(self.previous[joint])
            elif self.missing:
                held[joint] = float(offsets.get(joint, 0.0))
        return held


@dataclass
class SourcePlan:
    """One source of a fit.

    Attributes:
        series: the source restricted to the data joints the fit uses (rows and, for a robot
            system, the other model joints whose motion it needs).
        rows: the data joints whose efforts are fitted.
        held: {model joint: position} held still.
        no_effort: {data joint: why} joints that move without a usable effort (not fitted).
        unexcited: {data joint: why} joints the fit would fit whose motion here does not excite
            their columns (not rows; a robot system keeps their motion unless it is noise).
    """

    series: JointSeries
    rows: list[str]
    held: dict[str, float]
    no_effort: dict[str, str]
    unexcited: dict[str, str] = field(default_factory=dict)


@dataclass
class FitPlan:
    """What a fit takes from its sources (:func:`plan_fit`).

    Attributes:
        system: the system fitted (a robot system restricted to the holds and rows).
        sources: one :class:`SourcePlan` per source.
        rows: the data joints fitted in any source, in order of appearance.
        held: {model joint: position} held still in every source (what ``system`` is restricted to).
        no_effort: {data joint: why} joints left out for want of a usable effort (any source).
        unexcited: the data joints not fitted in some source because their motion there does not
            excite their columns (in order of appearance).
    """

    system: System
    sources: list[SourcePlan]
    rows: list[str]
    held: dict[str, float]
    no_effort: dict[str, str]
    unexcited: list[str] = field(default_factory=list)

    def warnings(self) -> list[str]:
        """One line per source with joints not fitted there: their motion does not excite their
        columns, or they lack a usable effort."""
        out = []
        robot = self.system.robot is not None
        for sp in self.sources:
            if sp.unexcited:
                whys = "; ".join(f"{j}: {why}" for j, why in sp.unexcited.items())
                named = ", ".join(sp.unexcited)
                done = "left out of its rows"
                if robot:
                    models = dict(zip(sp.unexcited, self.system.model_joints(list(sp.unexcited))))
                    at = ", ".join(f"{j} = {sp.held[m]:.4g}" for j, m in models.items() if m in sp.held)
                    kept = ", ".join(j for j, m in models.items() if m not in sp.held)
                    parts = ["their efforts not fitted, no friction identified for them"]
                    if kept:
                        parts.append(f"the motion of {kept} still enters the other joints' dynamics")
                    if at:
                        parts.append(f"held still at their logged positions ({at}), as --hold would hold them")
                    done = "; ".join(parts)
                out.append(f"{sp.series.source}: {named} do not move enough to excite their columns ({whys}): {done} "
                           "(their rows would sit at one configuration, with a friction that never slides); record "
                           "them moving to identify them")
            if sp.no_effort:
                whys = "; ".join(f"{j}: {why}" for j, why in sp.no_effort.items())
                out.append(f"{sp.series.source}: no usable effort from {', '.join(sp.no_effort)} ({whys}): left out "
                           "of the fit, no friction identified for them (their motion still enters the other "
                           "joints' dynamics)")
        return out

    def notes(self) -> list[str]:
        """What was held, per source, when some joint is held in one source only."""
        return [f"{sp.series.source}: held still {sp.held}" for sp in self.sources
                if set(sp.held) != set(self.held)]


def plan_fit(sources: list[JointSeries], system: System, rows: list[str] | tuple[str, ...] | None = None,
             holds: Holds | None = None, structure: dict[str, float] | None = None,
             judge_effort: bool = True, slow: dict[str, str] | None = None) -> FitPlan:
    """The plan of a fit of ``system`` on ``sources`` (see the module doc): ``rows`` the data
    joints to fit (None: every data joint), ``holds`` the held joints (robot systems);
    ``structure``: the held joints the robot system is restricted to (default: those held in
    every source; a result's ``held_joints`` when its parameters are reloaded); ``judge_effort``:
    judge each joint's signals — hold the joints whose motion does not excite their columns, leave
    out those without a usable effort (False: fit every one of ``rows`` that moves, as a
    cross-test of a result does); ``slow``: {data joint: why} joints that never move faster than their
    min speed (found by a fit of this plan), not fitted either (unexcited: no friction slides on them).

    Raises InputError naming the source when a requested joint is in none of them, a source has
    no joint to fit that moves enough or has a usable effort, or a joint asked for by name is
    excited in no source."""
    holds = holds or Holds()
    robot = system.robot is not None
    wanted = None if rows is None else list(rows)
    if wanted is not None:
        absent = [j for j in wanted if not any(j in s.joints for s in sources)]
        if absent:
            raise InputError(f"joint(s) {absent} in none of the sources "
                             f"({'; '.join(f'{s.source}: {list(s.joints)}' for s in sources)})")
    kept = [_kept_joints(s, system, wanted, holds, robot) for s in sources]
    kinds = _joint_kinds(system, sources)
    ranges = [_joint_side_ranges(s.select(keep) if keep != list(s.joints) else s, system)
              for s, keep in zip(sources, kept)]
    scale: dict[str, float] = {}
    for keep, r in zip(kept, ranges):
        for j, value in zip(keep, r):
            scale[kinds.get(j, "revolute")] = max(scale.get(kinds.get(j, "revolute"), 0.0), float(value))
    excitation = (scale, kinds) if judge_effort else None
    plans = [_source_plan(s, system, wanted, holds, robot, keep, r, excitation, slow or {})
             for s, keep, r in zip(sources, kept, ranges)]
    union = list(dict.fromkeys(j for sp in plans for j in sp.rows))
    if wanted is not None:
        union = [j for j in wanted if j in union]
    common = {j: v for j, v in plans[0].held.items() if all(sp.held.get(j) == v for sp in plans[1:])}
    held = common if structure is None else dict(structure)
    if robot:
        system = restricted_system(system, held, system.model_joints(union))
    no_effort = {j: why for sp in plans for j, why in sp.no_effort.items()}
    logged = dict.fromkeys(j for s in sources for j in s.joints)
    unexcited = [j for j in logged if any(j in sp.unexcited for sp in plans)]
    if wanted is not None:  # asked for by name and excited nowhere: nothing of it to fit
        never = [j for j in wanted if j in unexcited and j not in union]
        if never:
            whys = "; ".join(f"{sp.series.source}: {j}: {sp.unexcited[j]}" for j in never for sp in plans
                             if j in sp.unexcited)
            raise InputError(f"joint(s) {never} asked for (--joints) but their motion excites their columns in no "
                             f"source ({whys}): record them moving, or leave them out of --joints")
    return FitPlan(system, plans, union, held, no_effort, unexcited)


def _kept_joints(s: JointSeries, system: System, wanted: list[str] | None, holds: Holds, robot: bool) -> list[str]:
    """The data joints of ``s`` the fit takes: those to fit in the request's order, then (robot
    systems) the other model joints of the log (not held by ``holds``, within the drive's)."""
    mapped = dict(zip(s.joints, system.model_joints(list(s.joints))))
    if wanted is not None:
        both = [j for j in wanted if mapped.get(j) in holds.values]
        if both:
            raise InputError(f"joint(s) {both} are both fitted (--joints) and held still (--hold)")
    model = set(system.joints) if isinstance(system.joints, tuple) else set()
    drive = set(system.drive.joints) if system.drive is not None else None
    keep = [j for j in (s.joints if wanted is None else wanted) if j in mapped]
    if robot:
        keep = [j for j in keep if mapped[j] not in holds.values]  # held: its logged column is not used
        keep += [j for j in s.joints if j not in keep and mapped[j] in model and mapped[j] not in holds.values
                 and (drive is None or mapped[j] in drive)]
    return keep


def _source_plan(s: JointSeries, system: System, wanted: list[str] | None, holds: Holds, robot: bool,
                 keep: list[str], ranges: np.ndarray, excitation: tuple[dict, dict] | None,
                 slow: dict[str, str]) -> SourcePlan:
    """The plan of source ``s``: ``keep`` the joints the fit takes from it (:func:`_kept_joints`),
    ``ranges`` their joint-side ranges; ``excitation`` (the fit's motion scale by kind, the joints'
    kinds) judges which joints excite their columns, and their efforts (None: every joint of
    ``keep`` used as it is, as a cross-test of a result does); ``slow`` (:func:`plan_fit`) are unexcited."""
    mapped = dict(zip(s.joints, system.model_joints(list(s.joints))))
    candidates = [j for j in keep if wanted is None or j in wanted]
    if not candidates:
        raise InputError(f"{s.source}: none of the joints to fit {wanted} (data joints: {list(s.joints)})")
    series = s if keep == list(s.joints) else s.select(keep)
    unexcited = {}
    if excitation is not None:
        scale, kinds = excitation
        unexcited = unexcited_joints(series, keep, ranges, scale, kinds)
        unexcited.update({j: why for j, why in slow.items() if j in candidates and j not in unexcited})
        if all(j in unexcited for j in candidates):
            _refuse_still(s.source, {j: unexcited[j] for j in candidates})
    fitted = [j for j in candidates if j not in unexcited]
    no_effort = no_effort_joints(series, fitted) if excitation is not None else {}
    rows = [j for j in fitted if j not in no_effort]
    if not rows:
        raise InputError(f"{s.source}: no joint to fit with a usable effort (joints {fitted}; "
                         + "; ".join(f"{j}: {why}" for j, why in no_effort.items()) + ")")
    held = {}
    if robot:
        moving = dict(zip(series.joints, moving_joints(series)))
        still = [j for j in series.joints if not moving[j] and (j not in candidates or j in unexcited)]
        if still:
            held = {mapped[j]: float(np.median(series.position[:, series.joints.index(j)])) for j in still}
            series = series.select([j for j in series.joints if j not in still])
        held.update(holds.resolve(system, [mapped[j] for j in series.joints] + list(held)))
    elif unexcited:
        series = series.select([j for j in series.joints if j not in unexcited])
    system.check_joints(list(series.joints), s.source, held)
    return SourcePlan(series, rows, held, no_effort, {j: why for j, why in unexcited.items() if j in candidates})


def _refuse_still(source: str, whys: dict[str, str]) -> None:
    """InputError: no joint to fit in ``source`` excites its columns (``whys``: each one's reason)."""
    detail = "; ".join(f"{j}: {why}" for j, why in whys.items())
    if all(why.startswith("motion is noise") for why in whys.values()):
        raise InputError(f"{source}: no joint moves more than {MOVING_FACTOR:g}× its position noise ({detail}): "
                         "nothing to identify; record the joints moving")
    raise InputError(f"{source}: no joint to fit moves enough to excite its columns ({detail}): record the joints "
                     "moving")


def _joint_kinds(system: System, sources: list[JointSeries]) -> dict[str, str]:
    """{data joint: ``revolute`` or ``prismatic``} (a robot model's joint types; other systems: every
    joint revolute, one kind)."""
    if system.robot is None:
        return {}
    prismatic = set(system.robot.model.prismatic)
    names = list(dict.fromkeys(j for s in sources for j in s.joints))
    return {j: "prismatic" if m in prismatic else "revolute" for j, m in zip(names, system.model_joints(names))}


def _joint_side_ranges(series: JointSeries, system: System) -> np.ndarray:
    """(J,) each joint's range on the joint side: a motor-side drive's motor angles over each
    motor's own gear ratio."""
    ranges = np.ptp(series.position, axis=0) if len(series.t) else np.zeros(len(series.joints))
    drive = system.drive
    if drive is None or drive.side != "motor":
        return ranges
    ratio = dict(zip(drive.joints, np.abs(drive.gear_ratio)))
    return ranges / np.array([ratio.get(m, 1.0) for m in system.model_joints(list(series.joints))])
