"""Honest warnings about an identification: one-line strings naming the problem and the way out.

Every check returns a list of messages (empty when all is well); the identification stores
them in ``result["warnings"]`` and the command line prints each as ``frictionid: warning: …``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from frictionid_core.identification.at_bound import bounds_reached
from frictionid_core.model import parameter_kind
from frictionid_core.preprocess import QDD_NOISE_SHARE_LIMIT

# A joint moves in one direction only when fewer than this share of its used rows go the other way.
ONE_DIRECTION_SHARE = 0.01
FRICTION_LEVELS = ("Fv", "Fc", "Fs")
INERTIAS = ("J", "M", "ZZ", "m", "Ia")  # masses and inertias (a rotor inertia Ia too)
_LISTED = 8  # names listed in a grouped message


def _listing(names: list[str]) -> str:
    more = f", … ({len(names)} in all)" if len(names) > _LISTED else ""
    return ", ".join(names[:_LISTED]) + more


def parameter_warnings(names: list[str], values: np.ndarray, std: dict[str, float], lower: np.ndarray,
                       upper: np.ndarray, physical: set[str] = frozenset(),
                       at_bound: Mapping[str, float] | None = None) -> list[str]:
    """Parameters at a search bound (``at_bound`` {name: bound}, default: those within
    :data:`~frictionid_core.identification.at_bound.AT_BOUND_SIGMAS` σ of ``lower`` or ``upper``),
    held at 0 by the sign constraint (``physical``: the names it holds), σ larger than the value,
    Fs < Fc, and negative friction levels, masses or inertias (each named). Parameters with lower
    == upper (fixed) are not judged."""
    out = []
    if at_bound is None:
        at_bound = bounds_reached(names, values, std, lower, upper)
    searched, held = [], []
    for name, lo, hi in zip(names, lower, upper):
        if name not in at_bound:
            continue
        b = at_bound[name]
        if b == 0.0 and name in physical:
            held.append(name)
        else:
            searched.append(f"{name} ({'lower' if abs(b - lo) <= abs(b - hi) else 'upper'} {b:.6g})")
    if searched:
        out.append(f"parameter(s) at a search bound: {_listing(searched)}: the optimum may lie beyond (no σ: not an "
                   "identified value); widen the bounds (--bounds NAME=LO:HI) or check the model")
    if held:
        out.append(f"parameter(s) held at 0, their physical bound (the data pull them below: torque the model does "
                   f"not explain, or too little motion): {_listing(held)}; --bounds NAME=LO:HI lets one go")
    value = dict(zip(names, map(float, values)))
    vague = [n for n in names if np.isfinite(std.get(n, np.nan)) and std[n] > abs(value[n])]
    if vague:
        out.append(f"σ > |value| for {len(vague)} parameter(s), not determined by these data: {_listing(vague)}")
    for name in names:
        kind = parameter_kind(name)
        base = name.rsplit("/", 1)[-1]
        if kind == "Fs":
            fc = name[: len(name) - len(base)] + "Fc" + base[2:]
            if fc in value and value[name] < value[fc]:
                out.append(f"{name} = {value[name]:.6g} < {fc} = {value[fc]:.6g}: static friction below the Coulomb "
                           "level (friction rising out of standstill, not dipping); if unexpected, compare with "
                           "--friction coulomb")
        if value[name] >= 0:
            continue
        if kind == "Fv":
            out.append(f"{name} = {value[name]:.6g} < 0: negative viscous friction is not physical (too little "
                       "speed range, or torque the model does not explain)")
        elif kind in FRICTION_LEVELS:
            out.append(f"{name} = {value[name]:.6g} < 0: a negative {'static' if kind == 'Fs' else 'Coulomb'} "
                       "friction level is not physical (an offset or torque the model does not explain)")
        elif kind in INERTIAS:
            out.append(f"{name} = {value[name]:.6g} < 0: negative {'mass' if kind in ('M', 'm') else 'inertia'} "
                       "is not physical (q̈ too small or noise-dominated, or a transmission the model lacks, e.g. a "
                       "coupled wrist: --drive)")
    return out


def acceleration_warnings(report: dict, cutoff_hz: float | dict[str, float], chosen: bool) -> list[str]:
    """Moving joints whose filtered q̈ is noise-dominated, each with the cut-off that keeps its
    position noise within QDD_NOISE_SHARE_LIMIT of its q̈ (``report``: of
    :func:`frictionid_core.preprocess.preprocess`; ``cutoff_hz``: one value or {joint: Hz};
    ``chosen``: the cut-off came from the data)."""
    out = []
    share = report.get("qdd_noise_share", {})
    clean = report.get("qdd_clean_cutoff_hz", {})
    for joint in report.get("moving_joints", []):
        s = share.get(joint)
        if s is None or s <= QDD_NOISE_SHARE_LIMIT:
            continue
        fc = cutoff_hz[joint] if isinstance(cutoff_hz, dict) else cutoff_hz
        head = (f"{joint}: the acceleration is noise-dominated ({100 * s:.3g} % of the filtered q̈ variance is "
                f"position noise at its {fc:.4g} Hz cut-off): inertia comes out low")
        if clean.get(joint):
            why = "the data chose too high a cut-off for this noise" if chosen else "lower the cut-off"
            out.append(head + f"; {why}: use --cutoff {joint}={_rounded_down(clean[joint])}")
        else:
            out.append(head + "; no cut-off keeps the noise below the motion: record larger or longer motion")
    return out


def _rounded_down(x: float, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits, rounded down: a cut-off named as the way out keeps the
    noise within the limit as printed (rounded up it could let a hair more in)."""
    scale = 10.0 ** (digits - 1 - int(np.floor(np.log10(x))))
    return f"{np.floor(x * scale) / scale:.{digits}g}"


# Words of the notes that report a repair of the data (each such note is a warning of the result).
REPAIR_WORDS = ("stamp", "broken row", "repeated row", "spike", "channel lag")


def stamp_warnings(notes: list[str]) -> list[str]:
    """The notes that say the data were repaired, with their counts: stamps repaired, samples
    resampled, the log cut into segments at gaps of its stamps, broken rows skipped, repeated rows
    dropped, spikes replaced, a lag of the velocity or effort removed."""
    return [n for n in notes if any(word in n for word in REPAIR_WORDS)]


def direction_problems(obs, names: list[str]) -> tuple[dict[str, str], list[str]]:
    """(errors, warnings): errors {joint: message} for joints that never move on the used rows of ``obs``,
    warnings for joints that move in one direction only, given the model's free parameter
    ``names``: then a constant offset and the Coulomb level (or the other branch of an asymmetric
    law) cannot be told apart, and the fit holds one of them (identifiability)."""
    errors, warnings = {}, []
    nd, nj = obs.n_samples, len(obs.joints)
    for j, joint in enumerate(obs.joints):
        prefix = f"{joint}/" if nj > 1 else ""
        used = obs.used[j * nd : (j + 1) * nd]
        v = obs.velocity[used, j]
        if not np.any(v):  # no used row, or none that moves (a noise-free log of a joint at rest)
            speed = obs.report.get("min_speed_rows", {}).get(joint, np.nan)
            errors[joint] = (f"{joint} never moves faster than its min speed {speed:.3g}: nothing to identify its "
                             "friction from; record it moving (back and forth), lower --min-speed, or leave it out of "
                             "the fitted joints (--joints without it; a robot model still uses its logged position)")
            continue
        pos, neg = int(np.count_nonzero(v > 0)), int(np.count_nonzero(v < 0))
        minority = min(pos, neg)
        if minority >= ONE_DIRECTION_SHARE * v.size:
            continue
        where = (f"{joint} moves in one direction only ({minority} of {v.size} used rows go the "
                 f"{'negative' if pos >= neg else 'positive'} way)")
        if prefix + "offset" in names and prefix + "Fc" in names:
            msg = (f"{where}: its offset and Coulomb friction cannot be told apart; fix one, e.g. "
                   f"--fix {prefix}offset=0")
        else:
            branch = "neg" if pos >= neg else "pos"
            lost = [n for n in names if n.startswith(prefix) and n.endswith(f"_{branch}")]
            if not lost:
                continue
            msg = f"{where}: {', '.join(lost)} are not identifiable; use a symmetric friction law (no --asymmetric)"
        warnings.append(msg)  # the fit drops the direction the data cannot resolve (identifiability)
    return errors, warnings

