"""Drive model: gearboxes, coupled joints and effort units between a log and the model's joints.

Motor angles are ``q_m = R·q`` with ``R = diag(N) + coupling`` (N: each motor's own gear ratio,
coupling: off-diagonal terms ``R[motor, joint]``). Power balance gives the joint torques
``τ = Rᵀ·y`` from the motor torques ``y`` (``y = effort_scale·e`` for a recorded effort ``e`` in
A, mA, N·m… on the motor side).

Motor-side friction (``friction_on: motor``) is stated *referred to the joint side through each
motor's own ratio*, as datasheets and FIGAROH state it: with ``C = diag(N)⁻¹·R`` (unit diagonal)

- referred motor velocity ``w = C·q̇`` (rad/s; the referred rotor acceleration is ``ẇ = C·q̈``),
- referred motor torque ``u = diag(N)·y = C⁻ᵀ·τ`` (N·m), so ``τ = Cᵀ·u``.

For the Stäubli TX40 wrist (motor 6 turns with joints 5 and 6): ``w₆ = q̇₅ + q̇₆``,
``τ₅ = 45·y₅ + 32·y₆``, ``u₅ = τ₅ − τ₆``.

A drive is stated in YAML (:func:`load_drive`)::

    name: my_arm                # optional (default: the file name)
    joints: [joint_1, ...]      # model joint names; every list below is in this order
    side: joint                 # joint | motor: where the log measures positions and efforts
    gear_ratio: [...]           # motor angle = gear_ratio × joint angle (default 1)
    coupling: [[5, 4, 32.0]]    # extra terms of R, 0-based [motor, joint, ratio]
    effort_scale: [...]         # recorded effort unit → torque on the recorded side (default 1)
    position_offset: [...]      # rad added to the joint angle to reach the model's zero (default 0)
    friction_on: joint          # joint | motor

Motor-side parameters are named ``motor_<k>`` (:meth:`Drive.motor_names`): ``k`` is 1-based and
motor ``k`` is row ``k − 1`` of R, the motor whose own ratio ``N[k−1]`` drives ``joints[k−1]``
(TX40: ``motor_6`` is the wrist motor that also turns with ``joint_5``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.files import check_keys, joint_names, read_yaml
from frictionid_core.timeseries import JointSeries

SIDES = ("joint", "motor")
DRIVE_KEYS = ("name", "joints", "side", "gear_ratio", "coupling", "effort_scale", "position_offset",
              "friction_on")
MAX_CONDITION = 1e12  # cond(R) above this: R is not invertible in floating point
# Near-singular drives: a gear ratio below MIN_GEAR_RATIO in magnitude (a joint a thousand times
# faster than its motor is no gearbox: a unit or a typo), an effort scale or a coupling ratio below
# MIN_SCALE (zero to round-off), or a coupling whose referred matrix C = diag(N)⁻¹·R has a condition
# number above MAX_COUPLING_CONDITION (motors that do not tell their joints apart: the TX40's wrist
# gives 2.6). A negative value is a direction: a motor turning against its joint (gear_ratio, the
# TX40's −48), an effort logged against the joint axis (effort_scale −1, as the effort-sign check
# writes), a coupling of the opposite sense.
MIN_GEAR_RATIO = 1e-3
MIN_SCALE = 1e-9
MAX_COUPLING_CONDITION = 1e6


@dataclass(frozen=True)
class Drive:
    """Transmission between the model's joints and a log (validated on creation; see the module doc).

    Attributes:
        joints: model joint names, length J; every per-joint tuple is in this order.
        side: ``joint`` or ``motor``: where the log measures positions and efforts.
        gear_ratio: N, motor angle / joint angle per joint (default 1).
        coupling: off-diagonal terms ``(motor, joint, ratio)`` of R, 0-based indices.
        effort_scale: recorded effort unit → torque on the recorded side (N·m/A, N·m/mA…; default 1).
        position_offset: rad added to the joint angle to reach the model's zero (default 0).
        friction_on: ``joint`` or ``motor``: where friction and rotor inertia act.
        name: label stored in results.
        source: file it was read from (for messages; not compared).
    """

    joints: tuple[str, ...]
    side: str = "joint"
    gear_ratio: tuple[float, ...] | None = None
    coupling: tuple[tuple[int, int, float], ...] = ()
    effort_scale: tuple[float, ...] | None = None
    position_offset: tuple[float, ...] | None = None
    friction_on: str = "joint"
    name: str = ""
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        where = self.source or "drive"
        joints = joint_names(self.joints, where)
        for key in ("side", "friction_on"):
            if getattr(self, key) not in SIDES:
                raise InputError(f"{where}: key '{key}' is {getattr(self, key)!r}; choose one of {', '.join(SIDES)}")
        per_joint = {
            "gear_ratio": _numbers(self.gear_ratio, "gear_ratio", joints, where, default=1.0,
                                   smallest=(MIN_GEAR_RATIO, "motor angle = gear_ratio × joint angle")),
            "effort_scale": _numbers(self.effort_scale, "effort_scale", joints, where, default=1.0,
                                     smallest=(MIN_SCALE, "torque = effort_scale × recorded effort")),
            "position_offset": _numbers(self.position_offset, "position_offset", joints, where, default=0.0),
        }
        for key, value in {"joints": joints, **per_joint,
                           "coupling": _coupling(self.coupling, joints, where)}.items():
            object.__setattr__(self, key, value)
        cond = np.linalg.cond(self.C) if self.coupling else 1.0
        if not cond <= MAX_COUPLING_CONDITION:
            raise InputError(f"{where}: keys 'gear_ratio' and 'coupling' give a singular or near-singular motor←joint "
                             f"matrix (condition number of diag(gear_ratio)⁻¹·R {cond:.3g}, above "
                             f"{MAX_COUPLING_CONDITION:.0e}): the motor angles do not determine the joint angles; "
                             "check the coupling's [motor, joint, ratio] terms")
        cond = np.linalg.cond(self.R)
        if not cond < MAX_CONDITION:
            raise InputError(f"{where}: keys 'gear_ratio' and 'coupling' give a singular motor←joint matrix R "
                             f"(condition number {cond:.3g})")

    # ------------------------------------------------------------------ matrices
    @cached_property
    def N(self) -> np.ndarray:
        """Each motor's own gear ratio, shape (J,): the diagonal of R."""
        return _frozen(np.array(self.gear_ratio))

    @cached_property
    def R(self) -> np.ndarray:
        """Motor←joint matrix, shape (J, J): motor angles ``q_m = R·q``."""
        r = np.diag(self.N)
        for motor, joint, ratio in self.coupling:
            r[motor, joint] = ratio
        return _frozen(r)

    @cached_property
    def C(self) -> np.ndarray:
        """Referred motor←joint matrix ``C = diag(N)⁻¹·R`` (unit diagonal), shape (J, J)."""
        return _frozen(self.R / self.N[:, None] + 0.0)  # + 0.0: no −0 entries

    @cached_property
    def _R_inv(self) -> np.ndarray:
        return _frozen(np.linalg.inv(self.R))

    @cached_property
    def _C_inv(self) -> np.ndarray:
        return _frozen(np.linalg.inv(self.C))

    # ------------------------------------------------------- referred motor side
    def motor_velocity(self, qd: np.ndarray) -> np.ndarray:
        """Referred motor velocities ``w = C·q̇``, rad/s, for joint velocities ``qd`` (N, J) or (J,).

        Also maps joint accelerations to referred rotor accelerations (``ẇ = C·q̈``)."""
        return np.asarray(qd, dtype=float) @ self.C.T

    def referred_motor_torque(self, tau: np.ndarray) -> np.ndarray:
        """Referred motor torques ``u = C⁻ᵀ·τ``, N·m, for joint torques ``tau`` (N, J) or (J,)."""
        return np.asarray(tau, dtype=float) @ self._C_inv

    def joint_torque(self, u: np.ndarray) -> np.ndarray:
        """Joint torques ``τ = Cᵀ·u``, N·m, for referred motor torques ``u`` (N, J) or (J,)."""
        return np.asarray(u, dtype=float) @ self.C

    def joint_velocity_matrix(self) -> np.ndarray:
        """M (J, J) with joint velocities ``q̇ = M·v`` of recorded velocities v: R⁻¹ on the motor side, else 1."""
        return self._R_inv if self.side == "motor" else np.eye(len(self.joints))

    def recorded_effort_matrix(self) -> np.ndarray:
        """M (J, J) with recorded efforts ``e = M·τ`` of joint torques τ (N·m):
        diag(1/effort_scale)·R⁻ᵀ on the motor side, else diag(1/effort_scale)."""
        per_joint = self._R_inv.T if self.side == "motor" else np.eye(len(self.joints))
        return per_joint / np.array(self.effort_scale)[:, None]

    def coupled_motors(self) -> list[int]:
        """0-based indices of the motors that turn with more than one joint."""
        return [int(k) for k in np.flatnonzero(np.count_nonzero(self.R, axis=1) > 1)]

    def motor_names(self) -> list[str]:
        """Names of motor-side parameters: ``motor_<k>``, k = 1…J, motor k driving ``joints[k−1]``."""
        return [f"motor_{k + 1}" for k in range(len(self.joints))]

    # ------------------------------------------------------------- whole series
    def to_joint_side(self, series: JointSeries, joint_map: dict[str, str] | None = None) -> JointSeries:
        """Joint angles (rad), velocities (rad/s) and torques (N·m) from a log recorded on ``side``.

        ``series`` has one column per drive joint: either named as the drive's joints (any order;
        through ``joint_map`` {log name: drive joint} when given) or named as in the log and
        already in the drive's order. Log names are kept; columns come out in the drive's order. Motor side:
        ``q = R⁻¹·q_m + position_offset``, ``q̇ = R⁻¹·q̇_m``, ``τ = Rᵀ·(effort_scale·e)``; joint side:
        ``q = q_rec + position_offset``, ``τ = effort_scale·e``. What was done goes to ``notes``;
        ``extras`` and ``meta`` pass through unchanged. A log of some of the drive's joints is
        converted by the drive restricted to them (:meth:`restricted`).
        """
        named = [(joint_map or {}).get(j, j) for j in series.joints]
        if set(named) < set(self.joints) and len(set(named)) == len(named):
            try:
                return self.restricted(named).to_joint_side(series, joint_map)
            except InputError as exc:
                raise InputError(f"{series.source}: {exc}") from None
        s = self._aligned(series, joint_map)
        scaled = s.effort * np.array(self.effort_scale)
        if self.side == "motor":
            q = s.position @ self._R_inv.T + np.array(self.position_offset)
            qd = None if s.velocity is None else s.velocity @ self._R_inv.T
            tau = scaled @ self.R
            done = "q = R⁻¹·q_m + position_offset, τ = Rᵀ·(effort_scale·e)"
        else:
            q = s.position + np.array(self.position_offset)
            qd, tau = s.velocity, scaled
            done = "q = q + position_offset, τ = effort_scale·e"
        return self._with(s, q, tau, qd, f"{self._label}: {self.side}-side log to joint side: {done}")

    def restricted(self, joints: list[str]) -> Drive:
        """This drive on its joints ``joints`` only (kept in the drive's order); InputError when a
        coupling term links one of them with a joint left out (the log then needs both)."""
        keep = [k for k, j in enumerate(self.joints) if j in joints]
        kept = set(keep)
        crossing = [(self.joints[m], self.joints[j]) for m, j, _ in self.coupling if (m in kept) != (j in kept)]
        if crossing:
            raise InputError(f"{self._label}: coupling term(s) between the joints {crossing} link a joint of the "
                             f"data {sorted(joints)} with one it lacks; the log needs both")
        at = {k: i for i, k in enumerate(keep)}
        def _pick(values: tuple) -> tuple:
            return tuple(values[k] for k in keep)

        return Drive(joints=_pick(self.joints), side=self.side, gear_ratio=_pick(self.gear_ratio),
                     coupling=tuple((at[m], at[j], r) for m, j, r in self.coupling if m in kept),
                     effort_scale=_pick(self.effort_scale), position_offset=_pick(self.position_offset),
                     friction_on=self.friction_on, name=self.name, source=self.source)

    def to_recorded_side(self, series: JointSeries) -> JointSeries:
        """Inverse of :meth:`to_joint_side`: what this drive logs for joint-side data.

        Motor side: motor angles ``q_m = R·(q − position_offset)`` (rad), motor velocities, and
        efforts in recorded units ``e = R⁻ᵀ·τ / effort_scale``; joint side: ``q − position_offset``
        and ``τ / effort_scale``."""
        s = self._aligned(series)
        q = s.position - np.array(self.position_offset)
        if self.side == "motor":
            q = q @ self.R.T
            qd = None if s.velocity is None else s.velocity @ self.R.T
            y = s.effort @ self._R_inv
            done = "q_m = R·(q − position_offset), e = R⁻ᵀ·τ / effort_scale"
        else:
            qd, y = s.velocity, s.effort
            done = "q − position_offset, e = τ / effort_scale"
        e = y / np.array(self.effort_scale)
        return self._with(s, q, e, qd, f"{self._label}: joint side to a {self.side}-side log: {done}")

    def to_dict(self) -> dict:
        """Every choice as plain JSON values; :func:`drive_from_dict` reads it back."""
        return {"name": self.name, "joints": list(self.joints), "side": self.side,
                "gear_ratio": list(self.gear_ratio), "coupling": [list(c) for c in self.coupling],
                "effort_scale": list(self.effort_scale), "position_offset": list(self.position_offset),
                "friction_on": self.friction_on}

    def _aligned(self, series: JointSeries, joint_map: dict[str, str] | None = None) -> JointSeries:
        """``series`` with its columns in the drive's joint order (log names mapped through
        ``joint_map`` to the drive's joints)."""
        joints = list(self.joints)
        for named in (series.joints, [(joint_map or {}).get(j, j) for j in series.joints]):
            if named == joints:
                return series
            if sorted(named) == sorted(joints):
                return series.select([series.joints[named.index(j)] for j in joints])
        known = [j for j in named if j in self.joints]
        if known or len(series.joints) != len(joints):
            missing = [j for j in joints if j not in named]
            extra = [log for log, j in zip(series.joints, named) if j not in self.joints]
            why = []
            if known and extra:
                kept = ",".join(log for log, j in zip(series.joints, named) if j in self.joints)
                why.append(f"extra {extra} (data joints the drive does not list: add them to its 'joints' and "
                           f"per-joint lists, or leave them out of the data: --joints {kept})")
            if known and missing:
                why.append(f"missing {missing} (drive joints the data lack)")
            raise InputError(f"{series.source}: the data joints {series.joints} do not match {self._label} "
                             f"joints {joints}" + (f": {'; '.join(why)}" if why else ""))
        return series

    @property
    def _label(self) -> str:
        return f"drive '{self.name}'" if self.name else "drive"

    @staticmethod
    def _with(s: JointSeries, position, effort, velocity, note: str) -> JointSeries:
        return JointSeries(s.t, list(s.joints), position, effort, velocity, s.source, dict(s.extras),
                           dict(s.meta), [*s.notes, note])


def drive_from_dict(data: dict, source: str = "") -> Drive:
    """A :class:`Drive` from a mapping of the YAML keys (unknown keys refused); ``source`` names it
    in messages."""
    where = source or "drive"
    check_keys(data, DRIVE_KEYS, where, required=("joints",))
    coupling = data.get("coupling") or ()
    name = data.get("name") or (Path(source).stem if source else "")
    return Drive(joints=data["joints"], side=data.get("side", "joint"), gear_ratio=data.get("gear_ratio"),
                 coupling=coupling, effort_scale=data.get("effort_scale"),
                 position_offset=data.get("position_offset"), friction_on=data.get("friction_on", "joint"),
                 name=str(name), source=source)


def result_drive(result: dict) -> Drive | None:
    """The drive of an identification result (its ``drive`` key, an older result has none), or None."""
    data = result.get("drive")
    return drive_from_dict(data, "the result's drive") if data else None


def friction_rows(result: dict) -> list[str]:
    """Who owns the friction and offset parameters of an identification result (the ``<name>/``
    prefixes): the drive's motors (``motor_<k>``) when its friction acts on the motors, else the
    result's joints."""
    drive = result_drive(result)
    return drive.motor_names() if drive is not None and drive.friction_on == "motor" else list(result["joints"])


def bundled_drives() -> list[str]:
    """Names of the drives shipped with frictionid (``frictionid_core/drive/bundled/<name>.yaml``)."""
    return sorted(p.name[:-5] for p in resources.files("frictionid_core.drive").joinpath("bundled").iterdir()
                  if p.name.endswith(".yaml"))


def load_drive(path_or_name: str | Path) -> Drive:
    """The drive in a YAML file, or a bundled drive by name (e.g. ``tx40``, see :func:`bundled_drives`)."""
    path = Path(path_or_name).expanduser()
    if not path.exists():
        name = str(path_or_name)
        if name not in bundled_drives():
            raise InputError(f"{name}: no such drive file and no bundled drive of that name "
                             f"(bundled: {', '.join(bundled_drives())})")
        path = Path(str(resources.files("frictionid_core.drive").joinpath("bundled", f"{name}.yaml")))
    return drive_from_dict(read_yaml(path, "a drive model"), str(path))


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _number(value) -> float | None:
    """``value`` as a finite float (numbers or numeric strings such as YAML's ``1e-3``), else None."""
    if isinstance(value, bool):
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _numbers(value, key: str, joints: tuple[str, ...], where: str, *, default: float,
             smallest: tuple[float, str] | None = None) -> tuple[float, ...]:
    """One finite number per joint (``default`` for all when None); ``smallest``: (the least
    magnitude allowed, what the value does) for a scale that must not vanish."""
    if value is None:
        return (default,) * len(joints)
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise InputError(f"{where}: key '{key}' must be a list of {len(joints)} numbers (one per joint), "
                         f"got {value!r}")
    if len(value) != len(joints):
        raise InputError(f"{where}: key '{key}' has {len(value)} values for {len(joints)} joints {list(joints)}")
    out = []
    for j, v in zip(joints, value):
        x = _number(v)
        if x is None:
            raise InputError(f"{where}: key '{key}': value {v!r} of joint '{j}' is not a finite number")
        if smallest is not None and abs(x) < smallest[0]:
            what = "zero" if x == 0 else f"{x:.3g}, near zero (below {smallest[0]:g} in magnitude)"
            raise InputError(f"{where}: key '{key}': value of joint '{j}' is {what}: {smallest[1]} would vanish "
                             "(a negative value is allowed: it reverses the direction)")
        out.append(x)
    return tuple(out)


def _coupling(value, joints: tuple[str, ...], where: str) -> tuple[tuple[int, int, float], ...]:
    """Validated coupling terms ``(motor, joint, ratio)``: 0-based, off the diagonal, once each."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise InputError(f"{where}: key 'coupling' must be a list of [motor, joint, ratio], got {value!r}")
    n, out, seen = len(joints), [], set()
    for term in value:
        ok = (not isinstance(term, (str, bytes)) and hasattr(term, "__len__") and len(term) == 3
              and all(isinstance(i, (int, np.integer)) and not isinstance(i, bool) for i in term[:2]))
        ratio = _number(term[2]) if ok else None
        if ratio is None:
            raise InputError(f"{where}: key 'coupling': term {term!r} is not [motor, joint, ratio] "
                             "(0-based integer indices, finite ratio)")
        motor, joint = int(term[0]), int(term[1])
        if not (0 <= motor < n and 0 <= joint < n):
            raise InputError(f"{where}: key 'coupling': term {list(term)} has an index outside 0…{n - 1} "
                             f"({n} joints)")
        if motor == joint:
            raise InputError(f"{where}: key 'coupling': term {list(term)} is on the diagonal; "
                             "state that ratio in 'gear_ratio'")
        if abs(ratio) < MIN_SCALE:
            raise InputError(f"{where}: key 'coupling': term {[motor, joint, ratio]} has a zero ratio (below "
                             f"{MIN_SCALE:g} in magnitude): leave the term out")
        if (motor, joint) in seen:
            raise InputError(f"{where}: key 'coupling': [motor {motor}, joint {joint}] is given twice")
        seen.add((motor, joint))
        out.append((motor, joint, ratio))
    return tuple(out)
