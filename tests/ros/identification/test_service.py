"""The ~/identify service logic: answers, activation, cancel and the wall-time limit."""

from __future__ import annotations

import json
import threading
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from frictionid_interfaces.srv import Identify

from frictionid_ros.identification import IdentifyService
from frictionid_ros.store import ActiveParameters, read_results
from frictionid_ros.worker import JobControl
from support.node_parts import FC, FV, HUGE, LOG, feed, make_inputs, node_config, service_with_parameters
from support.waiting import wait_until


def test_identify_service_answers_and_activates(tmp_path):
    cfg = node_config(tmp_path, identification_worker="thread")
    inputs = make_inputs(cfg)
    published = []
    active = ActiveParameters(cfg.results_file, published.append, log=LOG)
    service = IdentifyService(lambda: cfg, inputs, active, {"joint_states": "/joint_states"}, None, log=LOG)
    answer = service.handle(Identify.Request())
    ok, message, result = answer.ok, answer.message, answer.identified
    assert not ok and message.startswith("too little data") and result is None
    assert (service.last_ok, service.last_status) == (False, message)
    stamps, _, _ = feed(inputs)
    answer = service.handle(Identify.Request(joints=["b"], dry_run=True))
    ok, message, result = answer.ok, answer.message, answer.identified
    assert ok and "dry run" in message and not published and not cfg.results_file.exists()
    # noise-free data: only the pre-processing (filtered derivatives) moves the estimates, by < 0.1 %
    assert list(result.per_joint) == ["b"] and result.per_joint["b"].params["Fc"] == pytest.approx(FC[1], rel=1e-3)
    answer = service.handle(Identify.Request())
    ok, message, result = answer.ok, answer.message, answer.identified
    assert ok and message.startswith("identified friction-only/coulomb with ls on 1000 samples of ['a', 'b']")
    assert f"saved to {cfg.results_file}" in message and service.last_status == message
    for i, j in enumerate("ab"):
        assert result.per_joint[j].params["Fv"] == pytest.approx(FV[i], rel=1e-3)
    assert (result.window_start_ns, result.window_end_ns, result.window_samples) == (stamps[0], stamps[-1], 1000)
    assert len(published) == 1 and published[0].per_joint.keys() == {"a", "b"}  # the dry run published nothing
    saved = read_results(cfg.results_file)
    assert saved.per_joint["a"].params == result.per_joint["a"].params and saved.window_samples == 1000
    assert json.loads(cfg.results_file.read_text())["friction"] == "coulomb"


def test_cancel_stops_the_identification_and_keeps_the_parameters(tmp_path):
    service, active = service_with_parameters(tmp_path)
    before = active.results
    control, box = JobControl(), {}
    t = threading.Thread(target=lambda: box.setdefault("answer", service.handle(Identify.Request(**HUGE), control)))
    t.start()
    wait_until(lambda: control.progress[0] >= 2 or not t.is_alive(), "two generations of the identification")
    assert t.is_alive(), box
    assert service.running is control and service.handle(Identify.Request()).message.startswith("busy")
    assert service.cancel_running("cancelled by the test")
    t.join(120)
    answer = box["answer"]
    assert not answer.ok and answer.cancelled and answer.identified is None
    assert answer.message.startswith("cancelled by the test after") and "active parameters unchanged" in answer.message
    assert active.results is before and service.running is None and not service.cancel_running("again")
    assert service.handle(Identify.Request()).ok  # not stuck busy


def background_job(service: IdentifyService) -> tuple[JobControl, dict, threading.Thread]:
    """A long job holding ``service``'s slot as an online re-identification does (``slot(background=
    ...)``), two generations in: (its control, a box that gets "cancelled" with its message, its thread)."""
    from frictionid_ros.identification import parse_request
    from frictionid_ros.worker import Cancelled

    background, box = JobControl(), {}

    def job():
        with service.slot(background=background) as free:
            assert free
            try:
                service.run_job(parse_request(Identify.Request(**HUGE), service._settings(), ["a", "b"]), background)
            except Cancelled as exc:
                box["cancelled"] = str(exc)

    t = threading.Thread(target=job)
    t.start()
    wait_until(lambda: background.progress[0] >= 2, "two generations of the background job")
    return background, box, t


def test_a_request_preempts_a_background_job_but_not_another_request(tmp_path):
    """A background job in the slot (an online re-identification: ``slot(background=...)``) is
    cancelled by a request, which then runs at once; a request's own identification is not: the
    next request is answered "busy"."""
    service, _ = service_with_parameters(tmp_path)
    background, box, t = background_job(service)
    answer = service.handle(Identify.Request())
    t.join(30)
    assert answer.ok, answer.message
    assert background.reason == "preempted by a requested identification" and "cancelled" in box
    control = JobControl()
    t = threading.Thread(target=lambda: box.setdefault("long", service.handle(Identify.Request(**HUGE), control)))
    t.start()
    wait_until(lambda: control.progress[0] >= 2, "two generations of the requested identification")
    assert service.handle(Identify.Request()).message.startswith("busy") and not control.cancelled
    service.cancel_running("done")
    t.join(30)


def test_wall_time_limit_stops_the_identification(tmp_path):
    service, active = service_with_parameters(tmp_path, max_wall_s=0.5)
    before = active.results
    answer = service.handle(Identify.Request(**HUGE))
    assert not answer.ok and answer.cancelled and active.results is before
    assert answer.message.startswith("stopped: over the wall-time limit max_wall_s = 0.5 s after"), answer.message


def test_a_preempting_slot_takes_it_from_a_background_job_only(tmp_path):
    """``slot(preempt=reason)`` (a ~/load through the gate) cancels a background job holding the slot
    with that reason and holds the slot; a request's own identification is not cancelled: busy."""
    service, _ = service_with_parameters(tmp_path)
    background, box, t = background_job(service)
    with service.slot(preempt="preempted by a load") as free:
        assert free and service.busy
    t.join(30)
    assert background.reason == "preempted by a load" and "cancelled" in box and not service.busy
    control = JobControl()
    t = threading.Thread(target=lambda: box.setdefault("long", service.handle(Identify.Request(**HUGE), control)))
    t.start()
    wait_until(lambda: control.progress[0] >= 2, "two generations of the requested identification")
    with service.slot(preempt="preempted by a load") as free:
        assert not free and not control.cancelled
    service.cancel_running("done")
    t.join(30)
