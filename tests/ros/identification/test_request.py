"""The ~/identify request validated into a job: defaults, overrides, errors naming the field."""

from __future__ import annotations

import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from frictionid_interfaces.srv import Identify

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import IdentifyRequest, SolverOptions
from frictionid_ros.identification import parse_request
from support.node_parts import NS, T0, node_config, stamp_time


def test_request_defaults_and_overrides(tmp_path):
    cfg = node_config(tmp_path, friction_model="tustin", solver="de", seed=7, window_seconds=2.0)
    job = parse_request(Identify.Request(), cfg, ["a", "b"])
    assert job.joints == ["a", "b"] and job.window_seconds == 2.0 and not job.dry_run
    r = job.request
    assert (r.friction, r.solver.method, r.solver.seed, r.asymmetric) == ("tustin", "de", 7, False)
    assert r.joints == ("a", "b") and r.system == cfg.system
    job = parse_request(Identify.Request(joints=["b"], friction_model="coulomb", solver="ls", seed=3, asymmetric=True,
                                         window_start=stamp_time(T0), dry_run=True), cfg, ["a", "b"])
    r = job.request
    assert (job.joints, r.friction, r.solver.method, r.solver.seed, r.asymmetric) == (["b"], "coulomb", "ls", 3, True)
    assert (job.window_seconds, job.start_ns, job.end_ns, job.dry_run) == (0.0, T0, 0, True)
    # the node's system and settings, the request's budgets in the solver's units
    r = parse_request(Identify.Request(budget=50, population=20), cfg, ["a"]).request
    assert r == IdentifyRequest(system=cfg.system, joints=["a"], friction="tustin",
                                solver=SolverOptions("de", 7, pop=20, generations=50))
    r = parse_request(Identify.Request(budget=50, solver="lm"), cfg, ["a"]).request
    assert (r.solver.calls, r.solver.generations) == (50, None)
    seeds = {parse_request(Identify.Request(seed=-1), cfg, ["a"]).request.solver.seed for _ in range(3)}
    assert len(seeds) == 3 and min(seeds) >= 0  # negative: a fresh random seed each time


@pytest.mark.parametrize("fields, needle", [
    (dict(joints=["nope"]), r"unknown joint\(s\) \['nope'\]; buffered joints: \['a', 'b'\]"),
    (dict(joints=["a", "a"]), r"duplicated joint names"),
    (dict(friction_model="dahl"), r"request field 'friction_model': unknown friction model 'dahl'"),
    (dict(solver="simplex"), r"request field 'solver': unknown solver 'simplex'"),
    (dict(population=-1), r"request field 'population' must be an integer >= 0, got -1"),
    (dict(budget=-5), r"request field 'budget' must be an integer >= 0, got -5"),
    (dict(window_seconds=-1.0), r"window_seconds must be >= 0"),
    (dict(window_seconds=float("nan")), r"window_seconds must be >= 0"),
    (dict(window_seconds=2.0, window_end=stamp_time(T0)), r"both window_seconds and window_start/window_end"),
    (dict(window_start=stamp_time(T0), window_end=stamp_time(T0)), r"window_end must be after window_start"),
    (dict(budget=1001), r"request field 'budget' = 1001 is over the node's limit max_budget = 1000"),
    (dict(population=2**31 - 1), r"request field 'population' = 2147483647 is over the node's limit max_population"),
    (dict(window_seconds=61.0), r"window_seconds = 61 s is over the node's limit max_window_seconds = 60 s"),
    (dict(window_start=stamp_time(T0), window_end=stamp_time(T0 + 61 * NS)),
     r"window_start..window_end = 61 s is over the node's limit max_window_seconds = 60 s"),
])
def test_request_errors_name_the_field(tmp_path, fields, needle):
    with pytest.raises(FrictionIdError, match=needle):
        parse_request(Identify.Request(**fields), node_config(tmp_path), ["a", "b"])


def test_the_node_parameters_are_the_request_defaults(tmp_path):
    """filter_cutoff_hz/decimation override the system's pre-processing, drive_file gives the drive's
    keys, known_rigid_body is the request field of that name (tx40: the links held, the rotor
    inertias identified)."""
    from frictionid_core.identification import PreprocessingOverrides

    cfg = node_config(tmp_path, filter_cutoff_hz=25.0, decimation=4)
    r = parse_request(Identify.Request(), cfg, ["a"]).request
    assert r.preprocessing == PreprocessingOverrides(cutoff_hz=25.0, decimate=4) and r.drive is None
    assert parse_request(Identify.Request(), node_config(tmp_path), ["a"]).request.preprocessing == \
        PreprocessingOverrides()
    from frictionid_ros.parameters import PARAMETERS, make_config

    joints = [f"joint_{k}" for k in range(1, 7)]
    cfg = make_config({**{k: v.default for k, v in PARAMETERS.items()}, "joints": joints, "system": "tx40",
                       "drive_file": "tx40", "known_rigid_body": True, "results_file": str(tmp_path / "p.json")})
    r = parse_request(Identify.Request(), cfg, joints).request
    assert r.drive == cfg.drive.to_dict() and r.drive["friction_on"] == "motor"
    assert r.known_rigid_body and r.fixed == {}
