"""Arms the tool has never seen, on synthetic data: what the data resolve (dropped, held at the
URDF's values, fixed by the user), several logs in one fit (joint-wise sweeps), model joints the
log lacks (held), joints without usable effort, gravity in the one-joint model.

The robot is the little arm of :mod:`support.little_arm`: a continuous base pan joint and a
two-finger gripper (the joints a log of the arm does not hold) around a gravity-loaded shoulder,
an elbow and a wrist."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.errors import InputError
from frictionid_core.excitation.design import FourierTrajectory, fit_to_limits
from frictionid_core.identification import IdentifyRequest, identify, model_from_result, validate
from frictionid_core.io import save_csv
from frictionid_core.robots import load_urdf
from frictionid_core.synthetic import synthesize
from frictionid_core.systems import get_system, nominal_parameters
from frictionid_core.timeseries import JointSeries
from support.arm_logs import pendulum
from support.little_arm import ARM, FINGER, FRICTION, URDF, joint_xml, link_xml


@pytest.fixture(scope="module")
def arm_urdf(tmp_path_factory):
    path = tmp_path_factory.mktemp("arm") / "little_arm.urdf"
    path.write_text(URDF)
    return path


def recording(urdf, moving, *, seconds=12.0, seed=0, q0=None, source="arm", noise=0.002):
    """A log of the arm joints (shoulder, elbow, wrist) at 500 Hz, the joints of ``moving`` on a
    Fourier excitation, the others still at ``q0`` (default 0.3 rad); pan at 0, fingers at FINGER."""
    robot = load_urdf(urdf)
    rng = np.random.default_rng(seed)
    a, b = np.zeros((robot.nv, 3)), np.zeros((robot.nv, 3))
    start = np.zeros(robot.nv)
    for k, j in enumerate(robot.joints):
        start[k] = FINGER if j.startswith("finger") else (0.0 if j == "pan" else (q0 or {}).get(j, 0.3))
        if j in moving:
            a[k], b[k] = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
    traj = fit_to_limits(robot, FourierTrajectory(list(robot.joints), start, a, b, 2 * np.pi / 4, seconds), 0.2)
    params = {j: {"Fv": fv, "Fc": fc} for j, (fv, fc) in FRICTION.items()}
    series, _ = synthesize(robot, traj, friction="coulomb", friction_params=params, torque_noise=noise, rate=500.0,
                           seed=seed, source=source)
    return series.select(ARM)


def run_json(argv, path):
    assert main([*map(str, argv), "--json", str(path)]) == 0
    return json.loads(path.read_text())


# --------------------------------------------------------------------------- held joints
def test_model_joints_the_log_lacks_are_held(arm_urdf, tmp_path, capsys):
    """The log holds the arm only: refused naming the missing joints and both flags; held (the
    fingers where they were, the pan at 0 by --hold-missing) the friction comes back, the result
    lists the held joints and validate holds them again."""
    system = f"urdf:{arm_urdf}"
    est, val = recording(arm_urdf, ARM, seed=1), recording(arm_urdf, ARM, seed=2, source="val")
    missing = r"\['pan', 'finger_l', 'finger_r'\]"
    with pytest.raises(InputError, match=rf"arm: system 'urdf:.*' needs every joint of its model: missing from the "
                                         rf"data: {missing}.*--hold-missing.*--hold JOINT=VALUE"):
        identify(est, IdentifyRequest(system=system))
    request = IdentifyRequest(system=system, hold={"finger_l": FINGER, "finger_r": FINGER}, hold_missing=True)
    r = identify(est, request)
    assert r.held_joints == {"finger_l": FINGER, "finger_r": FINGER, "pan": 0.0}
    assert r.joints == ARM and r.no_effort_joints == []
    for j in ARM:
        assert r.params[f"{j}/Fv"] == pytest.approx(FRICTION[j][0], rel=0.03), j
        assert r.params[f"{j}/Fc"] == pytest.approx(FRICTION[j][1], rel=0.03), j
    assert not any(n.startswith(("finger", "pan")) and "/" in n for n in r.params)  # no friction of held joints
    assert r.drive is None and not any("sign opposite" in w for w in r.warnings)
    assert validate(val, r)["relerr_pct"] < 1.2 * r.metrics["relerr_pct"]
    back = json.loads(json.dumps(r.to_dict()))
    assert back["held_joints"] == r.held_joints and validate(val, back) == validate(val, r)
    # the CLI: error line naming both flags; --hold/--hold-missing; validate needs no flag
    save_csv(est, tmp_path / "est.csv")
    save_csv(val, tmp_path / "val.csv")
    assert main(["identify", str(tmp_path / "est.csv"), "--system", system]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--hold-missing" in err and "--hold JOINT=VALUE" in err and "Traceback" not in err
    cli = run_json(["identify", tmp_path / "est.csv", "--system", system, "--hold", f"finger_l={FINGER}",
                    "--hold", f"finger_r={FINGER}", "--hold-missing"], tmp_path / "r.json")
    assert cli["held_joints"] == r.held_joints and cli["params"] == pytest.approx(r.params, rel=1e-9, abs=1e-12)
    assert "held still: " in capsys.readouterr().out
    v = run_json(["validate", tmp_path / "val.csv", "--params", tmp_path / "r.json"], tmp_path / "v.json")
    assert v["metrics"]["relerr_pct"] == pytest.approx(validate(val, r)["relerr_pct"], rel=1e-9)


def negated(series: JointSeries, joint: str) -> JointSeries:
    """``series`` with the effort of ``joint`` negated (a driver's sign opposite to the URDF axis)."""
    effort = series.effort.copy()
    effort[:, series.joints.index(joint)] *= -1.0
    return replace(series, effort=effort)


def test_an_effort_logged_against_the_joint_axis_is_negated(arm_urdf, tmp_path, capsys):
    """The elbow's effort logged with the opposite sign: fitted as logged its friction ends at the
    sign constraint's 0; the check fits it negated (auto: that fit, its drive holding the sign, the
    friction back within 3 %, validate reading the drive; as-logged: the log's fit and a warning
    naming the joint). Links of held joints keep the model's inertials (the data see their sum only)."""
    system = f"urdf:{arm_urdf}"
    holds = {"finger_l": FINGER, "finger_r": FINGER}
    est = negated(recording(arm_urdf, ARM, seed=1), "elbow")
    val = negated(recording(arm_urdf, ARM, seed=2, source="val"), "elbow")
    r = identify(est, IdentifyRequest(system=system, hold=holds, hold_missing=True))
    assert r.drive["joints"] == ARM and r.drive["effort_scale"] == [1.0, -1.0, 1.0]
    flagged = [w for w in r.warnings if "sign opposite to the model's joint axes" in w]
    assert len(flagged) == 1 and flagged[0].startswith("the effort of elbow is logged"), r.warnings
    for j in ARM:
        assert r.params[f"{j}/Fv"] == pytest.approx(FRICTION[j][0], rel=0.03), j
        assert r.params[f"{j}/Fc"] == pytest.approx(FRICTION[j][1], rel=0.03), j
    assert r.request.effort_sign == "auto" and r.request.drive is None  # the request reruns to the same fit
    assert validate(val, r)["relerr_pct"] < 1.2 * r.metrics["relerr_pct"]
    for finger in holds:  # held: as modelled, not spread over by the reconstruction
        link = r.plausibility["links"][finger]
        assert link["mass"] == pytest.approx(link["model_mass"], rel=1e-6) and not link["problems"]
    kept = identify(est, IdentifyRequest(system=system, hold=holds, hold_missing=True, effort_sign="as-logged"))
    assert kept.drive is None and kept.params["elbow/Fc"] == 0.0 and kept.params["elbow/Fv"] == 0.0
    assert any(w.startswith("the effort of elbow seems logged with the sign opposite") for w in kept.warnings)
    assert kept.metrics["per_joint"]["elbow"]["relerr_pct"] > 2 * r.metrics["per_joint"]["elbow"]["relerr_pct"]
    # the command line: the flag, and validate with the result's drive
    save_csv(est, tmp_path / "est.csv")
    save_csv(val, tmp_path / "val.csv")
    cli = run_json(["identify", tmp_path / "est.csv", "--system", system, "--hold-missing", "--hold",
                    f"finger_l={FINGER},finger_r={FINGER}"], tmp_path / "r.json")
    assert cli["drive"]["effort_scale"] == [1.0, -1.0, 1.0]
    assert "sign opposite to the model's joint axes" in capsys.readouterr().err
    v = run_json(["validate", tmp_path / "val.csv", "--params", tmp_path / "r.json"], tmp_path / "v.json")
    assert v["metrics"]["relerr_pct"] == pytest.approx(validate(val, r)["relerr_pct"], rel=1e-6)
    as_logged = run_json(["identify", tmp_path / "est.csv", "--system", system, "--hold-missing", "--hold",
                          f"finger_l={FINGER},finger_r={FINGER}", "--effort-sign", "as-logged"], tmp_path / "k.json")
    assert as_logged.get("drive") is None and as_logged["params"]["elbow/Fc"] == 0.0


def test_the_held_position_enters_the_dynamics(arm_urdf):
    """The elbow stays still at 0.3 rad and the log lacks it: held there, the shoulder and wrist
    fit as well as with the elbow logged; held at 0 (a wrong guess) the wrist's axis is elsewhere
    and the fit is worse. (A held joint at the end of the chain would merely regroup its bodies
    with the hand's: any position fits alike there.)"""
    system = f"urdf:{arm_urdf}"
    est = recording(arm_urdf, ["shoulder", "wrist"], seed=1, noise=1e-5)
    holds = {"finger_l": FINGER, "finger_r": FINGER}
    logged = identify(est, IdentifyRequest(system=system, hold=holds, hold_missing=True, joints=["shoulder", "wrist"]))
    lacking = est.select(["shoulder", "wrist"])
    right = identify(lacking, IdentifyRequest(system=system, hold={**holds, "elbow": 0.3}, hold_missing=True))
    wrong = identify(lacking, IdentifyRequest(system=system, hold={**holds, "elbow": 0.0}, hold_missing=True))
    assert right.joints == ["shoulder", "wrist"] and "elbow/Fv" not in right.params
    assert right.held_joints["elbow"] == 0.3 and right.metrics["relerr_pct"] == pytest.approx(
        logged.metrics["relerr_pct"], rel=1e-3)
    assert wrong.metrics["relerr_pct"] > 1.5 * right.metrics["relerr_pct"]


# ------------------------------------------------------------------------ identifiability
LIFTER = "".join([
    '<robot name="lifter"><link name="base"/>',
    link_xml("carriage", 5.0, "0 0 0.05", 0.05), link_xml("arm", 1.5, "0.2 0 0", 0.02),
    link_xml("tool", 0.3, "0.05 0 0", 0.001),
    joint_xml("lift", "prismatic", "base", "carriage", "0 0 0.2", "0 0 1",
           '<limit lower="0" upper="0.6" effort="200" velocity="0.5"/>'),
    joint_xml("elbow", "revolute", "carriage", "arm", "0 0 0.1", "0 1 0",
           '<limit lower="-2.5" upper="2.5" effort="30" velocity="3"/>'),
    joint_xml("wrist", "revolute", "arm", "tool", "0.4 0 0", "1 0 0",
           '<limit lower="-3" upper="3" effort="10" velocity="3"/>'),
    "</robot>"])
LIFT_SPEED = 0.03  # m/s, upwards the whole log
LIFTER_FRICTION = {"lift": (40.0, 8.0, 0.5), "elbow": (1.0, 0.5, 0.1), "wrist": (0.4, 0.2, -0.05)}  # Fv, Fc, offset


@pytest.fixture(scope="module")
def lifter(tmp_path_factory):
    """(URDF path, log): a vertical lift rising at constant speed under a swinging arm and wrist,
    500 Hz, exact positions, torque noise 0.01. On these data the lift's gravity load (its mass
    column, g), its Coulomb level and offset (1) and its viscous friction (q̇, constant) are one
    direction: three of the four are unresolved."""
    path = tmp_path_factory.mktemp("lifter") / "lifter.urdf"
    path.write_text(LIFTER)
    robot = load_urdf(path)
    t = np.arange(6000) / 500.0
    w = 2 * np.pi / 4
    q = np.column_stack([0.1 + LIFT_SPEED * t, 0.8 * np.sin(w * t) + 0.3 * np.sin(3 * w * t + 1),
                         1.2 * np.sin(2 * w * t + 0.5)])
    qd = np.column_stack([np.full_like(t, LIFT_SPEED), 0.8 * w * np.cos(w * t) + 0.9 * w * np.cos(3 * w * t + 1),
                          2.4 * w * np.cos(2 * w * t + 0.5)])
    qdd = np.column_stack([np.zeros_like(t), -0.8 * w**2 * np.sin(w * t) - 2.7 * w**2 * np.sin(3 * w * t + 1),
                           -4.8 * w**2 * np.sin(2 * w * t + 0.5)])
    tau = robot.inverse_dynamics(q, qd, qdd)
    for k, j in enumerate(robot.joints):
        fv, fc, offset = LIFTER_FRICTION[j]
        tau[:, k] += fv * qd[:, k] + fc * np.sign(qd[:, k]) + offset
    tau += np.random.default_rng(5).normal(0.0, 0.01, tau.shape)
    return path, JointSeries(t, list(robot.joints), q, tau, source="lifter")


def test_unresolved_directions_are_dropped_and_named(lifter):
    path, log = lifter
    r = identify(log, IdentifyRequest(system=f"urdf:{path}"))
    ident = r.identifiability
    # a lift rising at constant speed resolves neither its gravity load apart from its friction
    # nor its rotor inertia (q̈ = 0: its column holds only the filter's residue)
    assert ident["action"] == "dropped" and ident["rank"] + 4 == ident["columns"]
    mass = next(n for n in ident["unresolved"] if not n.startswith("lift/") and n != "lift.Ia")
    assert sorted(ident["unresolved"]) == sorted([mass, "lift.Ia", "lift/Fc", "lift/offset"])
    # ties keep friction: each folds into the lift's viscous term (column q̇ = LIFT_SPEED)
    assert ident["folded_into"]["lift/Fc"] == {"lift/Fv": pytest.approx(1 / LIFT_SPEED, rel=1e-6)}
    assert ident["folded_into"]["lift/offset"] == {"lift/Fv": pytest.approx(1 / LIFT_SPEED, rel=1e-6)}
    for name in ident["unresolved"]:
        assert r.params[name] == 0.0 and np.isnan(r.std[name])
    assert any("do not resolve 4 direction(s)" in w and "lift/Fc" in w and "--prior urdf" in w for w in r.warnings)
    assert any("lift moves in one direction only" in w for w in r.warnings)
    # as good as an independent least-squares fit of the same columns that drops what it cannot solve
    model, x = model_from_result(log, r)
    X, y = model.design(), model.obs.y
    norms = np.linalg.norm(X, axis=0)
    used = norms > 1e-6 * norms.max()  # a column of filter residue (the lift's q̈) solves nothing
    theta = np.linalg.lstsq(X[:, used], y, rcond=1e-10)[0]
    independent = 100 * np.linalg.norm(y - X[:, used] @ theta) / np.linalg.norm(y)
    # (the sign constraints of the one constraint policy may hold a parameter the free fit puts just
    # below 0: never better than the free fit, and within 1 % of its error, itself 0.008 %: the noise)
    relerr = 100 * np.linalg.norm(y - model.predict(x)) / np.linalg.norm(y)
    assert independent * (1 - 1e-9) <= relerr <= independent * 1.01
    for j in ("elbow", "wrist"):
        assert r.params[f"{j}/Fc"] == pytest.approx(LIFTER_FRICTION[j][1], rel=0.05), j


def test_unresolved_directions_held_at_the_urdf_or_fixed(lifter):
    """--prior urdf holds the lift's gravity load at the URDF's mass (the friction and offset
    columns resolved first); --fix covers the same directions by the user's values; with
    --consistent the prior makes the program well posed."""
    path, log = lifter
    system = f"urdf:{path}"
    dropped = identify(log, IdentifyRequest(system=system))
    prior = identify(log, IdentifyRequest(system=system, prior="urdf"))
    ident = prior.identifiability
    nominal = nominal_parameters(get_system(system))
    mass = [n for n in ident["unresolved"] if not n.startswith("lift/") and n != "lift.Ia"]
    assert ident["action"] == "prior" and len(mass) == 1 and nominal[mass[0]] > 1.0
    assert ident["held"] == {mass[0]: nominal[mass[0]], "lift.Ia": nominal["lift.Ia"], "lift/Fc": 0.0,
                             "lift/offset": 0.0}
    assert prior.params[mass[0]] == nominal[mass[0]] and np.isnan(prior.std[mass[0]])
    # the lift's friction now carries only what the mass does not: Fv·v = Fv_true·v + Fc_true + offset_true
    fv, fc, offset = LIFTER_FRICTION["lift"]
    assert prior.params["lift/Fv"] * LIFT_SPEED == pytest.approx(fv * LIFT_SPEED + fc + offset, rel=1e-3)
    # the prediction is the same: the held directions fold into the others either way (but for the
    # held rotor inertia's column, the filter's residue on the lift, ≈ 1e-8 of the others)
    assert prior.metrics["relerr_pct"] == pytest.approx(dropped.metrics["relerr_pct"], rel=1e-4)
    fixes = {"lift/Fc": fc, "lift/offset": offset, "lift/Fv": fv, "lift.Ia": nominal["lift.Ia"]}
    fixed = identify(log, IdentifyRequest(system=system, fixed=fixes))
    assert fixed.identifiability["action"] == "fixed"
    assert fixed.fixed == fixes and not any("do not resolve" in w for w in fixed.warnings)
    assert fixed.params[mass[0]] == pytest.approx(nominal[mass[0]], rel=1e-3)  # the mass, once friction is known
    consistent = identify(log, IdentifyRequest(system=system, prior="urdf", consistent=True))
    assert consistent.consistency["feasible"] and consistent.params[mass[0]] == pytest.approx(nominal[mass[0]])
    assert consistent.metrics["relerr_pct"] < 1.05 * dropped.metrics["relerr_pct"]


def test_fix_takes_rigid_body_names_with_a_slash(lifter):
    path, log = lifter
    r = identify(log, IdentifyRequest(system=f"urdf:{path}"))
    name = next(n for n in r.params if n.startswith("elbow.") and n not in r.identifiability["unresolved"])
    joint, _, p = name.partition(".")
    alias = f"{joint}/{p.removesuffix('R')}"
    fixed = identify(log, IdentifyRequest(system=f"urdf:{path}", fixed={alias: 0.1}))
    assert fixed.params[name] == 0.1 and fixed.fixed == {name: 0.1} and fixed.std[name] == 0.0


# -------------------------------------------------------------------------- several logs
def test_joint_wise_sweeps_are_fitted_together(arm_urdf, tmp_path, capsys):
    """Three logs, each moving one joint (the others still, gravity-loaded): alone, a sweep fits
    the joint it moves and holds the others where they stand, naming them; together each joint is
    fitted where it moves, the fit resolves more than any sweep alone and recovers each joint's
    friction; an error about one log names it."""
    sweeps = [recording(arm_urdf, [j], seed=10 + k, q0={"shoulder": 0.2 * k, "elbow": 0.5 - 0.3 * k},
                        source=f"sweep_{j}") for k, j in enumerate(ARM)]
    request = IdentifyRequest(system=f"urdf:{arm_urdf}", hold={"finger_l": FINGER, "finger_r": FINGER},
                              hold_missing=True)
    first = identify(sweeps[0], request)
    assert first.joints == ["shoulder"] and first.unexcited_joints == ["elbow", "wrist"]
    assert first.held_joints["elbow"] == pytest.approx(0.5, abs=1e-4) and "elbow/Fc" not in first.params
    assert any(w.startswith("sweep_shoulder: elbow, wrist do not move enough to excite their columns (elbow: motion "
                            "is noise") and "as --hold would" in w for w in first.warnings), first.warnings
    r = identify(sweeps, request)
    assert r.unexcited_joints == ARM  # each one still in the two sweeps of the others
    assert r.source == [s.source for s in sweeps] and r.joints == ARM
    # each joint judged where it moves: no joint's still q̈ in another sweep reads as noise-dominated
    assert not any("the acceleration is noise-dominated" in w for w in r.warnings), r.warnings
    assert set(r.preprocessing["moving_joints"]) == set(ARM)
    for j in ARM:
        assert r.params[f"{j}/Fv"] == pytest.approx(FRICTION[j][0], rel=0.05), j
        assert r.params[f"{j}/Fc"] == pytest.approx(FRICTION[j][1], rel=0.05), j
    alone = identify(sweeps[1], IdentifyRequest(system=request.system, hold=request.hold, hold_missing=True,
                                                joints=["elbow"]))
    assert r.identifiability["rank"] > alone.identifiability["rank"]
    still = JointSeries(sweeps[0].t, ARM, np.full_like(sweeps[0].position, 0.3), sweeps[0].effort, source="nothing")
    with pytest.raises(InputError, match="^nothing: no joint moves"):
        identify([*sweeps, still], request)
    for s in sweeps:
        save_csv(s, tmp_path / f"{s.source}.csv")
    files = [tmp_path / f"{s.source}.csv" for s in sweeps]
    cli = run_json(["identify", *files, "--system", f"urdf:{arm_urdf}", "--hold", f"finger_l={FINGER}",
                    "--hold", f"finger_r={FINGER}", "--hold-missing"], tmp_path / "r.json")
    assert cli["params"]["elbow/Fc"] == pytest.approx(FRICTION["elbow"][1], rel=0.05)


# --------------------------------------------------------------------- no usable effort
def test_a_joint_without_effort_is_left_out_and_named(arm_urdf):
    """The wrist moves but reports ±0.01 around 0 (a channel without torque): its rows leave the
    fit with a warning naming it, its motion stays in the others' dynamics."""
    est = recording(arm_urdf, ARM, seed=4)
    rng = np.random.default_rng(0)
    est.effort[:, 2] = np.round(rng.normal(0.0, 0.004, len(est)), 2)  # mostly 0.0, a few ±0.01
    r = identify(est, IdentifyRequest(system=f"urdf:{arm_urdf}", hold_missing=True,
                                      hold={"finger_l": FINGER, "finger_r": FINGER}))
    assert r.no_effort_joints == ["wrist"] and r.joints == ["shoulder", "elbow"]
    assert "wrist/Fv" not in r.params
    assert any("no usable effort from wrist" in w and "left out" in w for w in r.warnings)
    for j in ("shoulder", "elbow"):
        assert r.params[f"{j}/Fc"] == pytest.approx(FRICTION[j][1], rel=0.05), j


# --------------------------------------------------------------------- gravity, one joint
def test_gravity_in_the_one_joint_model(tmp_path):
    s, val = pendulum(), pendulum(seed=1, phase=1.1, source="val")
    r = identify(s, IdentifyRequest(system="joint", gravity=True))
    assert r.params["g_sin"] == pytest.approx(3.0 * np.cos(0.5), rel=0.01)
    assert r.params["g_cos"] == pytest.approx(3.0 * np.sin(0.5), rel=0.02)
    assert r.params["J"] == pytest.approx(0.05, rel=0.05) and r.params["Fc"] == pytest.approx(0.4, rel=0.03)
    without = identify(s, IdentifyRequest(system="joint"))
    assert validate(val, r)["relerr_pct"] < 0.1 * validate(val, without)["relerr_pct"]
    save_csv(s, tmp_path / "p.csv")
    save_csv(val, tmp_path / "v.csv")
    cli = run_json(["identify", tmp_path / "p.csv", "--system", "joint", "--gravity"], tmp_path / "r.json")
    assert cli["params"]["g_sin"] == pytest.approx(r.params["g_sin"], rel=1e-9)
    v = run_json(["validate", tmp_path / "v.csv", "--params", tmp_path / "r.json"], tmp_path / "v.json")
    assert v["metrics"]["relerr_pct"] == pytest.approx(validate(val, r)["relerr_pct"], rel=1e-9)
    # two joints in two sweeps, one gravity-loaded each: prefixed names
    other = JointSeries(s.t, ["k"], s.position, s.effort, source="k")
    both = identify([s, other], IdentifyRequest(system="joint", gravity=True))
    assert both.params["k/g_sin"] == pytest.approx(r.params["g_sin"], rel=1e-6)
