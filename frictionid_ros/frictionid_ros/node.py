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
MultiThreadedExecutor tops out below ~2 kHz). Services and
diagnostics run on this node in a MultiThreadedExecutor: ``~/identify`` is in a reentrant
callback group, so a second request is answered "busy" at once while the first one waits for
the identification, which runs in a worker process (``identification_worker: process``, see
:mod:`frictionid_ros.worker`) or a worker thread (``thread``).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import threading
import time
import traceback
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    import rclpy
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from frictionid_interfaces.msg import IdentifiedParameters, JointFriction
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

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.options import SolveOptions
from frictionid_core.io.checks import check_series
from frictionid_core.timeseries import JointSeries

from frictionid_ros import config as cfgmod
from frictionid_ros.buffer import NO_EFFORT, NO_POSITION, NO_VELOCITY, JointRing, NameMap, put
from frictionid_ros.feedforward import FeedForward
from frictionid_ros.store import Results, read_results, shared_parameters, split_identification, write_results
from frictionid_ros.worker import WorkerProcess, run_identification

NS = 1_000_000_000
LATENCY_WINDOW = 4096  # feed-forward latencies kept for the percentiles [samples]
SERVICE_DEPTH = 1000  # request queue of each service [requests]
GIL_SWITCH_INTERVAL = 0.0005  # [s]


def _guarded(fn):
    """Log and swallow an unexpected exception of a callback: it must never stop the executor.

    A service callback answers success=false with the error instead."""
    import functools

    @functools.wraps(fn)
    def wrapper(self, *args):
        try:
            return fn(self, *args)
        except Exception as exc:  # noqa: BLE001 - the node must stay alive
            key = (fn.__name__, type(exc).__name__, str(exc))
            if not self.context.ok():  # shutting down: a publish may fail, nothing to report
                pass
            elif key not in self._logged_errors:  # once per distinct error, not at 1 kHz
                if len(self._logged_errors) < 100:
                    self._logged_errors.add(key)
                self._log.error(f"{fn.__name__}: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
            if len(args) == 2 and hasattr(args[1], "success"):
                res = args[1]
                res.success, res.message = False, f"internal error: {type(exc).__name__}: {exc}"
                return res
            return None

    return wrapper


def _time(ns: int) -> Time:
    ns = int(ns)
    return Time(sec=ns // NS, nanosec=ns % NS)


def _ns(t: Time) -> int:
    return int(t.sec) * NS + int(t.nanosec)


@dataclass
class Job:
    """A validated identification request."""

    joints: list[str]
    friction: str
    asymmetric: bool
    solver: str
    seed: int
    options: dict
    window_seconds: float
    start_ns: int
    end_ns: int
    dry_run: bool


class FrictionIdNode(Node):
    """See the module docstring. Raises FrictionIdError for a bad configuration."""

    def __init__(self, *, context=None):
        super().__init__(cfgmod.NODE_NAME, context=context)
        self.cfg = self._declare_parameters()
        cfg = self.cfg
        self._pre = cfgmod.preprocessing_override(cfg.system, cfg.filter_cutoff_hz, cfg.decimation)
        self._log = self.get_logger()
        self._logged_errors: set = set()
        self._stopping = threading.Event()
        self._busy = threading.Lock()
        self._busy_since = 0.0
        self._state_lock = threading.Lock()

        # Buffers (created when the joints are known: from the config or the first message).
        self._ring: JointRing | None = None
        self._map: NameMap | None = None
        self._effort_ring: JointRing | None = None
        self._effort_map: NameMap | None = None
        self._ref_map: NameMap | None = None
        self._ff: FeedForward | None = None
        self._v = self._tau = self._ref_pos = self._ref_prev = None
        self._ref_t = 0
        self._ff_stamp = 0
        self._have_v = False
        self._received = self._rejected = self._effort_received = self._ff_published = 0
        self._rate_mark = (time.monotonic(), 0)
        self._rate_hz = 0.0
        self._last_reject = ""
        self._last_status = "no identification yet"
        self._last_ok = True
        self._lat = np.zeros(LATENCY_WINDOW)
        self._ff_n_lat = 0

        # Active parameters: restored from the results file so the feed-forward resumes.
        self._results = Results()
        self._restore()
        self._worker = WorkerProcess() if cfg.identification_worker == "process" else None

        # Inputs live on a hidden helper node spun by its own single-threaded executor: rclpy's
        # MultiThreadedExecutor hands every message to a thread pool and tops out below ~2 kHz
        # (measured), too slow for 1 kHz joint states plus the feed-forward. One thread runs
        # every input callback, so it is the only writer of the buffers and feed-forward state.
        self.input_node = Node(f"_{self.get_name()}_input", namespace=self.get_namespace(), context=self.context,
                               use_global_arguments=False, start_parameter_services=False)
        self._cb_identify = ReentrantCallbackGroup()
        self._cb_admin = MutuallyExclusiveCallbackGroup()
        self._cb_diag = MutuallyExclusiveCallbackGroup()
        qos_in = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=cfg.qos_depth,
            reliability=ReliabilityPolicy.BEST_EFFORT if cfg.qos == "sensor_data" else ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE)
        self.input_executor = make_input_executor(cfg.input_executor, self._log, self.context)
        events = not isinstance(self.input_executor, SingleThreadedExecutor)

        def sub(typ, topic, callback):
            # The SingleThreadedExecutor passes MessageInfo (middleware receipt time); the
            # EventsExecutor passes the message only: receipt = callback entry then.
            cb = (lambda m: callback(m, None)) if events else callback
            inp.create_subscription(typ, topic, cb, qos_in)

        inp = self.input_node
        self.topics = {"joint_states": self.resolve_topic_name(cfg.joint_states_topic)}
        sub(JointState, self.topics["joint_states"], self._on_joint_state)
        if cfg.effort_topic:
            self.topics["effort"] = self.resolve_topic_name(cfg.effort_topic)
            typ = JointState if cfg.effort_topic_type == "joint_state" else Float64MultiArray
            sub(typ, self.topics["effort"], self._on_effort)
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
        self.create_service(Identify, "~/identify", self._on_identify, qos_profile=qos_srv,
                            callback_group=self._cb_identify)
        self.create_service(Trigger, "~/reset", self._on_reset, qos_profile=qos_srv, callback_group=self._cb_admin)
        self.create_service(ParametersFile, "~/save", self._on_save, qos_profile=qos_srv, callback_group=self._cb_admin)
        self.create_service(ParametersFile, "~/load", self._on_load, qos_profile=qos_srv, callback_group=self._cb_admin)
        self.create_timer(cfg.diagnostics_period_s, self._on_diagnostics, callback_group=self._cb_diag)
        if cfg.feedforward_rate_hz > 0.0:
            inp.create_timer(1.0 / cfg.feedforward_rate_hz, self._on_ff_timer)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        if cfg.joints:
            self._setup_joints(list(cfg.joints))
        if self._results.per_joint:
            self._publish_parameters()
        self._log.info(
            f"ready: system {cfg.system}, joints {list(cfg.joints) or '(from the first message)'}, buffer "
            f"{cfg.buffer_seconds:g} s ({cfg.capacity} samples), input QoS {cfg.qos}, results {cfg.results_file}"
            + (f", restored parameters of {sorted(self._results.per_joint)}" if self._results.per_joint else ""))

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
        self.cfg = replace(self.cfg, friction_model=cfg.friction_model, asymmetric=cfg.asymmetric,
                           solver=cfg.solver, seed=cfg.seed, window_seconds=cfg.window_seconds,
                           min_samples=cfg.min_samples, max_missing_pct=cfg.max_missing_pct,
                           smoothing_eps=cfg.smoothing_eps)
        if self._ff is not None:
            self._ff.eps = cfg.smoothing_eps
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ buffers

    def _setup_joints(self, joints: list[str]) -> None:
        cfg = self.cfg
        nj = len(joints)
        self._map = NameMap(joints)
        if cfg.effort_topic:
            self._effort_ring = JointRing(joints, cfg.capacity)
            self._effort_map = NameMap(joints)
        if cfg.velocity_source == "reference":
            self._ref_map = NameMap(joints)
            self._ref_pos = np.full(nj, np.nan)
            self._ref_prev = np.full(nj, np.nan)
        self._v = np.zeros(nj)
        self._tau = np.zeros(nj)
        ff = FeedForward(joints, cfg.smoothing_eps)
        for problem in ff.set_params(self._results.per_joint):
            self._log.warning(f"feed-forward: {problem}")
        self._ff = ff
        self._ff_msg.layout.dim = [MultiArrayDimension(label="joints", size=nj, stride=nj)]
        self._ff_state_msg.name = list(joints)
        self._ring = JointRing(joints, cfg.capacity)  # last: callbacks test it to know the setup is complete

    def _reject(self, what: str) -> None:
        self._rejected += 1
        if what != self._last_reject:  # log each new reason once, not 1000 times a second
            self._last_reject = what
            self._log.warning(f"ignored message: {what}")

    @_guarded
    def _on_joint_state(self, msg: JointState, info) -> None:
        t_rx = info["received_timestamp"] if info else time.time_ns()  # receipt [ns, system clock]
        ring = self._ring
        names = msg.name
        if ring is None:
            if not names:
                return self._reject(f"'{self.cfg.joint_states_topic}': JointState without joint names")
            self._setup_joints(list(names))
            ring = self._ring
        try:
            idx = self._map.index(names)
        except KeyError as exc:
            return self._reject(f"'{self.cfg.joint_states_topic}': {exc.args[0]}")
        n = len(names)
        st = msg.header.stamp
        t_ns = st.sec * NS + st.nanosec or time.time_ns()
        flags = 0
        with ring.lock:
            k = ring.head
            ring.t_ns[k] = t_ns
            ring.rx_ns[k] = t_rx
            if not put(ring.position[k], msg.position, idx, n):
                flags |= NO_POSITION
            if not put(ring.velocity[k], msg.velocity, idx, n):
                flags |= NO_VELOCITY
            if self._effort_ring is None and not put(ring.effort[k], msg.effort, idx, n):
                flags |= NO_EFFORT
            ring.flags[k] = flags
            ring.commit()
        self._received += 1
        if self._ref_map is not None:
            return
        v = self._v
        if not flags & NO_VELOCITY:
            v[:] = ring.velocity[k]
        else:  # finite difference of the two newest buffered positions
            prev = ring.last_row(1)
            dt = (t_ns - int(ring.t_ns[prev])) * 1e-9 if prev is not None else 0.0
            if dt > 0.0:
                np.subtract(ring.position[k], ring.position[prev], out=v)
                v /= dt
            else:
                v.fill(np.nan)  # unknown velocity → zero torque
        self._ff_stamp = t_ns
        self._have_v = True
        if self.cfg.feedforward_rate_hz == 0.0:
            self._publish_ff(t_rx)

    @_guarded
    def _on_effort(self, msg, info) -> None:
        ring = self._effort_ring
        if ring is None:
            return self._reject(f"'{self.cfg.effort_topic}': effort before the joint names are known")
        flags = 0
        if isinstance(msg, JointState):
            try:
                idx = self._effort_map.index(msg.name)
            except KeyError as exc:
                return self._reject(f"'{self.cfg.effort_topic}': {exc.args[0]}")
            st = msg.header.stamp
            t_ns = st.sec * NS + st.nanosec or time.time_ns()
            n, src = len(msg.name), msg.effort
        else:
            # no stamp: paired with the joint states by receipt time (same clock, same path)
            t_ns, idx, src, n = info["received_timestamp"] if info else time.time_ns(), None, msg.data, len(ring.joints)
            if len(src) != n:
                return self._reject(f"'{self.cfg.effort_topic}': {len(src)} values for {n} joints {ring.joints}")
        with ring.lock:
            k = ring.head
            ring.t_ns[k] = t_ns
            if not put(ring.effort[k], src, idx, n):
                flags |= NO_EFFORT
            ring.flags[k] = flags
            ring.commit()
        self._effort_received += 1

    @_guarded
    def _on_reference(self, msg: JointState, info) -> None:
        t_rx = info["received_timestamp"] if info else time.time_ns()
        if self._ref_map is None:
            return self._reject(f"'{self.cfg.reference_topic}': reference before the joint names are known")
        try:
            idx = self._ref_map.index(msg.name)
        except KeyError as exc:
            return self._reject(f"'{self.cfg.reference_topic}': {exc.args[0]}")
        n = len(msg.name)
        st = msg.header.stamp
        t_ns = st.sec * NS + st.nanosec or time.time_ns()
        v = self._v
        if not put(v, msg.velocity, idx, n):  # no desired velocity: differentiate the desired position
            pos, prev = self._ref_pos, self._ref_prev
            prev[:] = pos
            if not put(pos, msg.position, idx, n):
                return self._reject(f"'{self.cfg.reference_topic}': neither velocity nor position")
            dt = (t_ns - self._ref_t) * 1e-9 if self._ref_t else 0.0
            if dt > 0.0:
                np.subtract(pos, prev, out=v)
                v /= dt
            else:
                v.fill(np.nan)
        self._ref_t = t_ns
        self._ff_stamp = t_ns
        self._have_v = True
        if self.cfg.feedforward_rate_hz == 0.0:
            self._publish_ff(t_rx)

    # ------------------------------------------------------------------ feed-forward

    def _publish_ff(self, t_rx: int = 0) -> None:
        """Publish the friction torque at the current velocity; ``t_rx``: receipt time of the trigger [ns]."""
        ff = self._ff
        if ff is None or not ff.active:
            return
        tau = ff.torque(self._v, self._tau)
        values = tau.tolist()
        self._ff_msg.data = values
        st = self._ff_state_msg
        st.header.stamp.sec, st.header.stamp.nanosec = divmod(self._ff_stamp, NS)
        st.velocity = self._v.tolist()
        st.effort = values
        self._pub_ff.publish(self._ff_msg)
        self._pub_ff_state.publish(st)
        if t_rx:
            self._lat[self._ff_n_lat % LATENCY_WINDOW] = (time.time_ns() - t_rx) * 1e-9
            self._ff_n_lat += 1
        self._ff_published += 1

    @_guarded
    def _on_ff_timer(self) -> None:
        if self._have_v:
            self._publish_ff()

    # ------------------------------------------------------------------ identification

    def _parse(self, req) -> Job:
        cfg = self.cfg
        ring = self._ring
        buffered = ring.joints if ring is not None else list(cfg.joints)
        joints = list(req.joints) or list(buffered)
        unknown = [j for j in joints if j not in buffered]
        if unknown:
            raise InputError(f"unknown joint(s) {unknown}; buffered joints: {buffered or 'none yet'}")
        if len(set(joints)) != len(joints):
            raise InputError(f"duplicated joint names in {joints}")
        try:
            opts = SolveOptions(friction=req.friction_model or cfg.friction_model,
                                asymmetric=bool(req.asymmetric or cfg.asymmetric), solver=req.solver or cfg.solver,
                                budget=int(req.budget), pop=int(req.population))
        except FrictionIdError as exc:
            raise InputError(str(exc)) from None
        friction, solver, options = opts.friction, opts.solver, opts.solver_options()
        seed = int(req.seed) if req.seed > 0 else cfg.seed if req.seed == 0 else int(np.random.SeedSequence().entropy % 2**63)
        ws = float(req.window_seconds)
        start, end = _ns(req.window_start), _ns(req.window_end)
        if not math.isfinite(ws) or ws < 0.0:
            raise InputError(f"window_seconds must be >= 0, got {ws}")
        if ws > 0.0 and (start or end):
            raise InputError("both window_seconds and window_start/window_end given; use one of them")
        if start and end and end <= start:
            raise InputError("window_end must be after window_start")
        if ws == 0.0 and not (start or end):
            ws = cfg.window_seconds
        return Job(joints, friction, bool(req.asymmetric or cfg.asymmetric), solver, seed, options, ws, start, end,
                   bool(req.dry_run))

    def _window_series(self, job: Job) -> tuple[JointSeries, int, int, list[str]]:
        """The request's window as a checked JointSeries, its first/last stamps [ns] and notes."""
        cfg = self.cfg
        ring = self._ring
        topic = self.topics["joint_states"]
        if ring is None or ring.count == 0:
            raise InputError(f"too little data: no joint states buffered on '{topic}' (need at least {cfg.min_samples})")
        w = ring.snapshot()
        t = w.t_ns
        if job.start_ns or job.end_ns:
            keep = np.ones(len(t), bool)
            if job.start_ns:
                keep &= t >= job.start_ns
            if job.end_ns:
                keep &= t <= job.end_ns
            what = "in window_start..window_end"
        else:
            span = job.window_seconds or cfg.buffer_seconds
            keep = t >= t.max() - int(span * NS)
            what = f"in the last {span:g} s"
        w = w.take(keep)
        n = len(w)
        if n < max(cfg.min_samples, 3):
            raise InputError(f"too little data: {n} joint-state samples {what} (need at least {cfg.min_samples}); "
                             f"{ring.count} buffered")
        cols = [ring.joints.index(j) for j in job.joints]
        pick = np.ix_(np.arange(n), cols)
        missing_pos = int(np.count_nonzero(w.flags & NO_POSITION))
        if missing_pos:
            raise InputError(f"field 'position' is empty or shorter than 'name' in {missing_pos} of {n} "
                             f"joint_states messages {what}")
        notes = []
        if self._effort_ring is None:
            missing = int(np.count_nonzero(w.flags & NO_EFFORT))
            if missing:
                raise InputError(
                    f"empty effort: field 'effort' is empty or shorter than 'name' in {missing} of {n} joint_states "
                    f"messages {what}; publish effort in the JointState or set the parameter 'effort_topic'")
            effort = w.effort[pick]
        else:
            w, effort, note = self._effort_on(w, cols, what)
            pick = np.ix_(np.arange(len(w)), cols)
            if note:
                notes.append(note)
        velocity = None if np.any(w.flags & NO_VELOCITY) else w.velocity[pick]
        t0 = int(w.t_ns.min())
        series = JointSeries(t=(w.t_ns - t0) * 1e-9, joints=list(job.joints), position=w.position[pick], effort=effort,
                             velocity=velocity, source=f"{topic} ({n} samples {what})")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            series = check_series(series)
        notes += [str(c.message) for c in caught if issubclass(c.category, UserWarning)]
        notes += self._check_gaps(series, what)
        return series, t0, int(w.t_ns.max()), notes

    def _check_gaps(self, series: JointSeries, what: str) -> list[str]:
        """Estimate lost samples from the stamps (gaps > 1.5 median periods); refuse too many."""
        dt = np.diff(series.t)
        med = float(np.median(dt))
        gaps = dt > 1.5 * med
        if not gaps.any():
            return []
        n_gaps = int(gaps.sum())
        missing = int(np.round(dt[gaps] / med).sum()) - n_gaps
        pct = 100.0 * missing / (len(series) + missing)
        text = (f"about {missing} of {len(series) + missing} joint states ({pct:.2f} %) lost or late {what} "
                f"({n_gaps} gaps, longest {dt.max() * 1e3:.1f} ms at a {med * 1e3:.3g} ms period)")
        if pct > self.cfg.max_missing_pct:
            raise InputError(f"gaps in the stamps: {text}, more than max_missing_pct = {self.cfg.max_missing_pct:g} %; "
                             "check the input QoS (qos, qos_depth) and the publisher's timing")
        return [text]

    def _effort_on(self, w, cols, what):
        """Interpolate the separate effort topic at the joint states of window ``w``: at their header
        stamps for a JointState effort topic, at their receipt times for an unstamped Float64MultiArray."""
        e = self._effort_ring.snapshot()
        topic = self.topics["effort"]
        if len(e) == 0:
            raise InputError(f"empty effort: nothing received on the effort topic '{topic}'")
        bad = int(np.count_nonzero(e.flags & NO_EFFORT))
        if bad:
            raise InputError(f"empty effort: field 'effort' is empty or short in {bad} messages on '{topic}'")
        order = np.argsort(e.t_ns, kind="stable")
        te, eff = e.t_ns[order], e.effort[order]
        at = w.t_ns if self.cfg.effort_topic_type == "joint_state" else w.rx_ns
        inside = (at >= te[0]) & (at <= te[-1])
        if inside.sum() < max(self.cfg.min_samples, 3):
            raise InputError(f"too little data: effort topic '{topic}' overlaps only {int(inside.sum())} joint "
                             f"states {what}")
        dropped = len(w) - int(inside.sum())
        w = w.take(inside)
        x = (at[inside] - te[0]).astype(float)
        xe = (te - te[0]).astype(float)
        effort = np.column_stack([np.interp(x, xe, eff[:, c]) for c in cols])
        return w, effort, (f"{dropped} joint states outside the effort topic's time range dropped" if dropped else "")

    def _run(self, job: Job) -> tuple[dict, int, int, int, list[str]]:
        series, t0, t1, notes = self._window_series(job)
        kwargs = dict(system=self.cfg.system, friction=job.friction, asymmetric=job.asymmetric,
                      solver=job.solver, seed=job.seed, **job.options)
        if self._pre is not None:
            kwargs["preprocessing"] = self._pre
        if self._worker is not None:
            status, payload = self._worker.run(series, kwargs, self._stopping)
        else:
            status, payload = run_identification(series, kwargs)
        if status == "error":
            raise FrictionIdError(payload)
        if status == "crash":
            self._log.error(f"identification crashed: {payload}")
            raise FrictionIdError(f"identification failed: {payload.splitlines()[0]}")
        d = payload
        bad = [k for k, v in d["params"].items() if not math.isfinite(v)]
        if bad:
            raise FrictionIdError(f"identification failed: non-finite parameter(s) {bad}")
        return d, t0, t1, len(series), notes

    @_guarded
    def _on_identify(self, req, res):
        t_start = time.monotonic()
        try:
            job = self._parse(req)
        except FrictionIdError as exc:
            return self._answer(res, False, str(exc), record=True)
        if not self._busy.acquire(blocking=False):
            return self._answer(res, False, f"busy: an identification is already running "
                                            f"(for {time.monotonic() - self._busy_since:.1f} s); try again later")
        try:
            self._busy_since = time.monotonic()
            box: dict = {}
            done = threading.Event()

            def work():
                try:
                    box["result"] = self._run(job)
                except BaseException as exc:  # reported to the caller below, never kills the node
                    box["error"] = exc
                finally:
                    done.set()

            threading.Thread(target=work, name="frictionid-identify", daemon=True).start()
            while not done.wait(0.1):
                if self._stopping.is_set():
                    return self._answer(res, False, "node shutting down", record=True)
            if "error" in box:
                exc = box["error"]
                if isinstance(exc, FrictionIdError):
                    return self._answer(res, False, str(exc), record=True)
                self._log.error("identification crashed:\n" + "".join(traceback.format_exception(exc)))
                return self._answer(res, False, f"identification failed: {type(exc).__name__}: {exc}", record=True)
            d, t0, t1, n, notes = box["result"]
            stamp = time.time_ns()
            per_joint = split_identification(d, stamp)
            msg = self._make_parameters_msg(per_joint, t0, t1, n, stamp, d)
            res.result = msg
            text = (f"identified {d['system']}/{d['friction']}{'-asym' if d['asymmetric'] else ''} with {d['solver']} "
                    f"on {n} samples of {job.joints} in {time.monotonic() - t_start:.2f} s: "
                    + ", ".join(f"{k}={v:.6g}" for k, v in d["params"].items()))
            if job.dry_run:
                text += " (dry run: active parameters unchanged)"
            else:
                text += self._activate(per_joint, d, t0, t1, n, stamp)
            if notes:
                text += "; notes: " + "; ".join(notes)
            return self._answer(res, True, text, record=True)
        finally:
            self._busy.release()

    def _answer(self, res, ok: bool, message: str, record: bool = False):
        res.success, res.message = ok, message
        if record:
            self._last_status, self._last_ok = message, ok
        if ok:
            self._log.info(f"identify: {message}")
        else:  # rclpy forbids one call site logging at two severities
            self._log.warning(f"identify: {message}")
        return res

    # ------------------------------------------------------------------ active parameters

    def _activate(self, per_joint, last: dict | None, t0: int, t1: int, n: int, stamp: int,
                  save: bool = True) -> str:
        """Make ``per_joint`` active (merged), publish it, and save it; returns a note for the reply."""
        with self._state_lock:
            merged = dict(self._results.per_joint)
            merged.update(per_joint)
            self._results = Results(merged, last, t0, t1, n, stamp)
            if self._ff is not None:
                for problem in self._ff.set_params(merged):
                    self._log.warning(f"feed-forward: {problem}")
            self._publish_parameters()
            if not save:
                return ""
            try:
                path = write_results(self.cfg.results_file, self._results)
                return f"; saved to {path}"
            except FrictionIdError as exc:
                self._log.error(str(exc))
                return f"; NOT saved: {exc}"

    def _restore(self) -> None:
        path = self.cfg.results_file
        if not path.exists():
            return
        try:
            self._results = read_results(path)
        except FrictionIdError as exc:
            self._log.error(f"parameters not restored: {exc}")

    def _make_parameters_msg(self, per_joint, t0: int, t1: int, n: int, stamp: int,
                             result: dict | None) -> IdentifiedParameters:
        """``result``: the core's identification dict (source of the shared parameters)."""
        msg = IdentifiedParameters()
        msg.shared_param_names, msg.shared_param_values, msg.shared_param_std = shared_parameters(result)
        msg.header.stamp = _time(stamp)
        msg.window_start, msg.window_end, msg.samples = _time(t0), _time(t1), int(n)
        order = [j for j in (self._ring.joints if self._ring else self.cfg.joints) if j in per_joint]
        order += [j for j in per_joint if j not in order]
        nan = float("nan")
        for j in order:
            p = per_joint[j]
            m = p.metrics
            msg.joints.append(JointFriction(
                joint_name=j, system_model=p.system, friction_model=p.friction, asymmetric=p.asymmetric,
                solver=p.solver, param_names=list(p.params), param_values=[float(v) for v in p.params.values()],
                param_std=[float(p.std.get(k, nan)) for k in p.params],
                relerr_pct=float(m.get("relerr_pct", nan)), r2=float(m.get("r2", nan)), rmse=float(m.get("rmse", nan)),
                err_std=float(m.get("error_std", nan)), cond=float(m.get("cond", nan)),
                samples=max(0, min(int(p.samples), 2**32 - 1)), stamp=_time(p.stamp_ns)))
        return msg

    def _publish_parameters(self) -> None:
        r = self._results
        self._pub_params.publish(self._make_parameters_msg(r.per_joint, r.window_start_ns, r.window_end_ns,
                                                           r.window_samples, r.stamp_ns, r.last))

    @_guarded
    def _on_reset(self, req, res):
        n = self._ring.count if self._ring is not None else 0
        for ring in (self._ring, self._effort_ring):
            if ring is not None:
                ring.clear()
        res.success, res.message = True, f"buffer cleared ({n} samples dropped)"
        self._log.info(res.message)
        return res

    @_guarded
    def _on_save(self, req, res):
        path = Path(os.path.expanduser(req.path)).absolute() if req.path else self.cfg.results_file
        with self._state_lock:
            results = self._results
        res.path = str(path)
        if not results.per_joint:
            res.success, res.message = False, "no active parameters to save (identify or load first)"
            return res
        try:
            write_results(path, results)
            res.success, res.message = True, f"saved parameters of {sorted(results.per_joint)} to {path}"
        except FrictionIdError as exc:
            res.success, res.message = False, str(exc)
        return res

    @_guarded
    def _on_load(self, req, res):
        path = Path(os.path.expanduser(req.path)).absolute() if req.path else self.cfg.results_file
        res.path = str(path)
        try:
            loaded = read_results(path)
        except FrictionIdError as exc:
            res.success, res.message = False, str(exc)
            return res
        if not loaded.per_joint:
            res.success, res.message = False, f"{path}: no parameters in the file"
            return res
        note = self._activate(loaded.per_joint, loaded.last, loaded.window_start_ns, loaded.window_end_ns,
                              loaded.window_samples, loaded.stamp_ns or time.time_ns(),
                              save=path != self.cfg.results_file)
        res.success, res.message = True, f"loaded parameters of {sorted(loaded.per_joint)} from {path}{note}"
        return res

    # ------------------------------------------------------------------ diagnostics

    def latency_percentiles(self) -> tuple[float, float, float]:
        """Feed-forward latency, receipt of the trigger → both messages published: p50, p99, max over the
        last LATENCY_WINDOW messages [s]. Receipt = middleware receipt (single_threaded input executor)
        or callback entry (events: the EventsExecutor gives no MessageInfo)."""
        n = min(self._ff_n_lat, LATENCY_WINDOW)
        if n == 0:
            return (math.nan,) * 3
        lat = self._lat[:n]
        p50, p99 = np.percentile(lat, [50, 99])
        return float(p50), float(p99), float(lat.max())

    @_guarded
    def _on_diagnostics(self) -> None:
        now = time.monotonic()
        t_prev, n_prev = self._rate_mark
        if now > t_prev:
            self._rate_hz = (self._received - n_prev) / (now - t_prev)
        self._rate_mark = (now, self._received)
        ring = self._ring
        count = ring.count if ring else 0
        cap = ring.capacity if ring else self.cfg.capacity
        span = 0.0
        if ring is not None and count > 1:
            span = (int(ring.t_ns[ring.last_row(0)]) - int(ring.t_ns[ring.last_row(count - 1)])) * 1e-9
        busy = self._busy.locked()
        p50, p99, pmax = self.latency_percentiles()
        kv = lambda k, v: KeyValue(key=k, value=str(v))  # noqa: E731
        buf = DiagnosticStatus(
            name=f"{self.get_fully_qualified_name().lstrip('/')}: joint buffer", hardware_id=self.get_fully_qualified_name(),
            level=DiagnosticStatus.OK if self._rate_hz > 0 else DiagnosticStatus.WARN,
            message=(f"{count}/{cap} samples ({100.0 * count / cap:.1f} %), {self._rate_hz:.1f} Hz"
                     if self._rate_hz > 0 else f"no joint states in the last period ({count}/{cap} samples)"),
            values=[kv("joints", ",".join(ring.joints) if ring else ""), kv("samples", count), kv("capacity", cap),
                    kv("fill_pct", f"{100.0 * count / cap:.2f}"), kv("buffered_seconds", f"{span:.3f}"),
                    kv("rate_hz", f"{self._rate_hz:.2f}"), kv("received", self._received),
                    kv("rejected", self._rejected), kv("effort_received", self._effort_received),
                    kv("buffer_bytes", ring.nbytes if ring else 0), kv("rss_kb", _rss_kb()),
                    kv("worker_pid", (self._worker.pid if self._worker else None) or ""),
                    kv("worker_rss_kb", _rss_kb(self._worker.pid) if self._worker and self._worker.pid else 0)])
        ident = DiagnosticStatus(
            name=f"{self.get_fully_qualified_name().lstrip('/')}: identification", hardware_id=self.get_fully_qualified_name(),
            level=DiagnosticStatus.OK if self._last_ok else DiagnosticStatus.WARN,
            message=("busy; last: " if busy else "") + self._last_status[:300],
            values=[kv("busy", busy), kv("last_success", self._last_ok), kv("last_status", self._last_status),
                    kv("active_joints", ",".join(sorted(self._results.per_joint))),
                    kv("ff_published", self._ff_published), kv("ff_latency_p50_us", f"{p50 * 1e6:.1f}"),
                    kv("ff_latency_p99_us", f"{p99 * 1e6:.1f}"), kv("ff_latency_max_us", f"{pmax * 1e6:.1f}")])
        arr = DiagnosticArray(status=[buf, ident])
        arr.header.stamp = self.get_clock().now().to_msg()
        self._pub_diag.publish(arr)

    def close(self) -> None:
        """Let a waiting ~/identify answer and return; end the worker process."""
        self._stopping.set()
        if self._worker is not None:
            self._worker.stop()

    def destroy_node(self) -> None:
        self.input_node.destroy_node()
        super().destroy_node()


def _rss_kb(pid: int | str = "self") -> int:
    """Resident memory of a process [kB] (0 if unknown)."""
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024
    except (OSError, ValueError, IndexError):
        return 0


def _ros_argv(argv: list[str]) -> tuple[list[str], argparse.Namespace]:
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
    return (argv[:1] + (["--ros-args", *extra, "--"] if extra else []) + argv[1:]), opts


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
        ros_argv, _ = _ros_argv(argv)
    except FrictionIdError as exc:
        print(f"frictionid_node: error: {exc}", file=sys.stderr)
        return 2
    try:
        rclpy.init(args=ros_argv)
    except Exception as exc:  # e.g. an unreadable --params-file given after --ros-args
        print(f"frictionid_node: error: cannot initialise ROS: {exc}", file=sys.stderr)
        return 2
    # A thread waiting for the GIL gets it after at most this long (default 5 ms): bounds how
    # long the services/diagnostics threads can delay the 1 kHz input callback.
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    node = None
    executors = []
    input_thread = None
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
