"""The ``frictionid`` ROS 2 node: buffer joint states, identify friction on request, feed forward.

    frictionid_node [--params-file config/frictionid.yaml] [--lifecycle] [--ros-args ...]
    python -m frictionid_ros.node --ros-args --params-file config/frictionid.yaml -p system:=friction-only

Topics (``~`` = ``/frictionid``):
* in:  ``joint_states`` (sensor_msgs/JointState), optional ``effort_topic`` (JointState or
  std_msgs/Float64MultiArray), optional ``reference_topic`` (JointState, feed-forward velocity);
* out: ``~/parameters`` (IdentifiedParameters, transient local: a late subscriber gets the
  active parameters), ``~/payload`` (geometry_msgs/Inertia, transient local: the active payload,
  in its link's frame), ``~/friction_torque`` (Float64MultiArray ordered by ``joints``, [N·m | N]),
  ``~/friction_torque_state`` (JointState: velocity used, effort = friction torque; header
  stamp = the stamp of the joint state that triggered it), ``/diagnostics`` (~1 Hz).

Services: ``~/identify`` (Identify), ``~/identify_payload`` (IdentifyPayload: a payload with the
active robot parameters as the base, :mod:`frictionid_ros.identification.payload_service`),
``~/reset`` (std_srvs/Trigger: clear the buffer, cancel a running identification), ``~/save`` and
``~/load`` (ParametersFile: files of the results folder only). Actions: ``~/identify``
(frictionid_interfaces/action/Identify: feedback, cancel), ``~/identify_payload`` and
``~/run_experiment`` (an identification experiment run on the robot through its controller, judged
before anything is applied: :mod:`frictionid_ros.experiment`, :mod:`.experiment_action`).

Lifecycle: a managed node (rclpy LifecycleNode): ``configure`` creates the subscriptions,
publishers, services, action, worker and restores the parameters; ``activate``/``deactivate``
start/stop the feed-forward; ``cleanup``/``shutdown`` cancel a running identification and remove
what ``configure`` created. With ``--lifecycle`` the node starts unconfigured and offers the
lifecycle services; without it (the default) it configures and activates itself.

Online re-identification (``online_period_s`` > 0, :mod:`frictionid_ros.identification.online`): the
recent window is identified and its result activated only if the safety gate accepts it;
``~/load`` is gated too; every decision is in ``/diagnostics`` ("safety gate"). Every parameter set
passes the safety screen first and the feed-forward is clamped (:class:`frictionid_ros.store.Screen`);
a node of the same name on the graph at start: refused (``unique_name``).

Concurrency: the input callbacks (joint states, effort, reference, feed-forward) run on a hidden
helper node ``_frictionid_input`` spun in its own thread by rclpy's EventsExecutor (or a
SingleThreadedExecutor, ``input_executor``), the only writer of the ring buffers. With
``realtime_priority`` that thread runs SCHED_FIFO where the OS allows
(:mod:`frictionid_ros.runtime.realtime`). Services, the action, online updates and diagnostics run
on this node in a MultiThreadedExecutor (:mod:`frictionid_ros.runtime.runner`); a second
``~/identify`` is answered "busy" at once while the first waits for the identification in a
low-priority worker process (:mod:`frictionid_ros.worker`) or thread. The callbacks' logic is in
the ROS-free subpackages: :mod:`frictionid_ros.inputs`, :mod:`frictionid_ros.identification` (the
services, requests, windows, online re-identification), :mod:`frictionid_ros.store`;
:mod:`.messages` builds the outputs.
"""

from __future__ import annotations

import functools
import sys
import traceback
import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    from diagnostic_msgs.msg import DiagnosticArray
    from frictionid_interfaces.msg import IdentifiedParameters
    from frictionid_interfaces.srv import Identify, IdentifyPayload, ParametersFile
    from geometry_msgs.msg import Inertia
    from rcl_interfaces.msg import SetParametersResult
    from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
    from rclpy.lifecycle import LifecycleNode, TransitionCallbackReturn
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension
    from std_srvs.srv import Trigger

from frictionid_core import FrictionIdError
from frictionid_ros.identification import IdentifyService, Online, PayloadService
from frictionid_ros.inputs import NS, Inputs
from frictionid_ros.node.action import identify_action, payload_action
from frictionid_ros.node.experiment_action import Publishers, experiment_action, experiment_service
from frictionid_ros.node.messages import diagnostic_array, fill_payload, inertia_msg, parameters_msg
from frictionid_ros.parameters import NODE_NAME, changed_config, declare_parameters
from frictionid_ros.runtime import schedule_this_thread
from frictionid_ros.runtime.runner import check_unique_name, make_input_executor, make_input_node, run
from frictionid_ros.store import ActiveParameters, Results, Screen
from frictionid_ros.worker import WorkerProcess, rss_kb

SERVICE_DEPTH = 1000  # request queue of each service [requests]


def _guarded(fn):
    """Log and swallow an unexpected exception of a callback: it must never stop the executor.

    A service callback answers success=false with the error instead."""

    @functools.wraps(fn)
    def wrapper(self, *args):
        try:
            return fn(self, *args)
        except Exception as exc:  # the node must stay alive
            key = (fn.__name__, type(exc).__name__, str(exc))
            # once per distinct error, not at 1 kHz; none when closing (a publish may fail)
            if self.context.ok() and self._entities and key not in self._logged_errors:
                if len(self._logged_errors) < 100:
                    self._logged_errors.add(key)
                self._log.error(f"{fn.__name__}: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
            if len(args) == 2 and hasattr(args[1], "success"):
                res = args[1]
                res.success, res.message = False, f"internal error: {type(exc).__name__}: {exc}"
                return res
            return None

    return wrapper


class FrictionIdNode(LifecycleNode):
    """See the module docstring. Raises FrictionIdError for a bad configuration; ``lifecycle``:
    start unconfigured with the lifecycle services, else configure and activate at once."""

    def __init__(self, *, context=None, lifecycle: bool = False):
        super().__init__(NODE_NAME, context=context, enable_communication_interface=lifecycle)
        self.cfg = cfg = declare_parameters(self)
        self._log = self.get_logger()
        if cfg.unique_name:
            check_unique_name(self)
        self._logged_errors: set = set()
        self._ff_on = False  # publish the feed-forward (lifecycle state active)
        self._entities: list = []  # (destroy, entity) of what configure created, for cleanup
        self._failure = ""
        self.scheduling = "normal (the input thread has not started)"  # realtime_priority as granted
        self.input_node = self._worker = None
        self.input_executor = make_input_executor(cfg.input_executor, self._log, self.context)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        if not lifecycle:
            for step, trigger in (("configure", self.trigger_configure), ("activate", self.trigger_activate)):
                if trigger() != TransitionCallbackReturn.SUCCESS:
                    raise FrictionIdError(f"{step} failed: {self._failure or 'see the log'}")

    # ------------------------------------------------------------------ lifecycle

    def on_configure(self, state) -> TransitionCallbackReturn:
        try:
            self._open()
        except FrictionIdError as exc:
            self._failure = str(exc)
            self._log.error(f"configure failed: {exc}")
            self.close()
            return TransitionCallbackReturn.FAILURE
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state) -> TransitionCallbackReturn:
        self._ff_on = True
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state) -> TransitionCallbackReturn:
        self._ff_on = False
        return TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state) -> TransitionCallbackReturn:
        self.close()
        return TransitionCallbackReturn.SUCCESS

    on_shutdown = on_cleanup

    def _open(self) -> None:
        """Create what the node serves with (configure)."""
        cfg = self.cfg
        self.inputs = Inputs(lambda: self.cfg, self._log.warning,
                             lambda joints, per_joint: self.active.screen.clamp(joints, per_joint, self.cfg.drive))
        try:
            cfg.results_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            self._log.warning(f"results folder {cfg.results_dir}: {exc.strerror or exc}")
        # Active parameters: restored from the results file so the feed-forward resumes.
        self.active = ActiveParameters(cfg.results_file, self._on_parameters, self._log, cfg.results_dir,
                                       Screen.of(cfg))
        self.active.restore()
        self.inputs.set_params(self.active.results.per_joint)
        self._worker = WorkerProcess(cfg.worker_nice) if cfg.identification_worker == "process" else None

        # Inputs on a hidden helper node with its own single-threaded executor (module docstring):
        # rclpy's MultiThreadedExecutor tops out below ~2 kHz; one thread writes every buffer.
        self.input_node, self.topics = make_input_node(self, cfg, self.input_executor, {
            "joint_states": self._on_joint_state, "effort": self._on_effort, "reference": self._on_reference,
            "feedforward": self._on_ff_timer})

        qos_out = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._pub_params = self._keep(self.destroy_publisher,
                                      self.create_publisher(IdentifiedParameters, "~/parameters", latched))
        self._pub_payload = self._keep(self.destroy_publisher, self.create_publisher(Inertia, "~/payload", latched))
        self._pub_ff, self._pub_ff_state, self._pub_diag = (
            self._keep(self.destroy_publisher, self.create_publisher(typ, topic, qos_out)) for typ, topic in (
                (Float64MultiArray, "~/friction_torque"), (JointState, "~/friction_torque_state"),
                (DiagnosticArray, "/diagnostics")))
        self._ff_msg = Float64MultiArray()
        self._ff_state_msg = JointState()

        self.identify_service = IdentifyService(lambda: self.cfg, self.inputs, self.active, self.topics, self._worker,
                                                self._log)
        self.online = Online(lambda: self.cfg, self.identify_service, self.active, lambda: self.inputs.joints,
                             self._log)
        self.payload_service = PayloadService(lambda: self.cfg, self.identify_service, self.active, self._worker,
                                              lambda: self.inputs.joints, self._log)
        if cfg.online_period_s > 0.0:  # re-identification behind the safety gate (identification.online)
            self._keep(self.destroy_timer, self.create_timer(cfg.online_period_s, self._on_online,
                                                             callback_group=MutuallyExclusiveCallbackGroup()))
        # Deep request queues: a burst of calls is answered (most of them "busy"), not dropped by DDS.
        # A group each: ~/reset and ~/save never wait for a ~/load judged in the worker.
        qos_srv = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=SERVICE_DEPTH,
                             reliability=ReliabilityPolicy.RELIABLE)
        identify = ReentrantCallbackGroup()
        for typ, name, callback, group in ((Identify, "~/identify", self._on_identify, identify),
                                           (IdentifyPayload, "~/identify_payload", self._on_identify_payload,
                                            identify),
                                           (Trigger, "~/reset", self._on_reset, MutuallyExclusiveCallbackGroup()),
                                           (ParametersFile, "~/save", self._on_save, MutuallyExclusiveCallbackGroup()),
                                           (ParametersFile, "~/load", self._on_load, MutuallyExclusiveCallbackGroup())):
            self._keep(self.destroy_service, self.create_service(typ, name, callback, qos_profile=qos_srv,
                                                                 callback_group=group))
        self._keep(self.destroy_timer, self.create_timer(cfg.diagnostics_period_s, self._on_diagnostics,
                                                         callback_group=MutuallyExclusiveCallbackGroup()))
        # ~/run_experiment: moves the robot through its controller (node.experiment_action, docs/experiment.md)
        publishers = self._keep(lambda p: p.destroy(), Publishers(self))
        self.experiment = experiment_service(self, lambda: self.cfg, self.identify_service, self.active, self._worker,
                                             self.inputs, self.topics, publishers, self._log)
        for action in (identify_action(self, self.identify_service, lambda: self.inputs.joints, self._log_identify,
                                       identify),
                       payload_action(self, self.payload_service, self._log_identify, identify),
                       experiment_action(self, self.experiment, lambda: self.inputs.joints, self._log_experiment,
                                         ReentrantCallbackGroup())):
            self._keep(lambda a: a.destroy(), action)

        if cfg.joints:
            self.inputs.setup(list(cfg.joints))
        restored = sorted(self.active.results.per_joint)
        if restored:
            self._pub_params.publish(parameters_msg(self.active.results, self.inputs.joints))
        if self.active.results.payload is not None:
            self._pub_payload.publish(inertia_msg(self.active.results.payload))
        self.input_executor.add_node(self.input_node)
        self._log.info(
            f"configured: system {cfg.system}, joints {list(cfg.joints) or '(from the first message)'}, buffer "
            f"{cfg.buffer_seconds:g} s ({cfg.capacity} samples), input QoS {cfg.qos}, results {cfg.results_file}"
            + (f", restored parameters of {restored}" if restored else ""))

    def close(self) -> None:
        """Cancel a running identification (a waiting ~/identify answers), end the worker process and
        remove what :meth:`_open` created (cleanup, shutdown, end of the process)."""
        self._ff_on = False
        service = getattr(self, "identify_service", None)
        if service is not None:
            service.stopping.set()
            service.cancel_running("node shutting down")  # the worker child stops before its stdin closes
        if self._worker is not None:
            self._worker.stop()
            self._worker = None
        if self.input_node is not None:
            self.input_executor.remove_node(self.input_node)  # a no-op if configure failed before adding it
            self.input_node.destroy_node()
            self.input_node = None
        entities, self._entities = self._entities, []  # empty first: a callback racing this logs nothing
        for destroy, entity in reversed(entities):
            destroy(entity)

    def _keep(self, destroy, entity):
        """Remember ``entity`` (and how to ``destroy`` it) for :meth:`close`; returns it."""
        self._entities.append((destroy, entity))
        return entity

    def _on_set_parameters(self, params) -> SetParametersResult:
        try:
            self.cfg = changed_config(self, self.cfg, params)
        except FrictionIdError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        inputs = getattr(self, "inputs", None)
        if inputs is not None and inputs.ff is not None:
            inputs.ff.eps = self.cfg.smoothing_eps
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ inputs and feed-forward

    def schedule_input_thread(self) -> None:
        """In the input thread before it spins: ``realtime_priority`` (:mod:`frictionid_ros.runtime.realtime`),
        logged."""
        self.scheduling = schedule_this_thread(self.cfg.realtime_priority, self._log,
                                               others=self.cfg.identification_worker == "process")

    @_guarded
    def _on_joint_state(self, msg: JointState, t_rx: int) -> None:
        if self.inputs.joint_state(msg, t_rx) and self.cfg.feedforward_rate_hz == 0.0:
            self._publish_ff(t_rx)
        self.experiment.on_joint_state(msg)  # into an experiment's bag while one records

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
        if ff is None or not ff.active or not self._ff_on:
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

    @_guarded
    def _on_identify(self, req, res):
        answer = self.identify_service.handle(req)
        res.success, res.message = answer.ok, answer.message
        if answer.identified is not None:
            res.result = parameters_msg(answer.identified, self.inputs.joints)
        self._log_identify(answer.ok, answer.message)
        return res

    def _log_identify(self, ok: bool, message: str) -> None:
        if ok:
            self._log.info(f"identify: {message}")
        else:  # rclpy forbids one call site logging at two severities
            self._log.warning(f"identify: {message}")

    def _log_experiment(self, ok: bool, message: str) -> None:
        if ok:
            self._log.info(f"run_experiment: {message}")
        else:  # rclpy forbids one call site logging at two severities
            self._log.warning(f"run_experiment: {message}")

    def _on_parameters(self, results: Results) -> None:
        """New active parameters (under ``active.lock``): feed them forward and publish them."""
        for problem in self.inputs.set_params(results.per_joint):
            self._log.warning(f"feed-forward: {problem}")
        self._pub_params.publish(parameters_msg(results, self.inputs.joints))
        if results.payload is not None:
            self._pub_payload.publish(inertia_msg(results.payload))

    @_guarded
    def _on_identify_payload(self, req, res):
        answer = self.payload_service.handle(req)
        res.success, res.message = answer.ok, answer.message
        fill_payload(res, answer.payload)
        self._log_identify(answer.ok, answer.message)
        return res

    @_guarded
    def _on_reset(self, req, res):
        cancelled = self.identify_service.cancel_running("cancelled by ~/reset")
        res.success, res.message = True, (f"buffer cleared ({self.inputs.clear()} samples dropped)"
                                          + ("; running identification cancelled" if cancelled else ""))
        self._log.info(res.message)
        return res

    @_guarded
    def _on_save(self, req, res):
        return self._file_request(req, res, self.active.save)

    @_guarded
    def _on_load(self, req, res):  # through the safety gate while online re-identification is on
        return self._file_request(req, res, self.online.offer if self.cfg.online_period_s > 0 else self.active.load)

    @_guarded
    def _on_online(self) -> None:
        self.online.tick()

    def _file_request(self, req, res, action):
        """~/save or ~/load: a file of the results folder (refused otherwise, nothing touched)."""
        try:
            path = self.active.file(req.path)
        except FrictionIdError as exc:
            res.success, res.message = False, str(exc)
            self._log.warning(f"{'save' if action == self.active.save else 'load'}: {exc}")
            return res
        res.path, (res.success, res.message) = str(path), action(path)
        return res

    @_guarded
    def _on_diagnostics(self) -> None:
        ok, message, values = self.inputs.buffer_status()
        pid = self._worker.pid if self._worker is not None else None
        values.update(rss_kb=rss_kb(), worker_pid=pid or "", worker_rss_kb=rss_kb(pid) if pid else 0,
                      scheduling=self.scheduling)
        ident = self.identify_service.status(active_joints=",".join(sorted(self.active.results.per_joint)),
                                             feedforward_on=self._ff_on, **self.inputs.feedforward_values())
        self._pub_diag.publish(diagnostic_array(self.get_fully_qualified_name(), [
            ("joint buffer", ok, message, values), ("identification", *ident), ("safety gate", *self.online.status()),
            ("payload", *self.payload_service.status()), ("experiment", *self.experiment.diagnostics()),
        ], self.get_clock().now().to_msg()))


def main(argv: list[str] | None = None) -> int:
    """Run the node until SIGINT/SIGTERM (see :func:`frictionid_ros.runtime.runner.run`)."""
    return run(FrictionIdNode, argv)


if __name__ == "__main__":
    sys.exit(main())
