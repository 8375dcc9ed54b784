"""The node's payload across processes: ``~/identify_payload`` (service and action) on the buffered
joint states of a synthetic loaded TX40 with the active parameters (an unloaded identification, the
node's ``results_file``) as the base; the payload on ``~/payload`` (transient local), in
/diagnostics, saved with the parameters and restored by a restarted node."""

from __future__ import annotations

import json
import time
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from frictionid_interfaces.action import IdentifyPayload as PayloadAction
    from frictionid_interfaces.srv import IdentifyPayload
    from geometry_msgs.msg import Inertia

    from frictionid_ros.runtime.action_client import ActionClient

from frictionid_core.identification import IdentifyRequest, identify
from frictionid_ros.store import Results, split_identification, write_results
from support.payload_logs import loaded_logs
from support.ros_harness import LATCHED, NS, start_node
from support.waiting import wait_until

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.filterwarnings("ignore::DeprecationWarning")]
SERVICE = "/frictionid/identify_payload"


@pytest.fixture(scope="module")
def setup(tmp_path_factory, ros):
    """A node of system tx40 whose results file is an identification of the unloaded TX40, fed
    the loaded log's joint states; yields (node, workdir, logs, first stamp [ns])."""
    logs = loaded_logs("tx40")
    workdir = tmp_path_factory.mktemp("payload_node")
    results = workdir / "results" / "parameters.json"
    results.parent.mkdir()
    base = identify(logs.base, IdentifyRequest(system="tx40", friction="coulomb"))
    write_results(results, Results(split_identification(base), base))  # the node's own format: it saves over it
    params = workdir / "params.yaml"
    params.write_text(f"""/**/frictionid:
  ros__parameters:
    joints: {json.dumps(list(logs.robot.joints))}
    system: "tx40"
    qos: "reliable"
    qos_depth: 2000
    diagnostics_period_s: 0.2
    buffer_seconds: 20.0
    results_file: "{results}"
""")
    node = start_node(workdir, ros, params, "payload")
    try:
        series = logs.loaded
        t0 = time.time_ns()
        ros.publish_states(t0 + (series.t * NS).astype(int), series.position, effort=series.effort,
                           names=tuple(series.joints), rate_hz=5000.0, wait=True)
        yield node, workdir, params, logs, t0
    finally:
        node.stop()


def _window(t0: int) -> dict:
    from builtin_interfaces.msg import Time

    return {"window_start": Time(sec=t0 // NS, nanosec=t0 % NS)}


def test_identify_payload_service_publishes_and_persists(setup, ros):
    node, workdir, _, logs, t0 = setup
    res = ros.call(IdentifyPayload, SERVICE, IdentifyPayload.Request(**_window(t0)), timeout=120.0)
    assert res.success, res.message
    assert res.link == "link_6" and res.feasible and len(res.resolved) == 10
    assert res.inertia.m == pytest.approx(logs.payload.mass, rel=0.01)
    assert res.inertia.com.z == pytest.approx(logs.payload.com[2], abs=0.005)
    assert 0.0 < res.mass_sigma < 0.05
    assert json.loads(res.json)["payload"]["mass"] == pytest.approx(res.inertia.m)
    assert res.message.startswith("payload on link_6: ") and "saved to" in res.message
    # ~/payload, transient local: a subscriber created now still gets it
    got = []
    sub = ros.node.create_subscription(Inertia, "/frictionid/payload", got.append, LATCHED)
    try:
        wait_until(lambda: got, "a message on ~/payload", 30.0)
    finally:
        ros.node.destroy_subscription(sub)
    assert got[-1].m == pytest.approx(res.inertia.m) and got[-1].izz == pytest.approx(res.inertia.izz)
    assert float(ros.diag_value("mass_kg", "frictionid: payload", newer_than=time.monotonic())) == pytest.approx(
        res.inertia.m, rel=1e-5)
    saved = json.loads((workdir / "results" / "parameters.json").read_text())
    assert saved["payload"]["mass"] == pytest.approx(res.inertia.m) and saved["payload"]["link"] == "link_6"
    assert saved["system"] == "tx40" and "per_joint" in saved


def test_identify_payload_action_and_bad_requests(setup, ros):
    node, _, _, logs, t0 = setup
    client = ActionClient(ros.node, PayloadAction, SERVICE)
    try:
        assert client.wait_for_server(timeout_sec=60.0)
        feedback = []
        handle = ros.wait(client.send_goal_async(PayloadAction.Goal(dry_run=True, **_window(t0)),
                                                 feedback_callback=lambda m: feedback.append(m.feedback)),
                          30.0, "send_goal")
        assert handle.accepted
        result = ros.wait(handle.get_result_async(), 120.0, "the action's result").result
    finally:
        client.destroy()
    assert result.success, result.message
    assert "dry run" in result.message and result.inertia.m == pytest.approx(logs.payload.mass, rel=0.01)
    bad = ros.call(IdentifyPayload, SERVICE, IdentifyPayload.Request(link="flange"))
    assert not bad.success and bad.message.startswith("link 'flange' is not a link of tx40")
    assert node.alive()


def test_restarted_node_restores_and_publishes_the_payload(setup, ros):
    node, workdir, params, _, t0 = setup
    saved = json.loads((workdir / "results" / "parameters.json").read_text())
    if "payload" not in saved:  # the service test saves it; run alone, identify it here
        assert ros.call(IdentifyPayload, SERVICE, IdentifyPayload.Request(**_window(t0)), timeout=120.0).success
        saved = json.loads((workdir / "results" / "parameters.json").read_text())
    node.stop()
    again = start_node(workdir, ros, params, "payload-restart")
    got = []
    sub = ros.node.create_subscription(Inertia, "/frictionid/payload", got.append, LATCHED)
    try:
        wait_until(lambda: got, "the restored payload on ~/payload", 60.0)
        assert got[-1].m == pytest.approx(saved["payload"]["mass"])
    finally:
        ros.node.destroy_subscription(sub)
        again.stop()
