"""The ``frictionid`` ROS 2 node: buffer joint states, identify friction on request, feed forward.

    frictionid_node [--params-file config/frictionid.yaml] [--ros-args ...]
    python -m frictionid_ros.node --ros-args --params-file config/frictionid.yaml -p system:=friction-only

Topics (``~`` = ``/frictionid``):

* in:  ``joint_states`` (sensor_msgs/JointState), optional ``effort_topic`` (JointState or
  std_msgs/Float64MultiArray), optional ``reference_topic`` (JointState, feed-forward velocity);
* out: ``~/parameters`` (IdentifiedParameters, transient local: a late subscriber gets the
  active parameters), ``~/friction_torque`` (Float64MultiArray ordered by ``joints``, [N·m | N]),
  ``~/friction_torque_state`` (JointState: velocity used, effort = friction torque; header
  stamp = the stamp of the joint state that triggered it), ``/diagnostics`` (~1 Hz).

Services: ``~/identify`` (Identify), ``~/reset`` (std_srvs/Trigger: clear the buffer),
``~/save`` and ``~/load`` (ParametersFile).

Concurrency: the input callbacks (joint states, effort, reference, feed-forward) run on a hidden
helper node ``_frictionid_input`` spun in its own thread by rclpy's EventsExecutor (or a
SingleThreadedExecutor, ``input_executor``) — the only writer of the ring buffers (rclpy's
MultiThreadedExecutor tops out below ~2 kHz). Services and diagnostics run on this node in a
MultiThreadedExecutor: ``~/identify`` is in a reentrant callback group, so a second request is
answered "busy" at once while the first one waits for the identification, which runs in a
worker process (``identification_worker: process``, see :mod:`frictionid_ros.worker`) or a
worker thread (``thread``). What the callbacks do is in ROS-free modules: :mod:`.inputs`
(buffers, feed-forward velocity), :mod:`.service` (``~/identify``: :mod:`.request`,
:mod:`.window`), :mod:`.store` (active parameters); :mod:`.messages` builds the outputs.
"""

from __future__ import annotations

import argparse
import functools
import sys
import threading
import time
import traceback
import warnings
from dataclasses import replace
from pathlib import Path

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from frictionid_interfaces.msg import IdentifiedParameters
    from frictionid_interfaces.srv import Identify, ParametersFile
    from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
    from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension
    from std_srvs.srv import Trigger

from frictionid_core.errors import FrictionIdError

from frictionid_ros import config as cfgmod
from frictionid_ros.buffer import NS
from frictionid_ros.inputs import Inputs
from frictionid_ros.messages import diagnostic_array, parameters_msg
from frictionid_ros.service import IdentifyService
from frictionid_ros.store import ActiveParameters, Results
from frictionid_ros.worker import WorkerProcess, rss_kb

SERVICE_DEPTH = 1000  # request queue of each service [requests]
GIL_SWITCH_INTERVAL = 0.0005  # [s]


def _guarded(fn):
    """Log and swallow an unexpected exception of a callback: it must never stop the executor.

    A service callback answers success=false with the error instead."""

    @functools.wraps(fn)
    def wrapper(self, *args):
        try:
            return fn(self, *args)
        except Exception as exc:  # noqa: BLE001 - the node must stay alive
            key = (fn.__name__, type(exc).__name__, str(exc))
            # once per distinct error, not at 1 kHz; none when shutting down (a publish may fail)
            if self.context.ok() and key not in self._logged_errors:
                if len(self._logged_errors) < 100:
                    self._logged_errors.add(key)
                self._log.error(f"{fn.__name__}: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
            if len(args) == 2 and hasattr(args[1], "success"):
                res = args[1]
                res.success, res.message = False, f"internal error: {type(exc).__name__}: {exc}"
                return res
            return None

    return wrapper


class FrictionIdNode(Node):
    """See the module docstring. Raises FrictionIdError for a bad configuration."""

    def __init__(self, *, context=None):
        super().__init__(cfgmod.NODE_NAME, context=context)
        self.cfg = cfg = self._declare_parameters()
        self._log = self.get_logger()
        self._logged_errors: set = set()
        self.inputs = Inputs(lambda: self.cfg, self._log.warning)
        # Active parameters: restored from the results file so the feed-forward resumes.
        self.active = ActiveParameters(cfg.results_file, self._on_parameters, self._log)
        self.active.restore()
        self.inputs.set_params(self.active.results.per_joint)
        self._worker = WorkerProcess() if cfg.identification_worker == "process" else None

        # Inputs on a hidden helper node with its own single-threaded executor (module docstring):
        # rclpy's MultiThreadedExecutor tops out below ~2 kHz; one thread writes every buffer.
        self.input_node = inp = Node(f"_{self.get_name()}_input", namespace=self.get_namespace(),
                                     context=self.context, use_global_arguments=False,
                                     start_parameter_services=False)
        qos_in = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=cfg.qos_depth,
            reliability=ReliabilityPolicy.BEST_EFFORT if cfg.qos == "sensor_data" else ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE)
        self.input_executor = make_input_executor(cfg.input_executor, self._log, self.context)
        events = not isinstance(self.input_executor, SingleThreadedExecutor)

        def sub(typ, topic, callback):  # callback(message, receipt time [ns, system clock])
            # The SingleThreadedExecutor passes MessageInfo (middleware receipt time); the
            # EventsExecutor passes the message only: receipt = callback entry then.
            inp.create_subscription(typ, topic, (lambda m: callback(m, time.time_ns())) if events
                                    else (lambda m, info: callback(m, info["received_timestamp"])), qos_in)

        self.topics = {"joint_states": self.resolve_topic_name(cfg.joint_states_topic)}
        sub(JointState, self.topics["joint_states"], self._on_joint_state)
        if cfg.effort_topic:
            self.topics["effort"] = self.resolve_topic_name(cfg.effort_topic)
            sub(JointState if cfg.effort_topic_type == "joint_state" else Float64MultiArray, self.topics["effort"],
                self._on_effort)
        if cfg.velocity_source == "reference":
            self.topics["reference"] = self.resolve_topic_name(cfg.reference_topic)
            sub(JointState, self.topics["reference"], self._on_reference)

        qos_out = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._pub_params = self.create_publisher(IdentifiedParameters, "~/parameters", latched)
        self._pub_ff = self.create_publisher(Float64MultiArray, "~/friction_torque", qos_out)
        self._pub_ff_state = self.create_publisher(JointState, "~/friction_torque_state", qos_out)
        self._pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", qos_out)
        self._ff_msg = Float64MultiArray()
        self._ff_state_msg = JointState()

        # Deep request queues: a burst of calls is answered (most of them "busy"), not dropped by DDS.
        qos_srv = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=SERVICE_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
        admin = MutuallyExclusiveCallbackGroup()
        self.create_service(Identify, "~/identify", self._on_identify, qos_profile=qos_srv,
                            callback_group=ReentrantCallbackGroup())
        self.create_service(Trigger, "~/reset", self._on_reset, qos_profile=qos_srv, callback_group=admin)
        self.create_service(ParametersFile, "~/save", self._on_save, qos_profile=qos_srv, callback_group=admin)
        self.create_service(ParametersFile, "~/load", self._on_load, qos_profile=qos_srv, callback_group=admin)
        self.create_timer(cfg.diagnostics_period_s, self._on_diagnostics,
                          callback_group=MutuallyExclusiveCallbackGroup())
        if cfg.feedforward_rate_hz > 0.0:
            inp.create_timer(1.0 / cfg.feedforward_rate_hz, self._on_ff_timer)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self.identify_service = IdentifyService(lambda: self.cfg, self.inputs, self.active, self.topics, self._worker,
                                                self._log)
        if cfg.joints:
            self.inputs.setup(list(cfg.joints))
        restored = sorted(self.active.results.per_joint)
        if restored:
            self._pub_params.publish(parameters_msg(self.active.results, self.inputs.joints))
        self._log.info(
            f"ready: system {cfg.system}, joints {list(cfg.joints) or '(from the first message)'}, buffer "
            f"{cfg.buffer_seconds:g} s ({cfg.capacity} samples), input QoS {cfg.qos}, results {cfg.results_file}"
            + (f", restored parameters of {restored}" if restored else ""))

    # ------------------------------------------------------------------ parameters

    def _declare_parameters(self) -> cfgmod.Config:
        values = {}
        for name, (default, desc, ro) in cfgmod.PARAMETERS.items():
            d = ParameterDescriptor(description=desc, read_only=ro)
            try:
                if isinstance(default, list):
                    p = self.declare_parameter(name, Parameter.Type.STRING_ARRAY, d)
                else:
                    p = self.declare_parameter(name, default, d)
            except Exception as exc:  # e.g. InvalidParameterTypeException for "30" where 30.0 is expected
                raise FrictionIdError(f"parameter '{name}': {exc} (default {default!r}: {type(default).__name__})") from None
            values[name] = p.value
        return cfgmod.make_config(values)

    def _on_set_parameters(self, params) -> SetParametersResult:
        values = {n: self.get_parameter(n).value for n in cfgmod.PARAMETERS}
        values.update({p.name: p.value for p in params})
        try:
            cfg = cfgmod.make_config(values)
        except FrictionIdError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        self.cfg = replace(
            self.cfg, solve=cfg.solve, window_seconds=cfg.window_seconds, min_samples=cfg.min_samples,
            max_missing_pct=cfg.max_missing_pct, smoothing_eps=cfg.smoothing_eps)
        if self.inputs.ff is not None:
            self.inputs.ff.eps = cfg.smoothing_eps
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ inputs and feed-forward

    @_guarded
    def _on_joint_state(self, msg: JointState, t_rx: int) -> None:
        if self.inputs.joint_state(msg, t_rx) and self.cfg.feedforward_rate_hz == 0.0:
            self._publish_ff(t_rx)

    @_guarded
    def _on_effort(self, msg, t_rx: int) -> None:
        self.inputs.effort(msg, t_rx)

    @_guarded
    def _on_reference(self, msg: JointState, t_rx: int) -> None:
        if self.inputs.reference(msg) and self.cfg.feedforward_rate_hz == 0.0:
            self._publish_ff(t_rx)

    @_guarded
    def _on_ff_timer(self) -> None:
        if self.inputs.have_v:
            self._publish_ff()

    def _publish_ff(self, t_rx: int = 0) -> None:
        """Publish the friction torque at the current velocity; ``t_rx``: receipt time of the trigger [ns]."""
        inp, ff = self.inputs, self.inputs.ff
        if ff is None or not ff.active:
            return
        values = ff.torque(inp.v, inp.tau).tolist()
        st = self._ff_state_msg
        if len(st.name) != len(values):  # the first one: the joints are known now
            st.name = list(ff.joints)
            self._ff_msg.layout.dim = [MultiArrayDimension(label="joints", size=len(values), stride=len(values))]
        self._ff_msg.data = values
        st.header.stamp.sec, st.header.stamp.nanosec = divmod(inp.ff_stamp, NS)
        st.velocity = inp.v.tolist()
        st.effort = values
        self._pub_ff.publish(self._ff_msg)
        self._pub_ff_state.publish(st)
        inp.published(t_rx)

    # ------------------------------------------------------------------ services

    @_guarded
    def _on_identify(self, req, res):
        res.success, res.message, identified = self.identify_service.handle(req)
        if identified is not None:
            res.result = parameters_msg(identified, self.inputs.joints)
        if res.success:
            self._log.info(f"identify: {res.message}")
        else:  # rclpy forbids one call site logging at two severities
            self._log.warning(f"identify: {res.message}")
        return res

    def _on_parameters(self, results: Results) -> None:
        """New active parameters (under ``active.lock``): feed them forward and publish them."""
        for problem in self.inputs.set_params(results.per_joint):
            self._log.warning(f"feed-forward: {problem}")
        self._pub_params.publish(parameters_msg(results, self.inputs.joints))

    @_guarded
    def _on_reset(self, req, res):
        res.success, res.message = True, f"buffer cleared ({self.inputs.clear()} samples dropped)"
        self._log.info(res.message)
        return res

    @_guarded
    def _on_save(self, req, res):
        path = self.active.file(req.path)
        res.path, (res.success, res.message) = str(path), self.active.save(path)
        return res

    @_guarded
    def _on_load(self, req, res):
        path = self.active.file(req.path)
        res.path, (res.success, res.message) = str(path), self.active.load(path)
        return res

    # ------------------------------------------------------------------ diagnostics

    @_guarded
    def _on_diagnostics(self) -> None:
        ok, message, values = self.inputs.buffer_status()
        pid = self._worker.pid if self._worker is not None else None
        values.update(rss_kb=rss_kb(), worker_pid=pid or "", worker_rss_kb=rss_kb(pid) if pid else 0)
        service = self.identify_service
        busy = service.busy
        ident = {"busy": busy, "last_success": service.last_ok, "last_status": service.last_status,
                 "active_joints": ",".join(sorted(self.active.results.per_joint)), **self.inputs.feedforward_values()}
        self._pub_diag.publish(diagnostic_array(self.get_fully_qualified_name(), [
            ("joint buffer", ok, message, values),
            ("identification", service.last_ok, ("busy; last: " if busy else "") + service.last_status[:300], ident),
        ], self.get_clock().now().to_msg()))

    def close(self) -> None:
        """Let a waiting ~/identify answer and return; end the worker process."""
        self.identify_service.stopping.set()
        if self._worker is not None:
            self._worker.stop()

    def destroy_node(self) -> None:
        self.input_node.destroy_node()
        super().destroy_node()


def _ros_argv(argv: list[str]) -> list[str]:
    """rclpy arguments, with ``--params-file`` outside ``--ros-args`` turned into a ROS argument."""
    from rclpy.utilities import remove_ros_args

    parser = argparse.ArgumentParser(prog="frictionid_node", description="Joint friction identification node.")
    parser.add_argument("--params-file", action="append", default=[], type=Path,
                        help="YAML parameters (frictionid: ros__parameters: ...); same as --ros-args --params-file")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    extra = []
    for f in opts.params_file:
        if not f.is_file():
            raise FrictionIdError(f"{f}: no such parameters file")
        extra += ["--params-file", str(f.absolute())]
    # ours first: explicit --ros-args -p/--params-file given later take precedence
    return argv[:1] + (["--ros-args", *extra, "--"] if extra else []) + argv[1:]


def make_input_executor(kind: str, log, context=None):
    """The executor of the input node: rclpy's EventsExecutor (C++ event queue: about half the CPU
    per message and a shorter latency tail than the SingleThreadedExecutor, measured in
    bench/ros_load.py) or the SingleThreadedExecutor (the fallback if rclpy lacks the former)."""
    if kind == "events":
        try:
            from rclpy.experimental import EventsExecutor

            return EventsExecutor(context=context)
        except Exception as exc:  # noqa: BLE001 - older rclpy: no EventsExecutor
            log.warning(f"EventsExecutor unavailable ({type(exc).__name__}: {exc}); using SingleThreadedExecutor")
    return SingleThreadedExecutor(context=context)


def _spin(executor, node) -> None:
    """Spin until shutdown. SIGINT/SIGTERM shut the context down, and an executor caught between
    two waits then raises RCLError ("context is not valid"): that is a normal end too."""
    context = node.context
    while context.ok():
        try:
            executor.spin_once(timeout_sec=0.1)
        except (KeyboardInterrupt, ExternalShutdownException):
            return
        except Exception as exc:  # noqa: BLE001
            if not context.ok():
                return
            node.get_logger().error(f"executor: {type(exc).__name__}: {exc}")


def main(argv: list[str] | None = None) -> int:
    """Run the node until SIGINT/SIGTERM; exit code 0, or 2 with one line for a bad configuration."""
    argv = list(sys.argv if argv is None else argv)
    try:
        rclpy.init(args=_ros_argv(argv))
    except FrictionIdError as exc:  # a missing --params-file
        print(f"frictionid_node: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # e.g. an unreadable --params-file given after --ros-args
        print(f"frictionid_node: error: cannot initialise ROS: {exc}", file=sys.stderr)
        return 2
    # A thread waiting for the GIL gets it after at most this long (default 5 ms): bounds how
    # long the services/diagnostics threads can delay the 1 kHz input callback.
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    node, executors, input_thread = None, [], None
    try:
        node = FrictionIdNode()
        inputs = node.input_executor
        inputs.add_node(node.input_node)
        services = MultiThreadedExecutor(num_threads=4)
        services.add_node(node)
        executors = [inputs, services]
        input_thread = threading.Thread(target=_spin, args=(inputs, node.input_node), name="frictionid-input",
                                        daemon=True)
        input_thread.start()
        _spin(services, node)
    except FrictionIdError as exc:
        print(f"frictionid_node: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.close()
        for ex in executors:
            ex.shutdown(timeout_sec=1.0)
        if input_thread is not None:
            input_thread.join(timeout=2.0)  # never destroy a node under a spinning executor
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
