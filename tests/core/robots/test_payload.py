"""Payload identification (frictionid payload): the physics of a payload's columns, its fit on
synthetic TX40 and UR5 logs with a known payload, what a slow log leaves unresolved, the friction
re-fit, and the payload file's contract."""

from __future__ import annotations

import json

import numpy as np
import pytest

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import (
    IdentifyRequest,
    PayloadRequest,
    identify,
    identify_payload,
    loaded_result,
    model_from_result,
    read_payload,
    validate,
    validation_metrics,
)
from frictionid_core.robots import (
    QUANTITIES,
    Payload,
    body_quantities,
    default_link,
    frame_map,
    link_frame,
    random_samples,
    robot_with_payload,
)
from support.payload_logs import loaded_logs, robot_of

PAYLOAD_KEYS = ["link", "mass", "com", "inertia", "sigma", "feasible", "resolved"]


@pytest.fixture(scope="module", params=["tx40", "ur5"])
def fitted(request):
    """(logs, base result, payload result, full re-identification on the loaded log) per robot."""
    logs = loaded_logs(request.param)
    base = identify(logs.base, IdentifyRequest(system=logs.system, friction="coulomb")).to_dict()
    result = identify_payload(logs.loaded, base, PayloadRequest(), base_file="base.json")
    full = identify(logs.loaded, IdentifyRequest(system=logs.system, friction="coulomb")).to_dict()
    return logs, base, result, full


@pytest.mark.parametrize("name", ["tx40", "ur5"])
def test_payload_columns_are_the_torque_of_the_fixed_body(name):
    """The payload's ten columns (its link's body, carried from the link frame) times its
    parameters are the torque the payload adds to Pinocchio's inverse dynamics (to round-off)."""
    _, robot = robot_of(name)
    link = default_link(robot)
    assert link == {"tx40": "link_6", "ur5": "tool0"}[name]
    payload = Payload(link, 1.7, (0.05, 0.01, -0.04), ((0.02, 0.0, 0.001), (0.0, 0.03, 0.0), (0.001, 0.0, 0.01)))
    q, qd, qdd = random_samples(robot, 6, seed=2)
    added = robot_with_payload(robot, payload).inverse_dynamics(q, qd, qdd) - robot.inverse_dynamics(q, qd, qdd)
    _, joint, pose = link_frame(robot, link)
    columns = robot.regressor(q, qd, qdd)[..., 10 * (joint - 1): 10 * joint] @ frame_map(pose)
    assert np.max(np.abs(columns @ payload.standard() - added)) < 1e-12 * np.max(np.abs(added))
    assert np.max(np.abs(added)) > 1.0  # a real load on these samples
    back = Payload.from_standard(link, payload.standard())
    assert back.mass == pytest.approx(1.7) and np.allclose(back.inertia, payload.inertia, atol=1e-15)


@pytest.mark.slow
def test_synthetic_payload_within_tolerances(fitted):
    """Mass within 1 %, centre of mass within 5 mm, every resolved quantity within 3 σ of the truth,
    consistent; the base alone is far off on the loaded log, base + payload near the noise."""
    logs, _, result, _ = fitted
    p = result.payload
    truth = body_quantities(logs.payload.standard())
    assert p.feasible and list(p.resolved) == list(QUANTITIES)  # a rich excitation resolves all ten
    assert abs(p.mass - logs.payload.mass) < 0.01 * logs.payload.mass
    assert np.max(np.abs(np.subtract(p.com, logs.payload.com))) < 0.005
    estimate = body_quantities(p.standard())
    sigma = np.array([p.sigma["mass"], *p.sigma["com"],
                      *(p.sigma["inertia"][a][b] for a, b in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)))])
    z = np.abs(estimate - truth) / sigma
    assert np.all(z < 3.0), dict(zip(QUANTITIES, z.round(2)))
    assert result.metrics_base["relerr_pct"] > 15.0 and result.metrics["relerr_pct"] < 0.5
    assert set(result.metrics["per_joint"]) == set(logs.robot.joints)


@pytest.mark.slow
def test_validation_with_the_payload_matches_a_full_reidentification(fitted):
    """On another loaded log, BASE + payload validates within 1.1 × a full re-identification on
    the loaded log (and the base alone is over 15 %)."""
    logs, base, result, full = fitted
    model, x = model_from_result(logs.validation, loaded_result(base, result), payload=result.payload)
    with_payload = validation_metrics(model, x, ["validation"])["relerr_pct"]
    reidentified = validate(logs.validation, full)["relerr_pct"]
    assert with_payload <= 1.1 * reidentified
    assert validate(logs.validation, base)["relerr_pct"] > 15.0


@pytest.mark.slow
def test_slow_motion_leaves_the_inertia_held_at_a_point_mass():
    """At a twentieth of the excitation's speed the accelerations are 1/400: the inertia about the
    centre of mass is not resolved, held at the point mass' values and listed; mass and centre of
    mass still within 1 % and 5 mm."""
    from frictionid_core.synthetic import synthesize
    from support.payload_logs import coulomb_friction, excitation

    logs = loaded_logs("tx40")
    base = identify(logs.base, IdentifyRequest(system=logs.system, friction="coulomb")).to_dict()
    heavy = robot_with_payload(logs.robot, logs.payload)
    slow, _ = synthesize(heavy, excitation(logs.robot, 2, duration=200.0), friction="coulomb",
                         friction_params=coulomb_friction(logs.robot), seed=8)
    result = identify_payload(slow.window(0.0, 40.0), base)
    p = result.payload
    inertia = [q for q in QUANTITIES if q.startswith("inertia.")]
    assert set(inertia) <= set(result.held) and not set(inertia) & set(p.resolved)
    assert {"mass", "com.x", "com.y", "com.z"} <= set(p.resolved)
    assert abs(p.mass - 2.8) < 0.028 and np.max(np.abs(np.subtract(p.com, logs.payload.com))) < 0.005
    assert p.inertia[0][0] == pytest.approx(0.4 * p.mass * 0.01**2) and p.inertia[0][1] == 0.0
    assert p.sigma["inertia"][0][0] is None and p.feasible
    assert any("does not resolve the payload's inertia" in w for w in result.warnings)


@pytest.mark.slow
def test_refit_friction_follows_the_load():
    """The loaded log's friction levels are 1.3 × the base's: held at the base's they bias the
    payload; re-fitted, the levels come back within 2 % and the mass within 1 %."""
    logs = loaded_logs("ur5", 1.3)
    base = identify(logs.base, IdentifyRequest(system=logs.system, friction="coulomb")).to_dict()
    held = identify_payload(logs.loaded, base)
    refit = identify_payload(logs.loaded, base, PayloadRequest(refit_friction=True))
    assert abs(refit.payload.mass - 2.8) < 0.028
    assert refit.metrics["relerr_pct"] < 0.5 * held.metrics["relerr_pct"]
    levels = refit.friction_params()
    assert len(levels) == 12 and refit.friction["base"].keys() == levels.keys()
    for joint, values in logs.friction.items():
        for name, value in values.items():
            assert levels[f"{joint}/{name}"] == pytest.approx(value, rel=0.02)


def test_payload_needs_a_robot_base_and_a_known_link(tmp_path):
    from support.data import emps_like

    series = emps_like()
    base = identify(series, IdentifyRequest(system="emps")).to_dict()
    with pytest.raises(FrictionIdError, match="system 'emps' has no robot model: a payload needs"):
        identify_payload(series, base)
    logs = loaded_logs("tx40")
    with pytest.raises(FrictionIdError, match="link 'flange' is not a link of tx40 .*link_6"):
        link_frame(logs.robot, "flange")


def test_payload_file_round_trip_and_bad_files(tmp_path):
    """A payload file written by hand reads back; a bad key is named."""
    good = {"payload": {"link": "tool0", "mass": 1.0, "com": [0, 0, 0.1],
                        "inertia": [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]}}
    path = tmp_path / "p.json"
    path.write_text(json.dumps(good))
    read = read_payload(path)
    assert read.payload.mass == 1.0 and read.payload.feasible and read.friction_params() == {}
    for change, message in ((dict(mass=-1.0), "key 'mass' must be > 0 kg"),
                            (dict(com=[0, 0]), "key 'com' must be 3 finite numbers"),
                            (dict(inertia=[[0.01, 1, 0], [0, 0.01, 0], [0, 0, 0.01]]), "'inertia' is not symmetric"),
                            (dict(resolved=["weight"]), "key 'resolved' must list names")):
        path.write_text(json.dumps({"payload": {**good["payload"], **change}}))
        with pytest.raises(FrictionIdError, match=f"{path}: key 'payload': {message}" if "inertia" not in message
                           else message):
            read_payload(path)
    path.write_text(json.dumps({"params": {}}))
    with pytest.raises(FrictionIdError, match="no 'payload' block"):
        read_payload(path)


@pytest.mark.parametrize("name", ["tx40", "ur5"])
def test_safety_screen_of_a_payload(name):
    """The test payload passes; 80 kg on the flange is over joint efforts (named with the limit);
    an inertia no body has is refused as such."""
    from frictionid_core.safety import payload_refusals
    from frictionid_core.systems import get_system
    from support.payload_logs import PAYLOAD

    system_name, robot = robot_of(name)
    system = get_system(system_name)
    link = default_link(robot)
    assert payload_refusals(Payload(link, **PAYLOAD), system) == []
    heavy = payload_refusals(Payload(link, 80.0, (0, 0, 0.3), ((1, 0, 0), (0, 1, 0), (0, 0, 1))), system)
    joint_2 = robot.joints[1]
    assert any("its gravity torque" in r and f"on '{joint_2}' is over the effort limit" in r for r in heavy)
    flat = Payload.from_dict({"link": link, "mass": 1.0, "com": [0, 0, 0], "inertia": [[1, 0, 0], [0, 1, 0],
                                                                                         [0, 0, 3]]})
    assert not flat.feasible
    assert payload_refusals(flat, system) == [f"payload on '{link}': its pseudo-inertia is not positive definite "
                                              "(no rigid body has this mass, centre of mass and inertia)"]
