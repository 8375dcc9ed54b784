"""The active parameters and the results files: merge, save, load, paths, round trips."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from frictionid_interfaces.srv import Identify

from frictionid_core.errors import FrictionIdError
from frictionid_core.files import temporary_name
from frictionid_core.identification import IdentifyResult
from frictionid_ros.identification import IdentifyService
from frictionid_ros.store import (
    ActiveParameters,
    Results,
    read_results,
    request_path,
    split_identification,
    write_results,
)
from support.node_parts import LOG, feed, identification_dict, make_inputs, node_config, service_with_parameters


def test_active_parameters_merge_save_and_load(tmp_path):
    cfg = node_config(tmp_path, identification_worker="thread")
    inputs = make_inputs(cfg)
    feed(inputs)
    changes = []
    active = ActiveParameters(cfg.results_file, changes.append, log=LOG)
    service = IdentifyService(lambda: cfg, inputs, active, {"joint_states": "/joint_states"}, None, log=LOG)
    assert service.handle(Identify.Request(joints=["a"])).ok
    assert service.handle(Identify.Request(joints=["b"], friction_model="tustin", solver="lm")).ok
    assert {j: p.friction for j, p in active.results.per_joint.items()} == {"a": "coulomb", "b": "tustin"}
    assert active.save(active.file("")) == (True, f"saved parameters of ['a', 'b'] to {cfg.results_file}")
    other = tmp_path / "other.json"
    ok, message = active.save(other)
    assert ok and other.is_file()
    fresh = ActiveParameters(cfg.results_file, changes.append, log=LOG)
    fresh.restore()  # at start: read quietly
    assert fresh.results.per_joint.keys() == {"a", "b"} and len(changes) == 2
    ok, message = fresh.load(other)
    assert ok and message == f"loaded parameters of ['a', 'b'] from {other}; saved to {cfg.results_file}"
    assert len(changes) == 3
    assert fresh.load(tmp_path / "missing.json") == (False, f"{tmp_path / 'missing.json'}: no such parameters file")
    assert ActiveParameters(tmp_path / "none.json", changes.append, LOG).save(other)[1].startswith("no active")


def test_request_paths_stay_inside_the_results_folder(tmp_path):
    folder, outside = tmp_path / "results", tmp_path / "outside"
    folder.mkdir()
    outside.mkdir()
    (outside / "notes.txt").write_text("x")
    (folder / "sub").mkdir()
    (folder / "out").symlink_to(outside, target_is_directory=True)
    (folder / "evil.json").symlink_to(outside / "notes.txt")
    (folder / "alias.json").symlink_to(folder / "sub" / "p.json")  # a link inside the folder is fine
    assert request_path(folder, "p.json") == folder / "p.json"
    assert request_path(folder, "sub/p.json") == request_path(folder, str(folder / "sub" / "p.json"))
    assert request_path(folder, "./sub//p.json") == folder / "sub" / "p.json"
    assert request_path(folder, "alias.json") == folder / "sub" / "p.json"
    refused = {str(outside / "notes.txt"): "outside the results folder", "/etc/passwd": "outside the results folder",
               "../outside/notes.txt": "'..'", "sub/../../outside/x.json": "'..'",
               "out/x.json": "symbolic link", "evil.json": "symbolic link", ".": "symbolic link",
               "none/x.json": "no such folder", "a\0b": "NUL"}
    for name, needle in refused.items():
        with pytest.raises(FrictionIdError, match="refused") as err:
            request_path(folder, name)
        assert needle in str(err.value) and f"inside the results folder {folder}" in str(err.value), str(err.value)
    # a folder reached through a symbolic link: its real path is accepted as inside too
    (tmp_path / "link").symlink_to(folder, target_is_directory=True)
    assert request_path(tmp_path / "link", str(folder / "p.json")) == folder / "p.json"


def test_the_node_overwrites_only_its_own_files(tmp_path):
    _, active = service_with_parameters(tmp_path)
    foreign = tmp_path / "foreign.json"
    for text in ('{"params": {}}', "not json", '{"format": "other/1"}'):
        foreign.write_text(text)
        ok, message = active.save(active.file("foreign.json"))
        assert not ok and "not a parameters file written by this node" in message and foreign.read_text() == text
    (tmp_path / "dir.json").mkdir()
    assert not active.save(active.file("dir.json"))[0]
    assert active.save(active.file("mine.json"))[0] and active.save(active.file("mine.json"))[0]  # its own: again


def test_results_file_round_trip_and_plain_identify_json(tmp_path):
    d = identification_dict(["a", "b"], {"a/Fv": 1.0, "a/Fc": 0.5, "b/Fv": 2.0, "b/Fc": 0.25,
                                         "a/offset": 0.0, "b/offset": 0.1})
    last = IdentifyResult.from_dict(d)
    per = split_identification(last, stamp_ns=7)
    assert per["b"].params == {"Fv": 2.0, "Fc": 0.25, "offset": 0.1} and per["a"].samples == 100
    path = write_results(tmp_path / "sub" / "p.json", Results(per, last, 1, 2, 300, 7))
    back = read_results(path)
    assert back.per_joint["b"].params == per["b"].params and back.window_samples == 300
    assert json.loads(path.read_text())["params"] == d["params"]  # IdentifyResult.to_dict() schema on top
    assert back.last == last
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps(d))
    assert read_results(plain).per_joint["a"].params["Fc"] == 0.5
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(identification_dict(["a"], {"Fv": 1.0})))
    with pytest.raises(FrictionIdError, match=r"\['Fc'\] missing"):
        read_results(bad)
    assert not list((tmp_path / "sub").glob("*.tmp"))  # atomic write leaves no temporary file


def test_a_save_removes_the_temporary_file_of_a_node_killed_while_saving(tmp_path):
    """A node killed during ``~/save`` leaves ``.parameters.json.<pid>.tmp``; the next save into that folder
    removes it (its process is gone), and keeps one of a process that still runs."""
    _, active = service_with_parameters(tmp_path)
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True)
    orphan = active.path.with_name(temporary_name(active.path.name, int(done.stdout)))  # its process has exited
    running = active.path.with_name(temporary_name(active.path.name, os.getppid()))
    for path in (orphan, running):
        path.write_text('{"per_joint": ')
    assert active.save(active.file(""))[0]
    assert not orphan.exists() and running.exists()


def test_payload_is_screened_saved_with_the_parameters_and_kept_by_later_sets(tmp_path):
    """A payload in the active parameters is written with them and read back; a set without one
    keeps it; the screen refuses a payload the robot cannot hold (nothing changes)."""
    from frictionid_core.identification import IdentifyRequest, identify
    from frictionid_core.robots import Payload
    from frictionid_ros.identification import base_result
    from frictionid_ros.store import Screen
    from support.payload_logs import PAYLOAD, loaded_logs

    logs = loaded_logs("tx40")
    base = identify(logs.base, IdentifyRequest(system="tx40", friction="coulomb"))
    from frictionid_core.systems import get_system

    active = ActiveParameters(tmp_path / "p.json", lambda results: None, LOG, screen=Screen(get_system("tx40")))
    with pytest.raises(FrictionIdError, match="no active robot parameters to use as the base"):
        base_result(active.results)
    payload = Payload("link_6", **PAYLOAD)
    active.activate(Results(split_identification(base), base, payload=payload))
    assert base_result(active.results).params == base.params
    active.activate(Results(split_identification(base), base))  # a later identification without a payload
    assert active.results.payload == payload
    assert read_results(tmp_path / "p.json").payload == payload
    heavy = Payload("link_6", 80.0, (0, 0, 0.3), ((1, 0, 0), (0, 1, 0), (0, 0, 1)))
    with pytest.raises(FrictionIdError, match="refused by the safety screen: payload on 'link_6' .*gravity torque"):
        active.activate(Results({}, base, payload=heavy))
    assert active.results.payload == payload
