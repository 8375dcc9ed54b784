"""The identification request (validated once, naming the field; YAML and pickle round trips;
``frictionid identify --request``) and the typed result (its JSON keys, ``from_dict`` round trip)."""

from __future__ import annotations

import dataclasses
import json
import pickle

import numpy as np
import pytest
import yaml

from frictionid_core.cli import main
from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import (
    IdentifyRequest,
    IdentifyResult,
    PreprocessingOverrides,
    SolverOptions,
    identify,
    read_request,
    write_request,
)
from support.data import EMPS_ESTIMATION

# The keys of 'frictionid identify --json' (a closed-form fit), in their order: a contract.
RESULT_KEYS = ["system", "joint_map", "friction", "asymmetric", "solver", "source", "joints", "params", "std",
               "std_robust", "at_bound", "metrics", "wall_s", "warnings", "notes", "drive", "window", "fixed",
               "bounds", "preprocessing", "layout", "identifiability", "no_effort_joints", "unexcited_joints",
               "request", "uncertainty", "velocity_range"]
OPTIMIZER_KEYS = ["optimizer", "varpro", "warm_start"]  # after "bounds", with an optimiser


def rich_request() -> IdentifyRequest:
    """A request that sets every kind of field."""
    return IdentifyRequest(
        system="tx40-j2", joints=["joint_2"], drive={"joints": ["joint_2"], "gear_ratio": [100.0], "name": "g"},
        friction="stribeck", asymmetric=True,
        solver=SolverOptions("de", seed=4, pop=12, generations=30, varpro=True, warm_start=False,
                             options={"F": 0.6}),
        preprocessing=PreprocessingOverrides(cutoff_hz=20.0, decimate=5, min_speed={"joint_2": 0.01}),
        window=(1.5, None), fixed={"offset": 0.0}, bounds={"vs": (1e-3, 0.5)})


def test_a_short_request_is_the_default_and_values_are_normalised():
    assert IdentifyRequest(system="emps", friction="coulomb") == IdentifyRequest()
    r = IdentifyRequest(solver="lm", joints=["a", "b"], window=[0, 2], bounds={"vs": [0, 1]}, prior="none")
    assert r.solver == SolverOptions("lm") and r.joints == ("a", "b") and r.window == (0.0, 2.0)
    assert r.bounds == {"vs": (0.0, 1.0)} and r.prior is None
    plain = r.to_dict()
    plain["bounds"]["vs"][0] = -1.0  # a copy: the request stays as it was
    assert r.bounds == {"vs": (0.0, 1.0)}
    assert SolverOptions("de", pop=0, generations=0) == SolverOptions("de")  # 0: the method's default


@pytest.mark.parametrize("fields, message", [
    (dict(friction="dahl"), r"^request field 'friction': unknown friction model 'dahl'; choose one of coulomb"),
    (dict(solver="simplex"), r"^request field 'solver.method': unknown solver 'simplex'"),
    (dict(solver={"method": "de", "pop": -1}), r"^request field 'solver.pop' must be an integer >= 0, got -1"),
    (dict(solver={"method": "de", "popsize": 5}), r"^request field 'solver.popsize': unknown; known: method, seed"),
    (dict(solver={"method": "de", "options": {"FF": 0.5}}),
     r"^request field 'solver.options': unknown option\(s\) \['FF'\] of de"),
    (dict(solver={"method": "ls", "options": {"F": 0.5}}), r"'ls' takes no options"),
    (dict(system="ur5"), r"^request field 'system': unknown system 'ur5'; choose one of emps"),
    (dict(joints=["a", "a"]), r"^request field 'joints': duplicated name\(s\) \['a'\]"),
    (dict(window=(2.0, 1.0)), r"^request field 'window': end_s 1.0 is not after start_s 2.0"),
    (dict(window={"start": 1.0}), r"^request field 'window.start': unknown; known: start_s, end_s"),
    (dict(bounds={"vs": (1.0,)}), r"^request field 'bounds.vs' must be \[lo, hi\]"),
    (dict(fixed={"offset": "0"}), r"^request field 'fixed.offset' must be a number, got '0'"),
    (dict(preprocessing={"decimate": 0}), r"^request field 'preprocessing.decimate': pre-processing: invalid decimate"),
    (dict(preprocessing={"velocity": "gps"}), r"^request field 'preprocessing.velocity': .*unknown velocity 'gps'"),
    (dict(drive={"joints": []}), r"^request field 'drive': "),
    (dict(asymmetric="yes"), r"^request field 'asymmetric' must be true or false, got 'yes'"),
    (dict(prior_weight=-1.0), r"^request field 'prior_weight' must be >= 0, got -1.0"),
    (dict(consistent=True), r"^request field 'consistent': needs a robot system .* system 'emps' has none"),
    (dict(prior="urdf"), r"^request field 'prior': needs a robot system .* system 'emps' has none"),
    (dict(system="tx40", stribeck_order=True), r"^request field 'stribeck_order': applies to the consistent fit only"),
    (dict(system="joint", hold={"j": 0.0}), r"^request field 'hold': needs a robot system .* 'joint' has none"),
    (dict(system="tx40", hold={"joint_1": float("inf")}), r"^request field 'hold.joint_1' must be a finite position"),
    (dict(system="tx40", hold={"joint_1": "up"}), r"^request field 'hold.joint_1' must be a number, got 'up'"),
    (dict(hold_missing=True), r"^request field 'hold_missing': needs a robot system"),
    (dict(system="tx40", gravity=True), r"^request field 'gravity': adds g_sin·sin q .*'tx40' has its own gravity"),
    (dict(system="tx40", consistent=True, prior="cad"), r"^request field 'prior': unknown prior 'cad'; choose"),
])
def test_a_bad_value_is_refused_on_creation_naming_its_field(fields, message):
    with pytest.raises(FrictionIdError, match=message):
        IdentifyRequest(**fields)


def test_from_dict_names_the_field_as_its_caller_does():
    with pytest.raises(FrictionIdError, match=r"^r.yaml: key 'solver.pop' must be an integer >= 0, got -1$"):
        IdentifyRequest.from_dict({"solver": {"method": "de", "pop": -1}}, where="r.yaml: key")
    with pytest.raises(FrictionIdError, match=r"^--pop must be an integer >= 0, got -1$"):
        IdentifyRequest.from_dict({"solver": {"pop": -1}}, where="", names={"solver.pop": "--pop"})
    with pytest.raises(FrictionIdError, match=r"^request field 'solvr': unknown; known: system, joints"):
        IdentifyRequest.from_dict({"solvr": "de"})
    with pytest.raises(FrictionIdError, match=r"must be a mapping of fields, got list"):
        IdentifyRequest.from_dict(["de"])


def test_yaml_and_pickle_round_trips(tmp_path):
    request = rich_request()
    assert IdentifyRequest.from_dict(request.to_dict()) == request
    path = write_request(tmp_path / "r.yaml", request)
    assert read_request(path) == request
    assert yaml.safe_load(path.read_text())["solver"]["options"] == {"F": 0.6}  # plain YAML
    assert pickle.loads(pickle.dumps(request)) == request  # what the node sends its worker
    (tmp_path / "bad.yaml").write_text("friction: stribeck\nsolver: {method: de, pop: -3}\n")
    with pytest.raises(FrictionIdError, match=r"bad.yaml: key 'solver.pop' must be an integer >= 0, got -3"):
        read_request(tmp_path / "bad.yaml")


def test_result_json_keeps_its_keys_and_round_trips(synthetic):
    ls = identify(synthetic(), IdentifyRequest(fixed={"offset": -3.0}))
    d = ls.to_dict()
    assert list(d) == RESULT_KEYS
    assert d["fixed"] == {"offset": -3.0} and d["window"] is None and d["request"] == ls.request.to_dict()
    de = identify(synthetic(), IdentifyRequest(friction="tustin", window=(0.5, None), bounds={"vs": (1e-3, 1.0)},
                                               solver=SolverOptions("de", pop=8, generations=3)))
    d = de.to_dict()
    cut = RESULT_KEYS.index("preprocessing")
    assert list(d) == RESULT_KEYS[:cut] + OPTIMIZER_KEYS + RESULT_KEYS[cut:] + ["holdout"]  # a nonlinear law
    assert d["window"] == {"start_s": 0.5, "end_s": None} and d["bounds"] == {"vs": [1e-3, 1.0]}
    for result in (ls, de):
        text = json.dumps(result.to_dict())
        back = IdentifyResult.from_dict(json.loads(text))
        assert same_result(back, result) and json.dumps(back.to_dict()) == text


def same_value(a, b) -> bool:
    """Equal, a NaN equal to a NaN (an undetermined σ), through dicts, lists, tuples and arrays."""
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(same_value(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(same_value, a, b))
    if isinstance(a, (float, np.ndarray)) or isinstance(b, (float, np.ndarray)):
        return np.array_equal(a, b, equal_nan=True)
    return a == b


def same_result(a: IdentifyResult, b: IdentifyResult) -> bool:
    """Field by field :func:`same_value`: results holding NaN σ compare equal when they agree."""
    return all(same_value(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(IdentifyResult))


def test_same_result_tells_nan_apart_only_from_numbers():
    assert same_value({"vs": float("nan"), "Fc": 1.0}, {"vs": float("nan"), "Fc": 1.0})
    assert not same_value({"vs": float("nan")}, {"vs": 1.0}) and not same_value({"Fc": 1.0}, {"Fc": 1.5})
    assert not same_value({"a": 1.0, "b": 2.0}, {"b": 2.0, "a": 1.0}) and not same_value([1.0], (1.0,))


def test_result_from_a_hand_written_file():
    d = {"system": "friction-only", "friction": "coulomb", "asymmetric": False, "params": {"Fv": 1.0, "Fc": 0.5},
         "review": {"accepted": True}}  # an unknown key is ignored
    r = IdentifyResult.from_dict(d)
    assert (r.solver, r.joints, r.std, r.request) == ("", [], {}, None)
    with pytest.raises(FrictionIdError, match=r"^p.json lacks 'asymmetric', 'params': not an identification result"):
        IdentifyResult.from_dict({"system": "emps", "friction": "coulomb"}, "p.json")


# -------------------------------------------------------------------------------- the CLI
FLAGS = ["--friction", "tustin", "--solver", "de", "--pop", "8", "--budget", "4", "--seed", "3", "--varpro",
         "--cutoff", "60", "--trim", "0.02:0", "--fix", "offset=-3.2", "--bounds", "vs=1e-3:0.5", "--start", "1",
         "--end", "30"]


def _without_wall_times(d: dict) -> dict:
    d = dict(d, wall_s=None)
    return dict(d, optimizer=dict(d["optimizer"], wall_s=None)) if "optimizer" in d else d


def test_a_saved_request_reproduces_the_fit(tmp_path, capsys):
    """The flags, and the request file they saved, give the same result JSON (bar wall times)."""
    src, saved = str(EMPS_ESTIMATION), tmp_path / "r.yaml"
    assert main(["identify", src, *FLAGS, "--save-request", str(saved), "--json", str(tmp_path / "a.json")]) == 0
    assert main(["identify", src, "--request", str(saved), "--json", str(tmp_path / "b.json")]) == 0
    a, b = (json.loads((tmp_path / n).read_text()) for n in ("a.json", "b.json"))
    assert _without_wall_times(a) == _without_wall_times(b)
    assert a["request"] == yaml.safe_load(saved.read_text())
    assert a["request"]["solver"] == {"method": "de", "seed": 3, "pop": 8, "generations": 4, "calls": None,
                                      "varpro": True, "warm_start": True, "options": {}}
    # a result JSON holds its request too
    assert main(["identify", src, "--request", str(tmp_path / "a.json"), "--json", str(tmp_path / "c.json")]) == 0
    assert _without_wall_times(json.loads((tmp_path / "c.json").read_text())) == _without_wall_times(a)
    capsys.readouterr()


def test_flags_given_override_the_request_file(tmp_path, capsys):
    saved = write_request(tmp_path / "r.yaml", IdentifyRequest(
        friction="tustin", solver=SolverOptions("lm", seed=2, calls=40), fixed={"offset": 0.0},
        preprocessing=PreprocessingOverrides(cutoff_hz=50.0)))
    out = tmp_path / "o.yaml"
    assert main(["identify", str(EMPS_ESTIMATION), "--request", str(saved), "--seed", "5", "--budget", "30",
                 "--decimate", "5", "--fix", "Fv=200", "--save-request", str(out)]) == 0
    got = read_request(out)
    assert got.solver == SolverOptions("lm", seed=5, calls=30)  # --budget counts lm's calls
    assert got.preprocessing == PreprocessingOverrides(cutoff_hz=50.0, decimate=5)  # setting by setting
    assert got.fixed == {"offset": 0.0, "Fv": 200.0} and got.friction == "tustin"
    capsys.readouterr()


def test_a_bad_request_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "r.yaml"
    bad.write_text("solver: {method: de, pop: -1}\n")
    assert main(["identify", str(EMPS_ESTIMATION), "--request", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err == f"frictionid: error: {bad}: key 'solver.pop' must be an integer >= 0, got -1\n"
    assert main(["identify", str(EMPS_ESTIMATION), "--consistent"]) == 2
    assert capsys.readouterr().err.startswith("frictionid: error: --consistent: needs a robot system")
