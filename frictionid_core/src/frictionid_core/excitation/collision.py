"""Self-collision and floor distances of a URDF robot, for excitation design (``excite --collision``).

The bodies are the URDF's COLLISION geometry (``pinocchio.buildGeomFromUrdf``, meshes found through
``package://`` in the URDF's own folders, example-robot-data and ``ROS_PACKAGE_PATH``); each mesh is
replaced by its convex hull (qhull through coal), so a distance is signed (negative: penetration
depth) and a lower bound of the meshes' own distance: hulls kept ``clearance`` apart keep the meshes
at least that far apart. Distances are computed by coal (``pinocchio.computeDistances``).

Checked pairs: every two bodies of links that are neither the same rigid body nor parent and child
(joints ``i`` and ``parents[i]``), minus the pairs already in contact at the zero pose (q = 0): a pair
whose hulls touch there but whose meshes do not is checked on the meshes (unsigned distance, slower).
With a floor at z = Z (the base frame), every body that moves (not fixed to the base) is also kept
above it.

:meth:`CollisionModel.distances` gives each pair's distance per sample and, on request, its gradient
in q: with the witness points p₁, p₂ and the normal n from body 1 to body 2,
∂d/∂q = nᵀ(J(p₂) − J(p₁)), J(p) the linear velocity Jacobian of the point p of its body.
"""

from __future__ import annotations

import itertools
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError

DEFAULT_CLEARANCE = 0.01  # m


def _libs():
    try:
        import coal
        import pinocchio as pin
    except ImportError as exc:  # pragma: no cover - both pinned requirements
        raise InputError(f"--collision needs Pinocchio and coal ('pip install pin'): {exc}") from None
    return pin, coal


def package_dirs(urdf: Path) -> list[str]:
    """Where ``package://NAME/…`` of ``urdf`` is looked for: its folders up to the root (a URDF in its
    package tree), example-robot-data's ``share`` folder, ``ROS_PACKAGE_PATH``."""
    dirs = [str(p) for p in Path(urdf).resolve().parents]
    try:
        from frictionid_core.robots import example_robot_data_dir

        dirs.append(str(example_robot_data_dir().parents[1]))
    except InputError:
        pass
    dirs += [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    return list(dict.fromkeys(dirs))


@dataclass
class CollisionModel:
    """The checked pairs of a robot's collision bodies (see the module doc).

    Attributes:
        robot: the RobotModel (its Pinocchio model carries the joints).
        geom: the Pinocchio GeometryModel (hulls, mesh copies for the mesh pairs, the floor).
        pairs: "body_a|body_b" per checked pair (``floor`` for the floor), in distance order.
        excluded: {"adjacent": [...], "in contact at the zero pose": [...]} pair names left out.
        clearance: the distance every pair keeps, m.
        floor: z of the floor plane in the base frame, m (None: no floor).
        mesh_pairs: the pairs checked on the meshes (their hulls touch at the zero pose).
    """

    robot: object
    geom: object
    pairs: list[str]
    excluded: dict[str, list[str]]
    clearance: float
    floor: float | None
    mesh_pairs: list[str] = field(default_factory=list)
    _gdata: object = field(default=None, repr=False)
    _data: object = field(default=None, repr=False)

    def __post_init__(self) -> None:
        pin, _ = _libs()
        self._gdata = pin.GeometryData(self.geom)
        self._data = self.robot.model.createData()
        self._joint = np.array([self.geom.geometryObjects[int(i)].parentJoint
                                for cp in self.geom.collisionPairs for i in (cp.first, cp.second)]).reshape(-1, 2)

    def distances(self, q: np.ndarray, gradient: bool = False):
        """Distances (N, P) of the pairs at the configurations q (N, nv), m; with ``gradient`` also
        ∂d/∂q (N, P, nv)."""
        pin, _ = _libs()
        q = np.atleast_2d(np.asarray(q, dtype=float))
        m, d, g, gd = self.robot.model, self._data, self.geom, self._gdata
        n, npairs = q.shape[0], len(self.pairs)
        out = np.empty((n, npairs))
        if gradient:
            normal, points = np.empty((n, npairs, 3)), np.empty((2, n, npairs, 3))
            jac, origin = np.zeros((n, m.njoints, 6, m.nv)), np.zeros((n, m.njoints, 3))
            joints = sorted(int(j) for j in set(self._joint.ravel().tolist()) - {0})
        for k in range(n):
            qk = self.robot.configuration(q[k])
            pin.computeDistances(m, d, g, gd, qk)
            res = gd.distanceResults
            out[k] = [r.min_distance for r in res]
            if gradient:
                normal[k] = [r.normal for r in res]
                points[0, k] = [r.getNearestPoint1() for r in res]
                points[1, k] = [r.getNearestPoint2() for r in res]
                pin.computeJointJacobians(m, d, qk)
                for j in joints:
                    jac[k, j] = pin.getJointJacobian(m, d, j, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
                    origin[k, j] = d.oMi[j].translation
        if not gradient:
            return out
        grad = np.zeros((n, npairs, m.nv))
        for side, sign in ((0, -1.0), (1, 1.0)):
            idx = self._joint[:, side]
            J = jac[:, idx]  # (N, P, 6, nv); zero for a body fixed to the base
            arm = points[side] - origin[:, idx]
            grad += sign * (np.einsum("kpi,kpiv->kpv", normal, J[:, :, :3])
                            + np.einsum("kpi,kpiv->kpv", np.cross(arm, normal), J[:, :, 3:]))
        return out, grad


def _pair_name(geom, model, i: int, j: int) -> str:
    """"a|b": each body by its link's name, or by its own (``<link>_<k>``) when its link has several."""
    frames = [o.parentFrame for o in geom.geometryObjects if o.name != "floor" and "#mesh" not in o.name]

    def body(k):
        o = geom.geometryObjects[k]
        if o.name == "floor":
            return "floor"
        return model.frames[o.parentFrame].name if frames.count(o.parentFrame) == 1 else o.name.split("#")[0]

    return f"{body(i)}|{body(j)}"


def load_collision_model(robot, urdf: str | Path, clearance: float = DEFAULT_CLEARANCE,
                         floor: float | None = None) -> CollisionModel:
    """The :class:`CollisionModel` of ``robot`` (built from ``urdf``): InputError naming the file when
    it has no collision geometry or a mesh cannot be found or read."""
    pin, coal = _libs()
    urdf = Path(urdf)
    if not (np.isfinite(clearance) and clearance >= 0):
        raise InputError(f"--clearance must be a distance ≥ 0 m, got {clearance:g}")
    if floor is not None and not np.isfinite(floor):
        raise InputError(f"--floor must be a finite height, m, got {floor}")
    model = robot.model
    try:
        geom = pin.buildGeomFromUrdf(model, str(urdf), pin.GeometryType.COLLISION, package_dirs=package_dirs(urdf))
    except Exception as exc:  # ValueError/RuntimeError: a mesh not found or unreadable
        msg = " ".join(str(exc).split())
        raise InputError(f"{urdf}: cannot load its collision geometry ({msg[:300]}); meshes are looked for "
                         "through package:// in the URDF's folders, example-robot-data and ROS_PACKAGE_PATH"
                         ) from None
    if geom.ngeoms == 0:
        raise InputError(f"{urdf}: the URDF has no <collision> geometry; --collision needs its links' collision "
                         "bodies")
    bodies = list(range(geom.ngeoms))
    meshes = {}
    for k in bodies:
        o = geom.geometryObjects[k]
        if isinstance(o.geometry, coal.BVHModelBase):
            mesh = o.geometry
            try:
                mesh.buildConvexHull(True, "Qt")
                hull = mesh.convex
            except Exception:  # a flat or degenerate mesh: kept as a mesh
                continue
            meshes[k] = mesh.clone()
            o.geometry = hull
    parents = list(model.parents)

    def adjacent(i: int, j: int) -> bool:
        a, b = geom.geometryObjects[i].parentJoint, geom.geometryObjects[j].parentJoint
        return a == b or parents[a] == b or parents[b] == a

    excluded: dict[str, list[str]] = {"adjacent": [], "in contact at the zero pose": []}
    candidates = []
    for i, j in itertools.combinations(bodies, 2):
        if adjacent(i, j):
            excluded["adjacent"].append(_pair_name(geom, model, i, j))
        else:
            candidates.append((i, j))
    q_zero = pin.neutral(model)
    data = model.createData()
    pin.forwardKinematics(model, data, q_zero)
    gdata = pin.GeometryData(geom)
    pin.updateGeometryPlacements(model, data, geom, gdata)

    def zero_distance(g1, g2, i, j) -> float:
        req, res = coal.DistanceRequest(), coal.DistanceResult()
        return float(coal.distance(g1, _transform(coal, gdata.oMg[i]), g2, _transform(coal, gdata.oMg[j]), req, res))

    checked, mesh_pairs = [], []
    for i, j in candidates:
        oi, oj = geom.geometryObjects[i], geom.geometryObjects[j]
        name = _pair_name(geom, model, i, j)
        if zero_distance(oi.geometry, oj.geometry, i, j) > 0:
            checked.append((i, j))
            continue
        mi, mj = meshes.get(i, oi.geometry), meshes.get(j, oj.geometry)
        if (i in meshes or j in meshes) and zero_distance(mi, mj, i, j) > 0:
            mesh_pairs.append((i, j, name))
        else:
            excluded["in contact at the zero pose"].append(name)
    # mesh copies of the bodies of the mesh pairs, then the floor
    copies = {}
    for i, j, _ in mesh_pairs:
        for k in (i, j):
            if k in meshes and k not in copies:
                o = geom.geometryObjects[k]
                copies[k] = geom.addGeometryObject(pin.GeometryObject(f"{o.name}#mesh", o.parentJoint, o.parentFrame,
                                                                      o.placement, meshes[k]))
    names = []
    for i, j in checked:
        geom.addCollisionPair(pin.CollisionPair(i, j))
        names.append(_pair_name(geom, model, i, j))
    for i, j, name in mesh_pairs:
        geom.addCollisionPair(pin.CollisionPair(copies.get(i, i), copies.get(j, j)))
        names.append(name)
    if floor is not None:
        plane = geom.addGeometryObject(pin.GeometryObject("floor", 0, 0, pin.SE3.Identity(),
                                                          coal.Halfspace(np.array([0.0, 0.0, 1.0]), float(floor))))
        for k in bodies:
            if geom.geometryObjects[k].parentJoint != 0:
                geom.addCollisionPair(pin.CollisionPair(k, plane))
                names.append(_pair_name(geom, model, k, plane))
    if not names:
        raise InputError(f"{urdf}: no pair of collision bodies to check (all adjacent or in contact at the zero "
                         "pose) and no --floor")
    return CollisionModel(robot, geom, names, excluded, float(clearance), floor, [n for *_, n in mesh_pairs])


def _transform(coal, placement):
    return coal.Transform3s(placement.rotation, placement.translation)
