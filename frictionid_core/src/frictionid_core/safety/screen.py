"""The one screen of every parameter set that can reach a robot (no ROS import).

Whatever becomes a friction feed-forward — an identification result, a parameters file (the
node's ``results_file`` and ``~/load``, the YAML of ``frictionid export --yaml``), an online
candidate — is screened by :func:`screen_parameters` first; a refused set is never activated,
saved or exported. Each refusal is one line naming the parameter and the limit:

* **finite**: every parameter is a finite number;
* **sign**: the friction laws' parameters (``Fv``, ``Fc``, ``Fs``, ``vs``, ``v0``, ``delta``, the
  dynamic laws' ``sigma0``, ``sigma1``, ``k1`` … and their ``_pos``/``_neg`` branches), the
  masses and inertias of the one-joint systems (``M``, ``J``, ``ZZ``) and the rotor inertias of a
  robot (``<joint>.Ia``) are ≥ 0 — unless the set's own ``bounds`` allow a negative value for
  that name (a user's explicit choice), or the value is within :data:`NEGATIVE_SIGMAS` standard
  errors of 0 (its ``std``: an unconstrained least-squares estimate of a friction that is about 0
  comes out a little negative as often as not);
* **magnitude**: |value| ≤ ``max_abs`` for every parameter but the dynamic laws' stiffnesses
  (``sigma0``, ``k1`` …: within their default bounds, :data:`STIFFNESS_PARAMETERS`); per joint
  (or motor) with a :class:`Limit`: the torque parameters |``Fc``|, |``Fs``|, |``offset``| ≤ its
  effort limit, and the viscous torque at its speed, |``Fv``|·speed, ≤ :data:`VISCOUS_MARGIN` ×
  its effort limit (when the speed is known).

Limits per joint (:class:`Limit`) come from the robot: its model's effort and velocity limits
(:func:`robot_limits`: a URDF's ``<limit effort velocity>``, the built-in ``tx40`` table), else
the data the set was identified on (:func:`data_limits`: the largest |effort| and |velocity| per
joint × :data:`DATA_MARGIN`, recorded with the set), else a default the caller gives (the node:
its ``feedforward_max``). Motor-side friction (``motor_<k>``, referred to the joint side) takes
the limit of the drive's joint k.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import DEFAULT_BOUNDS, parameter_base

# Largest |effort| and |velocity| of the identification data × this = the limits of a joint without
# a robot model: a friction that alone needs twice the largest effort the data holds is not that
# data's friction (and the feed-forward's clamp allows twice the largest effort seen).
DATA_MARGIN = 2.0
# |value| above this is refused for any parameter (SI units; the node's gate_max_abs).
MAX_ABS = 1e3
# Physical magnitudes (≥ 0): the friction laws' parameters (their default bounds start at 0 or
# above) and the one-joint systems' mass and inertias; robots: rotor inertias ``<joint>.Ia``.
NONNEGATIVE = frozenset({name for name, (low, _) in DEFAULT_BOUNDS.items() if low >= 0} | {"M", "J", "ZZ"})
ROTOR_SUFFIX = ".Ia"
# A negative physical magnitude within this many of its standard errors of 0 is 0 within its uncertainty.
NEGATIVE_SIGMAS = 3.0
TORQUE_PARAMETERS = ("Fc", "Fs", "offset")  # in effort units [N·m | N]
# Stiffnesses of the dynamic laws [N·m/rad | N/m]: micrometre break-away deflections make them large;
# held within their default bounds instead of max_abs (the clamp holds the feed-forward's torque).
STIFFNESS_PARAMETERS = {"sigma0": DEFAULT_BOUNDS["sigma0"][1], "k": DEFAULT_BOUNDS["k"][1]}
VISCOUS_PARAMETER = "Fv"  # [N·m·s/rad | N·s/m]: times a speed, an effort
# The viscous torque at a joint's speed limit may reach this × its effort limit: identification data
# rarely come near the speed limit, so Fv is extrapolated there (a poorly excited TX40 wrist joint gave
# 1.07 ×); the feed-forward's clamp holds the torque to the effort limit anyway.
VISCOUS_MARGIN = 2.0
_BRANCHES = ("_pos", "_neg")


@dataclass(frozen=True)
class Limit:
    """What a joint's (or motor's) friction must stay within: its ``effort`` limit [N·m | N] and
    the ``speed`` it reaches [rad/s | m/s] (nan: unknown), and where they come from (``source``)."""

    effort: float
    speed: float = math.nan
    source: str = ""

    def to_dict(self) -> dict:
        return {"effort": float(self.effort), "speed": float(self.speed), "source": self.source}

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "limit") -> Limit:
        """The limit of its :meth:`to_dict`; FrictionIdError naming ``where`` unless ``effort`` is a
        finite number > 0 and ``speed`` one ≥ 0 (or nan, unknown)."""
        try:
            effort, speed = float(data["effort"]), float(data.get("speed", math.nan))
            source = str(data.get("source", ""))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise FrictionIdError(f"{where}: malformed ({type(exc).__name__}: {exc})") from None
        if not (math.isfinite(effort) and effort > 0) or not (math.isnan(speed) or 0 <= speed < math.inf):
            raise FrictionIdError(f"{where}: effort must be a finite number > 0 and speed one >= 0, got "
                                  f"effort {effort:g}, speed {speed:g}")
        return cls(effort, speed, source)


def _split(name: str) -> tuple[str | None, str]:
    """(owner or None, the name without its ``<owner>/`` prefix)."""
    owner, sep, base = name.rpartition("/")
    return (owner, base) if sep else (None, name)


def _law_name(base: str) -> str:
    """A friction parameter's name without its branch suffix (``Fc_pos`` → ``Fc``)."""
    for suffix in _BRANCHES:
        if base.endswith(suffix):
            return base[: -len(suffix)]
    return base


def screen_parameters(params: Mapping[str, float], limits: Mapping[str, Limit] | None = None, *,
                      bounds: Mapping[str, tuple[float, float]] | None = None, max_abs: float = MAX_ABS,
                      default: Limit | None = None, std: Mapping[str, float] | None = None) -> list[str]:
    """The refusals of the parameter set ``params`` {name: value} (empty: accepted), one line each
    naming the parameter and the rule or limit (see the module docstring).

    Names are ``<owner>/<name>`` for a joint's (or motor's) parameter and plain for a shared one;
    a plain friction name belongs to the one owner of ``limits`` when there is one. ``limits``:
    {owner: Limit}; an owner without one takes ``default`` (None: no magnitude check of its
    own). ``bounds``: the set's requested bounds {name: (low, high)}; a negative ``low`` allows a
    negative value of a physical magnitude. ``max_abs``: largest |value| of any parameter. ``std``:
    the standard errors {name: std} of an estimate; a negative magnitude within NEGATIVE_SIGMAS of
    them of 0 is accepted."""
    limits = dict(limits or {})
    bounds = dict(bounds or {})
    std = dict(std or {})
    only = next(iter(limits)) if len(limits) == 1 else None
    refusals = []
    for name, raw in params.items():
        try:
            value = float(raw)
        except (TypeError, ValueError):
            refusals.append(f"parameter '{name}' = {raw!r} is not a number")
            continue
        if not math.isfinite(value):
            refusals.append(f"parameter '{name}' = {value} is not finite")
            continue
        owner, base = _split(name)
        law = _law_name(base)
        if value < 0 and (parameter_base(law) in NONNEGATIVE or base.endswith(ROTOR_SUFFIX)):
            low = bounds.get(name, (0.0, 0.0))[0]
            sigma = _number(std.get(name))
            within = math.isfinite(sigma) and sigma > 0 and value >= -NEGATIVE_SIGMAS * sigma
            if not (low is not None and float(low) < 0) and not within:
                below = f", {-value / sigma:.3g} standard errors below 0" if math.isfinite(sigma) and sigma > 0 else ""
                refusals.append(f"parameter '{name}' = {value:.6g} is negative (a physical magnitude, >= 0){below}")
                continue
        key = owner or only or ""
        limit = limits.get(key, default) if owner or law in TORQUE_PARAMETERS + (VISCOUS_PARAMETER,) else None
        refusal = _over_limit(name, law, value, limit, key) if limit is not None else ""
        cap = STIFFNESS_PARAMETERS.get(parameter_base(law), max_abs)
        if not refusal and abs(value) > cap:
            refusal = f"parameter '{name}' = {value:.6g} is over the limit |value| <= {cap:g}"
        if refusal:
            refusals.append(refusal)
    return refusals


def _number(raw) -> float:
    """``raw`` as a float; nan when it is not a number."""
    try:
        return float(raw)
    except (TypeError, ValueError):
        return math.nan


def _over_limit(name: str, law: str, value: float, limit: Limit, owner: str) -> str:
    """The refusal of a torque or viscous parameter over ``owner``'s ``limit``, else ""."""
    of = f" of '{owner}'" if owner else ""
    where = f" ({limit.source})" if limit.source else ""
    if law in TORQUE_PARAMETERS and abs(value) > limit.effort:
        return f"parameter '{name}' = {value:.6g} is over the effort limit {limit.effort:.6g}{of}{where}"
    torque = abs(value) * limit.speed
    if law == VISCOUS_PARAMETER and math.isfinite(limit.speed) and torque > VISCOUS_MARGIN * limit.effort:
        return (f"parameter '{name}' = {value:.6g}: its torque {torque:.6g} at the speed {limit.speed:.6g}{of} is "
                f"over {VISCOUS_MARGIN:g} x the effort limit {limit.effort:.6g}{where}")
    return ""


def robot_limits(system, owners: list[str] | None = None, joint_map: Mapping[str, str] | None = None
                 ) -> dict[str, Limit]:
    """{owner: Limit} of a robot system (``tx40``, ``urdf:PATH``) from its model's effort and
    velocity limits; ``owners``: the parameter owners (data joints, named in the model through
    ``joint_map``, or ``motor_<k>`` of the system's drive: joint k's limits). Joints without a
    finite positive effort limit are left out; empty for a system without a robot model."""
    robot = getattr(system, "robot", None)
    if robot is None:
        return {}
    model = robot.model
    effort = np.asarray(model.model.effortLimit, dtype=float)
    source = f"effort and velocity limits of {model.name}"
    by_joint = {j: Limit(float(effort[k]), float(model.velocity_limit[k]) if np.isfinite(model.velocity_limit[k])
                         else math.nan, source)
                for k, j in enumerate(model.joints) if np.isfinite(effort[k]) and effort[k] > 0}
    return _for_owners(by_joint, owners, getattr(system, "drive", None), joint_map)


def data_limits(series, drive=None, owners: list[str] | None = None, margin: float = DATA_MARGIN) -> dict[str, Limit]:
    """{owner: Limit} from the data an identification ran on: ``margin`` × the largest |effort| and
    |velocity| (recorded, else the gradient of the positions) of each joint of the JointSeries
    ``series`` — on the joint side through ``drive`` when given. Joints without effort are left out."""
    s = drive.to_joint_side(series) if drive is not None else series
    if len(s.t) < 2:
        return {}
    velocity = s.velocity if s.velocity is not None else np.gradient(s.position, s.t, axis=0)
    with np.errstate(invalid="ignore"):
        effort_max = np.nanmax(np.abs(s.effort), axis=0)
        speed_max = np.nanmax(np.abs(velocity), axis=0)
    source = f"{margin:g} x the largest |effort| and |velocity| of the identification data"
    by_joint = {j: Limit(margin * float(effort_max[k]),
                         margin * float(speed_max[k]) if np.isfinite(speed_max[k]) else math.nan, source)
                for k, j in enumerate(s.joints) if np.isfinite(effort_max[k]) and effort_max[k] > 0}
    return _for_owners(by_joint, owners, drive)


def _for_owners(by_joint: dict[str, Limit], owners: list[str] | None, drive,
                joint_map: Mapping[str, str] | None = None) -> dict[str, Limit]:
    """``by_joint`` keyed by ``owners``: a joint (named in ``by_joint`` through ``joint_map``), or
    ``motor_<k>`` of ``drive`` → the drive's joint k."""
    if owners is None:
        return by_joint
    out = {}
    for owner in owners:
        joint = (joint_map or {}).get(owner, owner)
        if drive is not None and owner.startswith("motor_") and owner[6:].isdigit():
            k = int(owner[6:]) - 1
            joint = drive.joints[k] if 0 <= k < len(drive.joints) else owner
        if joint in by_joint:
            out[owner] = by_joint[joint]
    return out


def result_refusals(result, limits: Mapping[str, Limit] | None = None, *, max_abs: float = MAX_ABS,
                    default: Limit | None = None) -> list[str]:
    """:func:`screen_parameters` of an identification result (an IdentifyResult or its JSON): its
    ``params`` against ``limits`` (None: those of its robot, :func:`robot_limits`, when its
    system is one), its own ``bounds`` and negative ``fixed`` values allowing negative values, its
    ``std`` the negative values within NEGATIVE_SIGMAS standard errors of 0."""
    get = _getter(result)
    if limits is None:
        limits = _result_robot_limits(get)
    return screen_parameters(dict(get("params") or {}), limits, bounds=explicit_bounds(result), max_abs=max_abs,
                             default=default, std=dict(get("std") or {}))


def effort_sign_refusals(result, drive=None) -> list[str]:
    """One line per joint whose effort the result (an IdentifyResult or its JSON) was identified
    with negated (its drive's ``effort_scale`` < 0: a driver's sign opposite to the model's axis)
    where ``drive`` (the feed-forward's: a :class:`~frictionid_core.drive.transmission.Drive`, None: none) keeps it,
    or the reverse: the feed-forward of that joint would have the wrong sign and add to its friction."""
    keys = _getter(result)("drive") if result is not None else None
    own = dict(zip(keys["joints"], keys.get("effort_scale") or [])) if keys else {}
    node = dict(zip(drive.joints, drive.effort_scale)) if drive is not None else {}
    out = []
    for joint in sorted(set(own) | set(node)):
        was, now = own.get(joint, 1.0) < 0, node.get(joint, 1.0) < 0
        if was != now:
            out.append(f"{joint}: identified with its effort {'negated' if was else 'as logged'} but the "
                       f"feed-forward's drive {'negates' if now else 'keeps'} it (effort_scale "
                       f"{node.get(joint, 1.0):g}): its friction torque would have the wrong sign; give the node a "
                       "drive_file with the result's effort_scale")
    return out


def explicit_bounds(result) -> dict[str, tuple[float, float]]:
    """The bounds a result (an IdentifyResult or its JSON; None: none) was asked for, and its
    negative ``fixed`` values as (value, value): where a physical magnitude may be negative."""
    if result is None:
        return {}
    get = _getter(result)
    allowed = {k: (float(v[0]), float(v[1])) for k, v in (get("bounds") or {}).items()}
    allowed.update({k: (float(v), float(v)) for k, v in (get("fixed") or {}).items()
                    if isinstance(v, (int, float)) and v < 0})
    return allowed


def _getter(result):
    return result.get if isinstance(result, Mapping) else lambda key, fallback=None: getattr(result, key, fallback)


def _result_robot_limits(get) -> dict[str, Limit]:
    """The :func:`robot_limits` of a result's robot system by its owners; empty for another system."""
    from frictionid_core.drive import friction_rows
    from frictionid_core.systems import get_system

    system = str(get("system") or "")
    if not (system == "tx40" or system.startswith("urdf:")):
        return {}
    drive = get("drive")
    owners = friction_rows({"drive": drive, "joints": list(get("joints") or [])})
    from frictionid_core.drive import drive_from_dict

    robot = get_system(system)
    return _for_owners(robot_limits(robot), owners, drive_from_dict(drive, "the result's drive") if drive else None,
                       get("joint_map") or {})
