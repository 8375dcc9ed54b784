"""frictionid_interfaces: generated Python types and a real rclpy service round trip.

Needs rclpy and the interface package built into the environment (`make setup` runs
tools/build_interfaces.sh). Deliberately no skip: a missing rclpy or an unbuilt
package must fail the suite.
"""

import math
import threading
import uuid
import warnings

import pytest

with warnings.catch_warnings():
    # lark (used by the rosidl parser) emits DeprecationWarnings on some versions.
    warnings.simplefilter("ignore", DeprecationWarning)
    import rclpy
    import rclpy.serialization
    from builtin_interfaces.msg import Time
    from rclpy.executors import MultiThreadedExecutor
    from std_msgs.msg import Header

    try:
        from frictionid_interfaces.action import Identify as IdentifyAction
        from frictionid_interfaces.msg import IdentifiedParameters, JointFriction
        from frictionid_interfaces.srv import Identify, ParametersFile
    except ImportError as exc:  # pragma: no cover - message for a broken setup
        raise ImportError(
            f"{exc}: frictionid_interfaces is not built into this environment; "
            "run `make setup` (tools/build_interfaces.sh <venv>)"
        ) from exc

from support.ros_harness import DOMAIN, close_spinning

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning:lark")


def _fields(cls):
    return cls.get_fields_and_field_types()


# --- field names, types, defaults -------------------------------------------------


def test_joint_friction_fields():
    assert _fields(JointFriction) == {
        "joint_name": "string",
        "system_model": "string",
        "friction_model": "string",
        "asymmetric": "boolean",
        "solver": "string",
        "param_names": "sequence<string>",
        "param_values": "sequence<double>",
        "param_std": "sequence<double>",
        "relerr_pct": "double",
        "r2": "double",
        "rmse": "double",
        "err_std": "double",
        "cond": "double",
        "samples": "uint32",
        "stamp": "builtin_interfaces/Time",
    }
    m = JointFriction()
    assert m.joint_name == "" and m.asymmetric is False
    assert len(m.param_names) == 0 and len(m.param_values) == 0 and len(m.param_std) == 0
    assert m.relerr_pct == 0.0 and m.samples == 0
    assert isinstance(m.stamp, Time)


def test_identified_parameters_fields():
    assert _fields(IdentifiedParameters) == {
        "header": "std_msgs/Header",
        "window_start": "builtin_interfaces/Time",
        "window_end": "builtin_interfaces/Time",
        "samples": "uint32",
        "joints": "sequence<frictionid_interfaces/JointFriction>",
        "shared_param_names": "sequence<string>",
        "shared_param_values": "sequence<double>",
        "shared_param_std": "sequence<double>",
    }
    m = IdentifiedParameters()
    assert isinstance(m.header, Header) and m.joints == [] and m.samples == 0 and list(m.shared_param_names) == []


def test_identify_request_defaults_mean_node_defaults():
    assert _fields(Identify.Request) == {
        "joints": "sequence<string>",
        "friction_model": "string",
        "asymmetric": "boolean",
        "solver": "string",
        "budget": "int32",
        "population": "int32",
        "seed": "int64",
        "window_seconds": "double",
        "window_start": "builtin_interfaces/Time",
        "window_end": "builtin_interfaces/Time",
        "dry_run": "boolean",
    }
    r = Identify.Request()
    assert r.joints == [] and r.friction_model == "" and r.solver == ""
    assert (r.budget, r.population, r.seed, r.window_seconds) == (0, 0, 0, 0.0)
    assert (r.window_start.sec, r.window_start.nanosec) == (0, 0)
    assert (r.window_end.sec, r.window_end.nanosec) == (0, 0)
    assert r.asymmetric is False and r.dry_run is False


def test_identify_response_and_parameters_file():
    assert _fields(Identify.Response) == {
        "success": "boolean",
        "message": "string",
        "result": "frictionid_interfaces/IdentifiedParameters",
    }
    assert _fields(ParametersFile.Request) == {"path": "string"}
    assert _fields(ParametersFile.Response) == {
        "success": "boolean",
        "message": "string",
        "path": "string",
    }
    assert Identify.Response().success is False
    assert ParametersFile.Request().path == ""


def test_identify_action_goal_result_feedback():
    """The action's goal and result are the service's request and response (one parser serves both)."""
    assert _fields(IdentifyAction.Goal) == _fields(Identify.Request)
    assert _fields(IdentifyAction.Result) == _fields(Identify.Response)
    assert _fields(IdentifyAction.Feedback) == {
        "generation": "uint32", "evaluations": "uint32", "best_cost": "double", "elapsed_s": "double"}


def test_field_types_are_enforced_when_checking():
    # Kilted checks field types only with check_fields=True (or ROS_PYTHON_CHECK_FIELDS=1).
    r = Identify.Request(check_fields=True)
    with pytest.raises(AssertionError):
        r.budget = 2**40  # int32 overflow
    with pytest.raises(AssertionError):
        r.seed = 1.5  # int64
    with pytest.raises(AssertionError):
        JointFriction(check_fields=True).samples = -1  # uint32
    with pytest.raises(AssertionError):
        Identify.Request(check_fields=True, windows_seconds=5.0)  # typo in a field name


def _sample_result():
    stamp = Time(sec=1700000000, nanosec=5)
    jf = JointFriction(
        joint_name="joint1",
        system_model="emps",
        friction_model="coulomb",
        asymmetric=True,
        solver="ls",
        param_names=["M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"],
        param_values=[95.154, 166.7061, 20.144, 240.4236, 20.6277],
        param_std=[0.1, 1.0, 0.1, math.nan, 0.1],
        relerr_pct=3.1117,
        r2=0.999,
        rmse=1.5,
        err_std=1.4,
        cond=26.02,
        samples=2480,
        stamp=stamp,
    )
    return IdentifiedParameters(
        header=Header(stamp=stamp),
        window_start=Time(sec=1699999975),
        window_end=stamp,
        samples=24841,
        joints=[jf],
    )


def test_serialization_round_trip_keeps_nan():
    msg = _sample_result()
    data = rclpy.serialization.serialize_message(msg)
    back = rclpy.serialization.deserialize_message(data, IdentifiedParameters)
    j = back.joints[0]
    assert j.param_names == msg.joints[0].param_names
    assert list(j.param_values) == list(msg.joints[0].param_values)
    assert math.isnan(j.param_std[3]) and j.param_std[0] == 0.1
    assert back.samples == 24841 and back.window_end.nanosec == 5


# --- rclpy service round trip -----------------------------------------------------


@pytest.mark.ros
def test_identify_service_round_trip():
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=DOMAIN)
    ns = "/fid_test_" + uuid.uuid4().hex[:8]  # isolate from other processes on the domain
    executor = MultiThreadedExecutor(context=ctx)
    seen = []

    def on_identify(req, res):
        seen.append(req)
        res.success = True
        res.message = f"{req.solver}/{req.friction_model} seed={req.seed}"
        res.result = _sample_result()
        res.result.joints[0].joint_name = req.joints[0]
        res.result.joints[0].solver = req.solver
        return res

    def on_save(req, res):
        res.success, res.message, res.path = True, "saved", "/abs/" + (req.path or "default.json")
        return res

    server = rclpy.create_node("server", namespace=ns, context=ctx)
    client_node = rclpy.create_node("client", namespace=ns, context=ctx)
    thread = threading.Thread(target=executor.spin, daemon=True)
    try:
        server.create_service(Identify, "~/identify", on_identify)
        server.create_service(ParametersFile, "~/save", on_save)
        executor.add_node(server)
        executor.add_node(client_node)  # a blocking client.call() needs its node spun too
        thread.start()

        cli = client_node.create_client(Identify, ns + "/server/identify")
        assert cli.wait_for_service(timeout_sec=60.0), "Identify service not discovered"
        req = Identify.Request(
            joints=["joint_a"], friction_model="tustin", asymmetric=True, solver="de",
            budget=100, population=50, seed=42, window_seconds=5.0, dry_run=True,
        )
        res = cli.call(req, timeout_sec=60.0)
        assert res is not None, "Identify call timed out"
        assert res.success and res.message == "de/tustin seed=42"
        j = res.result.joints[0]
        assert j.joint_name == "joint_a" and j.solver == "de" and j.asymmetric
        assert math.isnan(j.param_std[3]) and j.param_values[0] == pytest.approx(95.154)
        assert res.result.header.stamp.sec == 1700000000
        assert seen[0].seed == 42 and seen[0].dry_run and seen[0].window_seconds == 5.0

        save = client_node.create_client(ParametersFile, ns + "/server/save")
        assert save.wait_for_service(timeout_sec=60.0)
        sres = save.call(ParametersFile.Request(path=""), timeout_sec=60.0)
        assert sres is not None and sres.success and sres.path == "/abs/default.json"
    finally:
        close_spinning(ctx, executor, thread, [server, client_node])
