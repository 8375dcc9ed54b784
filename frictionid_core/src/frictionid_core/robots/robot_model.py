"""Rigid-body manipulator models on Pinocchio: inverse dynamics, regressor, limits.

A :class:`RobotModel` wraps a fixed-base ``pinocchio.Model`` whose movable joints each
have one degree of freedom (revolute, prismatic, or continuous). Everything robot-specific
(kinematics, masses, inertias) lives in the Pinocchio model; nothing here knows a robot.

Standard parameters, per body (Pinocchio's ``Inertia.toDynamicParameters`` order, inertia
about the joint frame origin, in the joint frame):
``m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz``; then one rotor (armature) inertia ``Ia``
per joint, entering τ_j as Ia_j·q̈_j. Parameter names are ``<joint>.<name>``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError

BODY_PARAMS = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
ROTOR_PARAM = "Ia"

# Used when a model gives no acceleration limit (URDF has none), rad/s² or m/s².
DEFAULT_ACCELERATION_LIMIT = 10.0


def _pin():
    try:
        import pinocchio
    except ImportError as exc:  # pragma: no cover - pinocchio is a pinned requirement
        raise InputError(f"robot models need Pinocchio ('pip install pin'): {exc}") from None
    return pinocchio


def param_name(joint: str, p: str) -> str:
    return f"{joint.replace('/', '_')}.{p}"


@dataclass
class RobotModel:
    """A fixed-base manipulator.

    Attributes:
        name: model name (``tx40``, URDF robot name, …).
        model: the Pinocchio model (its ``armature`` holds the rotor inertias).
        joints: movable joint names, in velocity order (nv).
        lower, upper: position limits (nv,) (±inf when unlimited).
        velocity_limit, acceleration_limit: (nv,) magnitudes.
        source: where the model came from (file or table).
        inertia_warnings: one line per moving body whose inertia breaks the triangle inequalities
            (:func:`check_inertials`): kept, but not a prior the consistent fit can pull toward.
    """

    name: str
    model: object
    joints: list[str]
    lower: np.ndarray
    upper: np.ndarray
    velocity_limit: np.ndarray
    acceleration_limit: np.ndarray
    source: str = ""
    inertia_warnings: tuple[str, ...] = ()
    _data: object = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self._data = self.model.createData()
        self._unit = self.model.nq != self.model.nv  # continuous joints: (cos, sin) configuration

    # --------------------------------------------------------------- structure
    @property
    def nv(self) -> int:
        return self.model.nv

    @property
    def prismatic(self) -> list[str]:
        """The prismatic joints (positions in m; the others turn, in rad)."""
        return [self.model.names[i] for i in range(1, self.model.njoints)
                if self.model.joints[i].shortname().startswith("JointModelP")]

    @property
    def armature(self) -> np.ndarray:
        return np.array(self.model.armature, dtype=float)

    def parameter_names(self) -> list[str]:
        """Standard parameters: 10 per body then one Ia per joint."""
        names = [param_name(j, p) for j in self.joints for p in BODY_PARAMS]
        return names + [param_name(j, ROTOR_PARAM) for j in self.joints]

    def parameters(self) -> np.ndarray:
        """Standard parameter values of the model (the ground truth of synthetic data)."""
        pi = [self.model.inertias[i].toDynamicParameters() for i in range(1, self.model.njoints)]
        return np.concatenate(pi + [self.armature])

    def limits_table(self) -> dict[str, dict[str, float]]:
        return {j: {"lower": float(self.lower[k]), "upper": float(self.upper[k]),
                    "velocity": float(self.velocity_limit[k]), "acceleration": float(self.acceleration_limit[k])}
                for k, j in enumerate(self.joints)}

    # ------------------------------------------------------------- kinematics
    def configuration(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio configuration of joint coordinates q (nv,)."""
        q = np.asarray(q, dtype=float)
        if not self._unit:
            return q
        pin = _pin()
        return pin.integrate(self.model, pin.neutral(self.model), q)

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """τ = M(q)q̈ + C(q,q̇)q̇ + g(q) + Ia·q̈ for samples (N, nv) → (N, nv) (Pinocchio rnea)."""
        pin = _pin()
        q, qd, qdd = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q, qd, qdd))
        out = np.empty_like(qd)
        m, d = self.model, self._data
        for k in range(q.shape[0]):
            out[k] = pin.rnea(m, d, self.configuration(q[k]), qd[k], qdd[k])
        return out

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """g(q) for samples (N, nv) → (N, nv)."""
        pin = _pin()
        q = np.atleast_2d(np.asarray(q, dtype=float))
        return np.array([pin.computeGeneralizedGravity(self.model, self._data, self.configuration(x)) for x in q])

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M(q) (rigid bodies + armature) at one configuration → (nv, nv)."""
        pin = _pin()
        M = pin.crba(self.model, self._data, self.configuration(np.asarray(q, dtype=float)))
        return np.triu(M) + np.triu(M, 1).T

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, rows: list[int] | None = None
                  ) -> np.ndarray:
        """Standard-parameter regressor for samples (N, nv) → (N, nv, 10·nb + nv), or with ``rows``
        (joint indices, velocity order) those rows alone (N, len(rows), 10·nb + nv).

        τ_k = Y_k · :meth:`parameters` (Pinocchio's joint torque regressor plus one q̈_j column
        per rotor inertia). Joints outside ``rows`` held still over every sample (one position,
        q̇ = q̈ = 0: a URDF's joints the log lacks) are locked into their parents' bodies, and
        Pinocchio computes the moving chain alone (:meth:`_locked`: a 48-joint TIAGo whose arm
        moves, 129 → 5 µs a sample); the columns are the same up to round-off.
        """
        pin = _pin()
        q, qd, qdd = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q, qd, qdd))
        n, nv = qd.shape
        nb = self.model.njoints - 1
        wanted = list(range(nv)) if rows is None else list(rows)
        still = ~(qd.any(axis=0) | qdd.any(axis=0) | (q != q[:1]).any(axis=0))
        still[wanted] = False
        if still.any() and n > 1 and self._lockable:
            m, d, vidx, T = self._locked(tuple(np.flatnonzero(still)), tuple(q[0, still]))
            nb_r = m.njoints - 1
            Y = np.zeros((n, m.nv, 10 * nb_r + m.nv))
            qr, qdr, qddr = q[:, vidx], qd[:, vidx], qdd[:, vidx]
            if m.nq != m.nv:  # continuous joints: (cos, sin) configurations
                qr = np.array([pin.integrate(m, pin.neutral(m), x) for x in qr])
            for k in range(n):
                Y[k, :, : 10 * nb_r] = pin.computeJointTorqueRegressor(m, d, qr[k], qdr[k], qddr[k])
            Y[:, np.arange(m.nv), 10 * nb_r + np.arange(m.nv)] = qddr
            at = {int(v): r for r, v in enumerate(vidx)}
            Y = Y[:, [at[j] for j in wanted], :]
            out = np.zeros((n, len(wanted), 10 * nb + nv))
            for cols, source, A in T:  # block-sparse: each body's columns from the one it moved into
                out[..., cols] = Y[..., source] if A is None else Y[..., source] @ A
            return out
        out = np.zeros((n, nv, 10 * nb + nv))
        m, d = self.model, self._data
        for k in range(n):
            out[k, :, : 10 * nb] = pin.computeJointTorqueRegressor(m, d, self.configuration(q[k]), qd[k], qdd[k])
        idx = np.arange(nv)
        out[:, idx, 10 * nb + idx] = qdd
        return out if rows is None else out[:, wanted, :]

    @property
    def _lockable(self) -> bool:
        """True when every joint has its frame (a URDF model's; Pinocchio's reduction needs them)."""
        if "_frames_of_joints" not in self.__dict__:
            pin = _pin()
            self.__dict__["_frames_of_joints"] = all(
                self.model.existFrame(name, pin.FrameType.JOINT) for name in self.model.names[1:])
        return self.__dict__["_frames_of_joints"]

    def _locked(self, locked: tuple[int, ...], at: tuple[float, ...]):
        """(the Pinocchio model with the joints ``locked`` (velocity indices) fixed at coordinates
        ``at``, its data, the velocity indices (in this model) of its joints, T): T lists, per
        column block of this model's standard parameters, (its columns, the reduced model's columns
        it is made of, A: None for the same parameters, or :func:`moved_parameters` of a locked
        body moved into the moving body it hangs from; a body hanging from the base is left out:
        its columns are 0). Cached."""
        key = (locked, at)
        cache = self.__dict__.setdefault("_locked_models", {})
        if key not in cache:
            pin = _pin()
            full, nb, nv = self.model, self.model.njoints - 1, self.model.nv
            ids = [i for i in range(1, full.njoints) if full.joints[i].idx_v in locked]
            q_ref = np.zeros(nv)
            q_ref[list(locked)] = at
            reduced = pin.buildReducedModel(full, ids, self.configuration(q_ref))
            nb_r = reduced.njoints - 1
            T, vidx = [], np.zeros(reduced.nv, dtype=int)
            for i in range(1, full.njoints):
                name, cols = full.names[i], slice(10 * (i - 1), 10 * i)
                if i in ids:
                    frame = reduced.frames[reduced.getFrameId(name, pin.FrameType.FIXED_JOINT)]
                    if frame.parentJoint > 0:
                        j = frame.parentJoint
                        T.append((cols, slice(10 * (j - 1), 10 * j), moved_parameters(frame.placement)))
                    continue
                r = reduced.getJointId(name)
                vr, v = reduced.joints[r].idx_v, full.joints[i].idx_v
                T += [(cols, slice(10 * (r - 1), 10 * r), None), (10 * nb + v, 10 * nb_r + vr, None)]
                vidx[vr] = v
            if len(cache) >= 8:
                cache.pop(next(iter(cache)))
            cache[key] = (reduced, reduced.createData(), vidx, T)
        return cache[key]

    def check_limits(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, t: np.ndarray | None = None,
                     what: str = "trajectory", tol: float = 1e-9) -> None:
        """Raise InputError naming the first joint/limit a trajectory (N, nv) violates."""
        t = np.arange(q.shape[0]) if t is None else t
        problems = []
        for k, j in enumerate(self.joints):
            checks = (
                ("position", q[:, k] < self.lower[k] - tol, q[:, k], f"[{self.lower[k]:.6g}, {self.upper[k]:.6g}]"),
                ("position", q[:, k] > self.upper[k] + tol, q[:, k], f"[{self.lower[k]:.6g}, {self.upper[k]:.6g}]"),
                ("velocity", np.abs(qd[:, k]) > self.velocity_limit[k] * (1 + tol), qd[:, k],
                 f"±{self.velocity_limit[k]:.6g}"),
                ("acceleration", np.abs(qdd[:, k]) > self.acceleration_limit[k] * (1 + tol), qdd[:, k],
                 f"±{self.acceleration_limit[k]:.6g}"),
            )
            for kind, bad, x, lim in checks:
                if bad.any():
                    i = int(np.flatnonzero(bad)[0])
                    worst = float(x[bad][np.argmax(np.abs(x[bad]))])
                    problems.append(f"joint '{j}' {kind} {worst:.6g} outside {lim} (first at t = {t[i]:.6g} s)")
        if problems:
            raise InputError(f"{what} violates the limits of {self.name}: " + "; ".join(dict.fromkeys(problems)))


def moved_parameters(placement) -> np.ndarray:
    """(10, 10) A with π' = A·π: a body's standard parameters π (BODY_PARAMS: mass, first moments,
    inertia about the frame origin) in a frame whose pose in another is ``placement``
    (pinocchio.SE3: x' = R·x + p) → the same body's in that other frame:
    m' = m, h' = R·h + m·p, I' = R·I·Rᵀ − [R·h]×[p]× − [p]×[R·h]× − m·[p]×[p]×."""
    R, p = np.asarray(placement.rotation), np.asarray(placement.translation)
    P = _skew(p)
    out = np.empty((10, 10))
    for k, e in enumerate(np.eye(10)):
        m, h = e[0], e[1:4]
        xx, xy, yy, xz, yz, zz = e[4:]
        inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        H = _skew(R @ h)
        moved = R @ inertia @ R.T - H @ P - P @ H - m * P @ P
        out[:, k] = [m, *(R @ h + m * p), moved[0, 0], moved[0, 1], moved[1, 1], moved[0, 2], moved[1, 2],
                     moved[2, 2]]
    return out


def _skew(v: np.ndarray) -> np.ndarray:
    """[v]×: the matrix of v × ·."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def from_pinocchio(pmodel, name: str, source: str = "",
                   acceleration_limit: np.ndarray | float | None = None) -> RobotModel:
    """Wrap a Pinocchio model; checks it is a fixed-base chain of 1-DOF joints."""
    joints = []
    for i in range(1, pmodel.njoints):
        jm = pmodel.joints[i]
        if jm.nv != 1:
            raise InputError(f"{source or name}: joint '{pmodel.names[i]}' ({jm.shortname()}) has {jm.nv} degrees of "
                             "freedom; only fixed-base robots with 1-DOF joints are supported")
        joints.append(pmodel.names[i])
    if not joints:
        raise InputError(f"{source or name}: the model has no movable joint")
    nv = pmodel.nv
    lower = np.full(nv, -np.inf)
    upper = np.full(nv, np.inf)
    for i in range(1, pmodel.njoints):
        jm = pmodel.joints[i]
        if jm.nq == 1:  # revolute/prismatic: a position limit; continuous joints stay unlimited
            lo, hi = pmodel.lowerPositionLimit[jm.idx_q], pmodel.upperPositionLimit[jm.idx_q]
            if np.isfinite(lo) and np.isfinite(hi) and hi > lo:
                lower[jm.idx_v], upper[jm.idx_v] = lo, hi
    vel = np.array(pmodel.velocityLimit, dtype=float)
    vel = np.where((vel > 0) & np.isfinite(vel), vel, np.inf)
    if acceleration_limit is None:
        acceleration_limit = DEFAULT_ACCELERATION_LIMIT
    acc = np.broadcast_to(np.asarray(acceleration_limit, dtype=float), (nv,)).copy()
    return RobotModel(name, pmodel, joints, lower, upper, vel, acc, source)


def load_urdf(path: str | Path, acceleration_limit: np.ndarray | float | None = None) -> RobotModel:
    """A :class:`RobotModel` from a URDF file (``pinocchio.buildModelFromUrdf``, fixed base).

    The file's numbers are checked first (:func:`check_urdf_numbers`: the parser would print
    errors and carry on with a zero inertia), the moving bodies' inertials after the build
    (:func:`check_inertials`); InputError naming the link or joint, a body's inertia that only
    breaks the triangle inequalities kept in ``inertia_warnings``.
    """
    pin = _pin()
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such URDF file")
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise InputError(f"{path}: not a valid URDF model (XML: {exc})") from None
    check_urdf_numbers(root, str(path))
    try:
        pmodel = pin.buildModelFromUrdf(str(path))
    except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with the parser's message
        msg = " ".join(str(exc).split())
        raise InputError(f"{path}: not a valid URDF model ({msg[:300]})") from None
    robot = from_pinocchio(pmodel, pmodel.name or path.stem, str(path), acceleration_limit)
    children = {j.get("name"): c.get("link") for j in root.iter("joint") if (c := j.find("child")) is not None}
    robot.inertia_warnings = tuple(check_inertials(pmodel, children, str(path)))
    return robot


# URDF element → its numeric attributes and how many numbers each holds.
URDF_NUMBERS = {
    "origin": {"xyz": 3, "rpy": 3}, "axis": {"xyz": 3}, "mass": {"value": 1},
    "inertia": dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1),
    "limit": dict.fromkeys(("lower", "upper", "velocity", "effort"), 1),
    "dynamics": dict.fromkeys(("damping", "friction"), 1),
    "safety_controller": dict.fromkeys(("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"), 1),
    "calibration": dict.fromkeys(("rising", "falling", "reference_position"), 1),
    "mimic": dict.fromkeys(("multiplier", "offset"), 1),
    "box": {"size": 3}, "cylinder": {"radius": 1, "length": 1}, "sphere": {"radius": 1}, "mesh": {"scale": 3},
}
# Tolerances of the inertia checks: relative (moments as written in a URDF, to a few digits) and
# absolute, kg·m² (a point mass: moments of 1e-18 from rounding).
INERTIA_TOLERANCE = 1e-6
INERTIA_FLOOR = 1e-12


def check_urdf_numbers(root, where: str) -> None:
    """InputError naming the link or joint, element and attribute of the first number of the
    URDF ``root`` (an ElementTree element) that is not one or not finite (e.g. a xacro leftover
    ``${m1}``), or of a negative mass."""
    for kind in ("link", "joint"):
        for owner in root.iter(kind):
            name = owner.get("name")
            for el in owner.iter():
                for attr, count in URDF_NUMBERS.get(el.tag, {}).items():
                    text = el.get(attr)
                    if text is None:
                        continue
                    try:
                        values = [float(v) for v in text.split()]
                    except ValueError:
                        values = []
                    if len(values) != count or not all(np.isfinite(values)):
                        hint = " (a xacro expression: expand the file with xacro first)" if "$" in text else ""
                        raise InputError(f"{where}: {kind} '{name}': <{el.tag} {attr}=\"{text}\"> is not "
                                         f"{'a finite number' if count == 1 else f'{count} finite numbers'}{hint}")
                    if el.tag == "mass" and values[0] < 0:
                        raise InputError(f"{where}: link '{name}': negative mass {values[0]:g} kg")


def check_inertials(pmodel, children: dict[str, str], where: str) -> list[str]:
    """InputError naming the link (``children``: joint → its child link) when the body a movable
    joint of ``pmodel`` moves (its link and the links fixed to it) has no positive mass or a
    negative principal moment about its centre of mass; a warning (returned, one line per link)
    when its moments break the triangle inequalities: no rigid body has that inertia, but real
    CAD exports do (the real TIAGo's arm_1_link, by 2 %), and the data fit does not need it, only
    the consistent fit's prior, which skips such a body."""
    warnings = []
    for i in range(1, pmodel.njoints):
        joint, body = pmodel.names[i], pmodel.inertias[i]
        link = f"link '{children.get(joint, joint)}' (moved by joint '{joint}')"
        if not body.mass > 0:
            raise InputError(f"{where}: {link} has mass {body.mass:g} kg; a moving link needs a positive mass "
                             "(its <inertial>)")
        moments = np.linalg.eigvalsh(body.inertia)  # ascending, about the centre of mass
        tol = max(INERTIA_TOLERANCE * moments[-1], INERTIA_FLOOR)
        shown = f"principal moments {', '.join(f'{m:.6g}' for m in moments)} kg·m² about its centre of mass"
        if moments[0] < -tol:
            raise InputError(f"{where}: {link} has an inertia no rigid body has: {shown} (each must be ≥ 0 and at "
                             "most the sum of the other two)")
        if moments[0] + moments[1] < moments[2] - tol:
            warnings.append(f"{where}: {link} has an inertia no rigid body has: {shown} (the largest exceeds the "
                            "sum of the other two); --prior urdf does not pull that link toward it")
    return warnings


def example_robot_data_dir() -> Path:
    """The ``robots`` directory of the ``example-robot-data`` package (URDFs, offline)."""
    import site
    import sys

    roots = list(site.getsitepackages()) + [site.getusersitepackages()] + list(sys.path)
    for root in roots:
        p = Path(root) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if p.is_dir():
            return p
    raise InputError("example-robot-data is not installed ('pip install example-robot-data')")
