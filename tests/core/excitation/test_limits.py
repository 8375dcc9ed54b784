"""``frictionid excite`` within every limit of the robot (issue 39, item 1): position, velocity,
acceleration and effort limits with the margin, collisions (pairs of non-adjacent links, a floor) with a
clearance, a trajectory starting and ending at rest, the report.

Each design is checked here INDEPENDENTLY of the product's own checks: from the written CSV, velocity
and acceleration by finite differences of the positions, torques by ``pinocchio.rnea`` on a model built
here from the URDF plus the documented nominal friction, distances by coal on the URDF's own collision
geometry (the meshes, not the hulls the design uses)."""

from __future__ import annotations

import itertools
import json
import re
import time
from pathlib import Path

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.errors import InputError
from frictionid_core.excitation.design import FourierTrajectory, load_trajectory, optimise_excitation, robot_of
from frictionid_core.robots import example_robot_data_dir

UR5 = "ur_description/urdf/ur5_robot.urdf"

# A three-link arm in the x-z plane with primitive collision bodies (fast distances): folding the
# elbow or the wrist brings the hand to the base or the upper arm; the hand's second body (a rod
# pointing back) overlaps the upper arm at the zero pose, so that pair is left out.
ARM3 = """<?xml version="1.0"?>
<robot name="arm3">
  <link name="base">
    <collision><origin xyz="0 0 0.1" rpy="0 0 0"/><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="upper">
    <inertial><origin xyz="0.2 0 0" rpy="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/></inertial>
    <collision><origin xyz="0.2 0 0" rpy="0 1.5707963 0"/><geometry><cylinder radius="0.04" length="0.3"/></geometry>
    </collision>
  </link>
  <link name="fore">
    <inertial><origin xyz="0.15 0 0" rpy="0 0 0"/><mass value="1.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="0.15 0 0" rpy="0 1.5707963 0"/><geometry><cylinder radius="0.035" length="0.2"/>
    </geometry></collision>
  </link>
  <link name="hand">
    <inertial><origin xyz="0.1 0 0" rpy="0 0 0"/><mass value="0.5"/>
      <inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
    <collision><origin xyz="0.1 0 0" rpy="0 0 0"/><geometry><sphere radius="0.05"/></geometry></collision>
    <collision><origin xyz="-0.2 0 0" rpy="0 0 0"/><geometry><box size="0.5 0.03 0.03"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" velocity="3" effort="25"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="0.4 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.8" upper="2.8" velocity="3" effort="15"/>
  </joint>
  <joint name="wrist" type="revolute">
    <parent link="fore"/><child link="hand"/><origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.8" upper="2.8" velocity="4" effort="6"/>
  </joint>
</robot>
"""


@pytest.fixture
def arm3(tmp_path) -> Path:
    path = tmp_path / "arm3.urdf"
    path.write_text(ARM3)
    return path


@pytest.fixture(scope="module")
def ur5_path() -> Path:
    return example_robot_data_dir() / UR5


# ------------------------------------------------------------------------ independent checks
def read_csv(path: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    head = path.read_text().splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    joints = [h[2:] for h in head if h.startswith("q:")]
    return joints, data[:, 0], data[:, [head.index(f"q:{j}") for j in joints]]


def independent_ratios(urdf: Path, csv: Path, max_acc: float = 10.0) -> dict:
    """Worst ratios from the samples of ``csv`` alone: finite differences, pinocchio.rnea on a model
    built here from ``urdf`` and the nominal friction (Fc and Fv·v_max each 5 % of the effort limit)."""
    import pinocchio as pin

    joints, t, q = read_csv(csv)
    h = t[1] - t[0]
    qd = np.gradient(q, h, axis=0, edge_order=2)
    qdd = np.gradient(qd, h, axis=0, edge_order=2)
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    assert [model.names[i] for i in range(1, model.njoints)] == joints
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    vmax, emax = model.velocityLimit, model.effortLimit
    tau = np.array([pin.rnea(model, data, *x) for x in zip(q, qd, qdd)])
    tau += 0.05 * emax / vmax * qd + 0.05 * emax * np.sign(qd)
    return {"position": float(np.max(np.abs(q - (lo + hi) / 2) / ((hi - lo) / 2))),
            "velocity": float(np.max(np.abs(qd) / vmax)), "acceleration": float(np.max(np.abs(qdd) / max_acc)),
            "effort": float(np.max(np.abs(tau) / emax)), "t": t, "q": q, "qd": qd, "qdd": qdd}


def independent_min_distance(urdf: Path, q: np.ndarray, floor: float | None = None,
                             package_dirs: list[str] | None = None) -> float:
    """The smallest coal distance over the configurations q between the URDF's own collision bodies
    (meshes as meshes) of links neither the same body nor parent and child, the pairs in contact at
    q = 0 left out; with ``floor``, every moving body's lowest point above z = floor."""
    import coal
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(urdf))
    geom = pin.buildGeomFromUrdf(model, str(urdf), pin.GeometryType.COLLISION, package_dirs=package_dirs or [])
    objects = geom.geometryObjects
    for i, j in itertools.combinations(range(geom.ngeoms), 2):
        a, b = objects[i].parentJoint, objects[j].parentJoint
        if a != b and model.parents[a] != b and model.parents[b] != a:
            geom.addCollisionPair(pin.CollisionPair(i, j))
    data, gdata = model.createData(), pin.GeometryData(geom)
    pin.computeDistances(model, data, geom, gdata, np.zeros(model.nq))
    apart = np.array([r.min_distance > 0 for r in gdata.distanceResults])
    out = np.inf
    lows = []
    for x in q:
        pin.computeDistances(model, data, geom, gdata, x)
        out = min(out, min(r.min_distance for r, keep in zip(gdata.distanceResults, apart) if keep))
        if floor is not None:
            plane, moved = coal.Halfspace(np.array([0.0, 0.0, 1.0]), floor), []
            for k, o in enumerate(objects):
                if o.parentJoint != 0:
                    placement = gdata.oMg[k]
                    res = coal.DistanceResult()
                    moved.append(coal.distance(o.geometry, coal.Transform3s(placement.rotation, placement.translation),
                                               plane, coal.Transform3s(), coal.DistanceRequest(), res))
            lows.append(min(moved))
    return float(min([out, *lows]))


# --------------------------------------------------------------------------------- trajectory
def test_ramped_trajectory_starts_and_ends_at_rest_with_exact_derivatives(tmp_path):
    rng = np.random.default_rng(0)
    traj = FourierTrajectory(["a", "b"], np.array([0.2, -0.1]), rng.uniform(-1, 1, (2, 3)), rng.uniform(-1, 1, (2, 3)),
                             2 * np.pi / 4, 8.0, 1.5)
    ends = traj.evaluate(np.array([0.0, 8.0]))
    for k in range(2):
        np.testing.assert_allclose(ends[0][k], traj.start_pose, atol=1e-12)
        np.testing.assert_allclose(ends[1][k], 0.0, atol=1e-12)
        np.testing.assert_allclose(ends[2][k], 0.0, atol=1e-12)
    # in the middle: the plain series
    plain = FourierTrajectory(["a", "b"], traj.q0, traj.a, traj.b, traj.wf, 8.0)
    for x, y in zip(traj.evaluate(np.array([1.5, 4.0, 6.5])), plain.evaluate(np.array([1.5, 4.0, 6.5]))):
        np.testing.assert_allclose(x, y, atol=1e-12)
    h = 1e-5
    tt = np.linspace(0.01, 7.99, 400)
    d1 = (traj.evaluate(tt + h)[0] - traj.evaluate(tt - h)[0]) / (2 * h)
    d2 = (traj.evaluate(tt + h)[1] - traj.evaluate(tt - h)[1]) / (2 * h)
    np.testing.assert_allclose(d1, traj.evaluate(tt)[1], atol=1e-6)
    np.testing.assert_allclose(d2, traj.evaluate(tt)[2], atol=1e-5)
    back = load_trajectory(traj.save(tmp_path / "r.npz"))
    assert back.ramp == 1.5
    np.testing.assert_array_equal(back.sample(100.0)[1], traj.sample(100.0)[1])


# ----------------------------------------------------------------------------- whole command
def test_excite_arm_within_every_limit_and_clearance_checked_independently(tmp_path, arm3, capsys):
    out, report = tmp_path / "t.csv", tmp_path / "r.json"
    code = main(["excite", "--system", f"urdf:{arm3}", "--harmonics", "3", "--period", "6", "--duration", "6",
                 "--evals", "300", "--starts", "4", "--collision", "--clearance", "0.02", "--floor", "0",
                 "--max-acc", "elbow=6,wrist=8", "--out", str(out), "--json", str(report)])
    assert code == 0, capsys.readouterr().err
    r = json.loads(report.read_text())
    margin = 0.05
    assert set(r["max_ratio"]) == {"position", "velocity", "acceleration", "effort"}
    assert all(0 < v <= 1 - margin for v in r["max_ratio"].values()), r["max_ratio"]
    assert r["min_clearance_m"] >= 0.02
    for key in ("cond", "cond_initial", "evaluations", "joints", "harmonics", "wf", "period", "duration", "system",
                "out", "trajectory"):  # the report's keys before limits (contract)
        assert key in r, key
    assert r["cond"] <= r["cond_initial"]
    assert r["limits"]["elbow"]["acceleration"] == 6.0 and r["limits"]["shoulder"]["acceleration"] == 10.0
    assert r["collision"]["excluded"]["in contact at the zero pose"] == ["upper|hand_1"]
    assert "base|upper" in r["collision"]["excluded"]["adjacent"]
    # independently, from the written samples
    got = independent_ratios(arm3, out, max_acc=1.0)
    acc = np.max(np.abs(got["qdd"]) / np.array([10.0, 6.0, 8.0]))
    for kind in ("position", "velocity", "effort"):
        assert got[kind] <= 1 - margin + 1e-3, (kind, got[kind])
        assert got[kind] == pytest.approx(r["max_ratio"][kind], rel=0.02, abs=1e-3), kind
    assert acc <= 1 - margin + 1e-3
    assert independent_min_distance(arm3, got["q"], floor=0.0) >= 0.02 - 1e-9
    # at rest at its start pose at both ends
    start = np.array([r["start_pose"][j] for j in ("shoulder", "elbow", "wrist")])
    np.testing.assert_allclose(got["q"][[0, -1]], [start, start], atol=1e-9)
    np.testing.assert_allclose(got["qd"][[0, -1]], 0.0, atol=1e-4)
    assert np.abs(got["qdd"][[0, -1]]).max() < 0.02  # finite differences of a quintic start: O(h)


def test_effort_limit_binds_and_is_held(tmp_path, arm3):
    """Effort limits low enough to bind (the shoulder's 25 → 12 N·m: gravity alone at the zero pose
    takes 11 N·m): the design holds them with the margin, checked from the samples."""
    weak = tmp_path / "weak.urdf"
    weak.write_text(arm3.read_text().replace('effort="25"', 'effort="16"'))
    out = tmp_path / "t.csv"
    code = main(["excite", "--system", f"urdf:{weak}", "--harmonics", "3", "--period", "5", "--duration", "5",
                 "--evals", "250", "--starts", "3", "--out", str(out), "--json", str(tmp_path / "r.json")])
    assert code == 0
    r = json.loads((tmp_path / "r.json").read_text())
    got = independent_ratios(weak, out)
    assert got["effort"] <= 0.95 + 1e-3 and r["max_ratio"]["effort"] > 0.8  # binding
    assert r["friction"]["source"].startswith("a nominal guess")


def test_friction_of_a_result_enters_the_effort(tmp_path, arm3):
    from frictionid_core.excitation.limits import motion_ratios, result_friction, robot_limits
    from frictionid_core.robots import load_urdf

    robot = load_urdf(arm3)
    result = {"friction": "coulomb", "asymmetric": False, "joints": ["a", "b"], "joint_map": {"a": "shoulder",
              "b": "elbow"}, "params": {"a/Fv": 2.0, "a/Fc": 3.0, "b/Fv": 1.0, "b/Fc": 0.5}}
    fr = result_friction(result, robot, "r.json")
    wrist = 0.5 * (0.05 * 6 / 4) + 0.05 * 6  # nominal: Fv·v_max and Fc each 5 % of the 6 N·m limit
    np.testing.assert_allclose(fr.torque(np.array([[1.0, -2.0, 0.5]])), [[5.0, -2.5, wrist]], rtol=1e-12)
    assert "wrist: a nominal guess" in fr.source
    limits = robot_limits(robot, friction=fr)
    still = motion_ratios(robot, limits, np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)))
    assert still["effort"][0, 0] == pytest.approx(abs(robot.gravity(np.zeros(3))[0, 0]) / 25.0)
    with pytest.raises(InputError, match="r.json: joint 'knee' of the result is not a joint of arm3"):
        result_friction(dict(result, joint_map={"a": "knee"}), robot, "r.json")
    with pytest.raises(InputError, match="friction acts on the drive's motors"):
        result_friction(dict(result, drive={"friction_on": "motor"}), robot, "r.json")


def test_excite_takes_the_friction_of_an_identification_result(tmp_path, capsys):
    from support.data import BAGS

    result = tmp_path / "j2.json"
    assert main(["identify", str(BAGS / "tx40_j2_excitation"), "--joints", "joint_2", "--system", "tx40-j2",
                 "--friction", "coulomb", "--solver", "ls", "--end", "6", "--json", str(result)]) == 0
    fitted = json.loads(result.read_text())["params"]
    code = main(["excite", "--system", "tx40-j2", "--params", str(result), "--harmonics", "2", "--period", "6",
                 "--duration", "6", "--evals", "60", "--starts", "2", "--out", str(tmp_path / "t.npz"),
                 "--json", str(tmp_path / "r.json")])
    assert code == 0
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["friction"]["joints"]["joint_2"] == {"law": "coulomb", "Fv": fitted["Fv"], "Fc": fitted["Fc"]}
    assert r["friction"]["source"].startswith(f"{result} (coulomb); joint_1, joint_3")
    assert f"friction from {result} (coulomb)" in capsys.readouterr().out
    assert main(["excite", "--system", "tx40-j2", "--params", str(result), "--out", str(result)]) == 2
    assert f"--out {result} is the input --params {result}: refusing to overwrite" in capsys.readouterr().err


def test_no_start_pose_names_the_pairs(tmp_path, ur5_path, capsys):
    code = main(["excite", "--system", f"urdf:{ur5_path}", "--floor", "0.2", "--out", str(tmp_path / "t.npz")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "no start pose at rest within the limits and clearances found near shoulder_pan_joint 0" in err
    assert "pair wrist_3_link|floor at -248 mm (clearance 10 mm)" in err and "--floor" in err


def test_tx40_j2_design_is_no_worse_than_the_limits_free_criterion(tmp_path):
    """The same duration and harmonics: the constrained design's cond (ramps, effort limits, the whole
    trajectory) is no worse than the optimiser that knew position, velocity and acceleration limits
    only (``optimise_excitation``, what excite ran before)."""
    from frictionid_core.excitation.limits import verify
    from frictionid_core.excitation.within_limits import design_excitation
    from frictionid_core.systems import get_system

    system = get_system("tx40-j2")
    robot, moving = robot_of(system, "tx40-j2")
    before = optimise_excitation(system, robot, moving=moving, harmonics=3, period=8.0, duration=8.0, evals=200,
                                 starts=4, seed=1)
    after = design_excitation(system, robot, moving=moving, harmonics=3, period=8.0, duration=8.0, evals=200,
                              starts=4, seed=1)
    assert after.cond <= before.cond
    assert after.report["ok"] and verify(robot, after.limits, after.trajectory)["ok"]
    assert not np.any(after.trajectory.a[[0, 2, 3, 4, 5]])


BAD = {
    "--max-acc junk": (["--max-acc", "fast"], "--max-acc item 'fast': expected JOINT=RAD/S²"),
    "--max-acc unknown joint": (["--max-acc", "knee=3"], "--max-acc: joint 'knee' is not a joint of arm3"),
    "--max-acc zero": (["--max-acc", "0"], "--max-acc: the acceleration limit of joint 'shoulder' must be > 0"),
    "--clearance alone": (["--clearance", "0.01"], "--clearance goes with --collision"),
    "--clearance negative": (["--collision", "--clearance", "-1"], "--clearance must be a distance ≥ 0 m"),
    "--margin": (["--margin", "1.5"], "--margin must be a fraction in [0, 1)"),
    "--ramp": (["--ramp", "11"], "--ramp must be > 0 and at most half the duration (10 s), got 11"),
    "--params missing": (["--params", "{tmp}/none.json"], "none.json"),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_excite_input_is_one_line(tmp_path, arm3, capsys, case):
    extra, message = BAD[case]
    code = main(["excite", "--system", f"urdf:{arm3}", "--out", str(tmp_path / "t.npz"), "--evals", "5",
                 "--starts", "1", *[e.format(tmp=tmp_path) for e in extra]])
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1, err
    assert not (tmp_path / "t.npz").exists()


def test_collision_needs_collision_geometry(tmp_path, capsys):
    bare = tmp_path / "bare.urdf"
    bare.write_text(re.sub(r"<collision>.*?</collision>", "", ARM3, flags=re.S))
    code = main(["excite", "--system", f"urdf:{bare}", "--collision", "--out", str(tmp_path / "t.npz")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert f"{bare}: the URDF has no <collision> geometry; --collision needs its links' collision bodies" in err
    code = main(["excite", "--system", "tx40", "--collision", "--out", str(tmp_path / "t.npz")])
    err = capsys.readouterr().err
    assert code == 2 and "--collision needs a URDF with collision geometry (--system urdf:PATH); tx40 has none" in err
    missing = tmp_path / "mesh.urdf"
    missing.write_text(ARM3.replace('<sphere radius="0.05"/>', '<mesh filename="package://nowhere/hand.stl"/>'))
    code = main(["excite", "--system", f"urdf:{missing}", "--collision", "--out", str(tmp_path / "t.npz")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and f"{missing}: cannot load its collision geometry" in err


def test_collision_pairs_and_distance_gradients_of_the_ur5(ur5_path):
    """Adjacent links are left out, the rest checked; hull distances bound the meshes' from below;
    the distance gradients (witness points) match finite differences."""
    from frictionid_core.excitation.collision import load_collision_model
    from frictionid_core.robots import load_urdf

    robot = load_urdf(ur5_path)
    col = load_collision_model(robot, ur5_path, 0.01)
    assert len(col.pairs) == 20 and "forearm_link|ee_link" in col.pairs
    assert col.excluded["in contact at the zero pose"] == [] and "wrist_3_link|ee_link" in col.excluded["adjacent"]
    q = np.random.default_rng(4).uniform(-2.0, 2.0, (4, 6))
    d, grad = col.distances(q, gradient=True)
    h = 1e-6
    fd = np.stack([(col.distances(q + h * e) - col.distances(q - h * e)) / (2 * h) for e in np.eye(6)], axis=-1)
    apart = d > 0.005  # penetration depths (EPA) are not smooth
    np.testing.assert_allclose(grad[apart], fd[apart], atol=1e-4)
    share = str(example_robot_data_dir().parents[1])
    assert d.min(axis=1)[0] <= independent_min_distance(ur5_path, q[:1], package_dirs=[share]) + 1e-9


# ---------------------------------------------------------------------------- acceptance (UR5)
@pytest.mark.slow
def test_ur5_excitation_with_collision_meets_every_limit_checked_independently(tmp_path, ur5_path, capsys):
    """Issue 39 item 1: the UR5 of example-robot-data, default duration and harmonics, --collision:
    every max_ratio ≤ 1 − margin and the clearance kept, checked from the written file alone (the
    meshes' own distances at 100 Hz); cond no worse than the limits-free design before (5.84)."""
    out, report = tmp_path / "ur5.csv", tmp_path / "r.json"
    start = time.perf_counter()
    code = main(["excite", "--system", f"urdf:{ur5_path}", "--collision", "--out", str(out), "--json", str(report)])
    seconds = time.perf_counter() - start
    assert code == 0, capsys.readouterr().err
    r = json.loads(report.read_text())
    assert all(v <= 0.95 for v in r["max_ratio"].values()) and r["min_clearance_m"] >= 0.01
    got = independent_ratios(ur5_path, out)
    for kind in ("position", "velocity", "acceleration", "effort"):
        assert got[kind] <= 0.95 + 1e-3, (kind, got[kind])
    share = str(example_robot_data_dir().parents[1])
    assert independent_min_distance(ur5_path, got["q"][::10], package_dirs=[share]) >= 0.01
    assert r["cond"] <= 5.84
    np.testing.assert_allclose(got["qd"][[0, -1]], 0.0, atol=1e-4)
    print(f"UR5 --collision: cond {r['cond']:.4g}, ratios {r['max_ratio']}, clearance {r['min_clearance_m']:.4g} m, "
          f"{seconds:.1f} s")
