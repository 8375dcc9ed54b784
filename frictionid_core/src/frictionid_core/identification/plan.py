"""What a fit takes from each source (:func:`plan_fit`): the joints whose efforts it fits, the model
joints it holds still, and the joints whose logged effort is unusable.

* **Rows.** The request's joints (default: every data joint) are the rows fitted. A robot system
  also keeps the source's other model joints: their motion enters the fitted joints' dynamics; one
  that does not move (range within MOVING_FACTOR × its position noise) is held still at its
  logged (median) position, so that its noise makes no columns of its own.
* **Held joints** (robot systems, :class:`Holds`): a model joint the source lacks stays still at a
  position (q̇ = q̈ = 0 in the regressor): ``hold`` names it with its position (a logged column of
  it is then not used), ``hold_missing`` holds every absent one at 0 (at the drive's
  ``position_offset`` when the drive lists it). The robot's base parameters are then those of
  that regressor (:func:`~frictionid_core.systems.robot.restricted_system`).
* **No usable effort** (:func:`no_effort_joints`): a joint that moves while its effort stays a
  sliver of the other joints' (or one value most of the time) is left out of the rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.preprocess import MOVING_FACTOR, noise_density
from frictionid_core.systems import System, restricted_system
from frictionid_core.timeseries import JointSeries

# A moving joint's effort is unusable when its spread (σ over the samples where it moves) is below
# this share of the largest spread among the source's other joints: a live joint of a real arm
# stays above ~2 % of the shoulder's even at the wrist (7-DOF arms: 1/60 … 1/30); a channel that
# reports nothing (noise, round-off) sits near 0.3 % (TIAGo arm_5…7: 0.2–0.4 %).
NO_EFFORT_SHARE = 0.01
# … or when one and the same value makes up at least this share of those samples (a channel
# reporting 0, or a constant).
STUCK_SHARE = 0.5
# A sample moves when |q̇| (central difference) exceeds this share of the joint's top speed (99th percentile).
MOVING_SPEED_SHARE = 0.05


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
    """

    series: JointSeries
    rows: list[str]
    held: dict[str, float]
    no_effort: dict[str, str]


@dataclass
class FitPlan:
    """What a fit takes from its sources (:func:`plan_fit`).

    Attributes:
        system: the system fitted (a robot system restricted to the holds and rows).
        sources: one :class:`SourcePlan` per source.
        rows: the data joints fitted in any source, in order of appearance.
        held: {model joint: position} held still in every source (what ``system`` is restricted to).
        no_effort: {data joint: why} joints left out for want of a usable effort (any source).
    """

    system: System
    sources: list[SourcePlan]
    rows: list[str]
    held: dict[str, float]
    no_effort: dict[str, str]

    def warnings(self) -> list[str]:
        """One line per source with joints left out for want of a usable effort."""
        out = []
        for sp in self.sources:
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
             judge_effort: bool = True) -> FitPlan:
    """The plan of a fit of ``system`` on ``sources`` (see the module doc): ``rows`` the data
    joints to fit (None: every data joint), ``holds`` the held joints (robot systems);
    ``structure``: the held joints the robot system is restricted to (default: those held in
    every source; a result's ``held_joints`` when its parameters are reloaded); ``judge_effort``:
    leave out the joints without a usable effort (False: fit every one of ``rows``, as a
    cross-test of a result does).

    Raises InputError naming the source when a requested joint is in none of them, or a source
    has no joint with a usable effort to fit."""
    holds = holds or Holds()
    robot = system.robot is not None
    wanted = None if rows is None else list(rows)
    if wanted is not None:
        absent = [j for j in wanted if not any(j in s.joints for s in sources)]
        if absent:
            raise InputError(f"joint(s) {absent} in none of the sources "
                             f"({'; '.join(f'{s.source}: {list(s.joints)}' for s in sources)})")
    plans = []
    for s in sources:
        plans.append(_source_plan(s, system, wanted, holds, robot, judge_effort))
    union = list(dict.fromkeys(j for sp in plans for j in sp.rows))
    if wanted is not None:
        union = [j for j in wanted if j in union]
    common = {j: v for j, v in plans[0].held.items() if all(sp.held.get(j) == v for sp in plans[1:])}
    held = common if structure is None else dict(structure)
    if robot:
        system = restricted_system(system, held, system.model_joints(union))
    no_effort = {j: why for sp in plans for j, why in sp.no_effort.items()}
    return FitPlan(system, plans, union, held, no_effort)


def _source_plan(s: JointSeries, system: System, wanted: list[str] | None, holds: Holds, robot: bool,
                 judge_effort: bool) -> SourcePlan:
    mapped = dict(zip(s.joints, system.model_joints(list(s.joints))))
    if wanted is not None:
        both = [j for j in wanted if mapped.get(j) in holds.values]
        if both:
            raise InputError(f"joint(s) {both} are both fitted (--joints) and held still (--hold)")
    model = set(system.joints) if isinstance(system.joints, tuple) else set()
    drive = set(system.drive.joints) if system.drive is not None else None
    # the joints to fit in the request's order, then (robot systems) the other model joints of the log
    keep = [j for j in (s.joints if wanted is None else wanted) if j in mapped]
    if robot:
        keep = [j for j in keep if mapped[j] not in holds.values]  # held: its logged column is not used
        keep += [j for j in s.joints if j not in keep and mapped[j] in model and mapped[j] not in holds.values
                 and (drive is None or mapped[j] in drive)]
    candidates = [j for j in keep if wanted is None or j in wanted]
    if not candidates:
        raise InputError(f"{s.source}: none of the joints to fit {wanted} (data joints: {list(s.joints)})")
    series = s if keep == list(s.joints) else s.select(keep)
    no_effort = no_effort_joints(series, candidates) if judge_effort else {}
    rows = [j for j in candidates if j not in no_effort]
    if not rows:
        raise InputError(f"{s.source}: no joint to fit with a usable effort (joints {candidates}; "
                         + "; ".join(f"{j}: {why}" for j, why in no_effort.items()) + ")")
    held = {}
    if robot:
        moving = dict(zip(series.joints, moving_joints(series)))
        still = [j for j in series.joints if j not in candidates and not moving[j]]
        if still:
            held = {mapped[j]: float(np.median(series.position[:, series.joints.index(j)])) for j in still}
            series = series.select([j for j in series.joints if j not in still])
        held.update(holds.resolve(system, [mapped[j] for j in series.joints] + list(held)))
    system.check_joints(list(series.joints), s.source, held)
    return SourcePlan(series, rows, held, no_effort)


def moving_joints(series: JointSeries) -> np.ndarray:
    """(J,) True for the joints of ``series`` whose range exceeds MOVING_FACTOR × their position
    noise (the pre-processing's rule of a moving joint)."""
    t, q = series.t, series.position
    if len(t) < 3:
        return np.ptp(q, axis=0) > 0
    fs = (len(t) - 1) / (t[-1] - t[0])
    return np.ptp(q, axis=0) > MOVING_FACTOR * np.sqrt(noise_density(q, fs) * fs / 2)


def no_effort_joints(series: JointSeries, candidates: list[str]) -> dict[str, str]:
    """{joint: why} of the ``candidates`` that move (range above MOVING_FACTOR × their position
    noise) while their effort is unusable: over the samples where the joint moves, its spread is
    below NO_EFFORT_SHARE of the largest spread among the other joints of ``series``, or one
    value makes up STUCK_SHARE of them."""
    t, q, e = series.t, series.position, series.effort
    if len(t) < 3:
        return {}
    moves = moving_joints(series)
    speed = np.abs(np.gradient(q, t, axis=0))
    spread_all = np.std(e, axis=0)
    out = {}
    for j in candidates:
        k = series.joints.index(j)
        top = np.percentile(speed[:, k], 99)
        moving = speed[:, k] > MOVING_SPEED_SHARE * top
        if not moves[k] or top <= 0 or moving.sum() < 10:
            continue  # a joint that does not move is not judged here
        x = e[moving, k]
        spread = float(np.std(x))
        others = float(np.max(np.delete(spread_all, k))) if len(series.joints) > 1 else 0.0
        stuck = float(np.max(np.unique(x, return_counts=True)[1]) / x.size)
        share = spread / others if others > 0 else np.inf
        if stuck >= STUCK_SHARE or share < NO_EFFORT_SHARE:
            reason = (f"{100 * stuck:.0f} % of its samples in motion read {_mode(x):.3g}" if stuck >= STUCK_SHARE
                      else f"its effort spread is {100 * share:.2g} % of the largest other joint's")
            out[j] = f"effort within {x.min():.3g} … {x.max():.3g} while it moves, {reason}"
    return out


def _mode(x: np.ndarray) -> float:
    values, counts = np.unique(x, return_counts=True)
    return float(values[np.argmax(counts)])
