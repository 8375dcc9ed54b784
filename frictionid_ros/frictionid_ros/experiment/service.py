"""The ``~/run_experiment`` action without ROS: an identification experiment run on the robot, judged
before anything is applied (docs/experiment.md).

One goal, in the node's one identification slot (a concurrent ``~/identify`` is answered "busy"):

1. **plan** (in the worker: :class:`~frictionid_ros.experiment.tasks.PlanTask`): the excitation — a
   file of the results folder, or designed within the robot's limits — its points, and the approach
   from the robot's present pose to its start pose at ``approach_speed`` × the limits, both screened
   against every limit (:func:`frictionid_core.safety.screen_motion`): a refused motion is never sent;
2. **approach**, then **settle** (:data:`SETTLE_S` at the start pose);
3. **excitation**: the joint states the node receives are written to an MCAP bag in the experiment's
   folder (``<results folder>/experiments/<time>/joint_states``) from :data:`LEAD_S` before the motion
   to :data:`TAIL_S` after it;
4. **identification** (in the worker: :class:`~frictionid_ros.experiment.tasks.FitTask`) on the first
   part of the bag, validation on the rest, then the **judgement**: applied to the feed-forward only if
   the validation passes its threshold (:func:`frictionid_core.experiment.judge`) and the parameters
   pass the safety screen, and not in a dry run.

During 2 and 3 every joint state is checked (:class:`frictionid_core.experiment.Monitor`): a tracking
error or an effort beyond the thresholds, joint states that stop for ``silence_s``, a cancel or an
error stop the motion — the robot is told to hold (a JointTrajectoryController: an empty trajectory,
which holds the present position; a position stream: its last command again) — and nothing is
identified or applied. The report (``experiment.json``) says what happened and when.

The ROS side (:mod:`frictionid_ros.node.experiment_action`) gives a commander (made by
``commander(interface, topic, joints, rate_hz)``: ``send(motion, start_ns)``, ``tick(now_ns)``, ``hold(q)``,
``close()``) and ``serialize(msg)``; the node's input
thread hands every joint state to :meth:`ExperimentService.on_joint_state`.
"""

from __future__ import annotations

import json
import math
import time
import traceback
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from frictionid_core import FrictionIdError, write_json
from frictionid_core.experiment import Abort, Monitor, judge
from frictionid_ros.experiment.recording import BagRecorder
from frictionid_ros.experiment.settings import Settings, parse_goal
from frictionid_ros.experiment.tasks import FitTask, PlanTask
from frictionid_ros.inputs import NS, stamp_ns
from frictionid_ros.store import Results, split_identification
from frictionid_ros.worker import Cancelled, JobControl, checked_result, run_identification

SETTLE_S = 0.3  # at rest at the start pose before the excitation [s]
LEAD_S = 0.5  # the bag starts this long before the excitation's first point [s]
TAIL_S = 0.5  # and ends this long after its last [s]
START_DELAY_S = 0.2  # a trajectory's start stamp is this far ahead of its sending [s]
STOPPED_SPEED = 0.01  # after a hold: the robot is still when every joint is slower than this [rad/s | m/s]
STOP_WATCH_S = 2.0  # how long the node watches the robot come to rest after a hold [s]
WATCH_PERIOD_S = 0.01  # the checks of a trajectory's motion run this often [s]
CLOCK_SLACK_S = 2.0  # a motion is watched at most this long past its end by this node's time [s]
ROBOT_SYSTEMS = "tx40 or urdf:PATH"


@dataclass
class ExperimentAnswer:
    """The answer to one goal (the action's result; ``ok``: it ran to its judgement)."""

    ok: bool
    message: str
    cancelled: bool = False
    accepted: bool = False
    applied: bool = False
    aborted: bool = False
    abort_reason: str = ""
    reason: str = ""
    bag: str = ""
    result_file: str = ""
    validation: dict = field(default_factory=dict)
    identified: Results | None = None
    report: dict = field(default_factory=dict)

    def json(self) -> str:
        return json.dumps(self.report, default=str)


@dataclass
class Status:
    """What the feedback shows: the phase, its progress, the last tracking error and the worst effort ratio."""

    phase: str = "plan"
    progress: float = 0.0
    tracking_error: float = 0.0
    max_effort_ratio: float = 0.0


class Stopped(Exception):
    """The motion was stopped (an :class:`~frictionid_core.experiment.Abort`)."""

    def __init__(self, abort: Abort):
        super().__init__(abort.text)
        self.abort = abort


class ExperimentService:
    """Answers RunExperiment goals (see the module docstring). ``settings()``: the node's Config;
    ``service``: the IdentifyService whose slot it takes; ``active``: ActiveParameters; ``worker``: the
    WorkerProcess (None: a thread); ``inputs``: the node's Inputs (its joint ring); ``topics``: the
    resolved topic names; ``commander(interface, topic, joints, rate_hz)``; ``serialize(msg)`` → bytes;
    ``log`` (rclpy-like)."""

    def __init__(self, settings, service, active, worker, inputs, topics, commander, serialize, log):
        self._settings, self._service, self._active, self._worker = settings, service, active, worker
        self._inputs, self._topics, self._commander, self._serialize, self._log = (
            inputs, topics, commander, serialize, log)
        self._recorder: BagRecorder | None = None
        self._sub: JobControl | None = None  # the worker job under way
        self.status = Status()
        self.watch_gap_s = 0.0  # the longest interval between two checks of a motion [s]
        self.running = False  # an experiment is under way
        self.last_ok, self.last_status = True, "no experiment yet"

    # ------------------------------------------------------------------ input thread
    def on_joint_state(self, msg) -> None:
        """Every joint state the node receives (its input thread): into the bag while one is recorded."""
        recorder = self._recorder
        if recorder is not None:
            recorder.put(stamp_ns(msg.header.stamp) or time.time_ns(), self._serialize(msg))

    # ------------------------------------------------------------------ the goal
    def handle(self, goal, control: JobControl, on_wait=None) -> ExperimentAnswer:
        """Run one goal; ``control``: the client's cancel; ``on_wait(control)`` every 50 ms (feedback)."""
        cfg = self._settings()
        try:
            robot, cols = self._robot(cfg)
            settings = parse_goal(goal, cfg, list(robot.joints))
            if settings.excitation_file:  # a file of the results folder only (as ~/load's)
                path = self._active.file(settings.excitation_file)
                if not path.is_file():
                    raise FrictionIdError(f"{path}: no such excitation file in the results folder")
                settings = replace(settings, excitation_file=str(path))
        except FrictionIdError as exc:
            return self._record(ExperimentAnswer(False, str(exc)))
        outer = JobControl()  # the slot's: cancelled only by a node shutting down
        outer.on_cancel(lambda: control.cancel(outer.reason))
        control.on_cancel(self._cancel_sub)
        answer = self._service.exclusive(lambda: self._running(settings, robot, cols, control), outer,
                                         (lambda _: on_wait(control)) if on_wait is not None else None,
                                         lambda value: value)
        if not isinstance(answer, ExperimentAnswer):  # busy, or the node shutting down
            answer = ExperimentAnswer(False, answer.message, cancelled=answer.cancelled)
        return self._record(answer)

    def _record(self, answer: ExperimentAnswer) -> ExperimentAnswer:
        if not answer.message.startswith("busy"):
            self.last_ok, self.last_status = answer.ok, answer.message
        return answer

    def _cancel_sub(self) -> None:
        sub = self._sub
        if sub is not None:
            sub.cancel("cancelled by the client")

    def _robot(self, cfg):
        """The robot model of the node's system and, per robot joint, its column in the joint ring."""
        from frictionid_core.excitation import robot_of
        from frictionid_core.systems import get_system

        if not (cfg.system == "tx40" or cfg.system.startswith("urdf:")):
            raise FrictionIdError(f"~/run_experiment needs a robot system ({ROBOT_SYSTEMS}); the node's system is "
                                  f"{cfg.system}")
        if cfg.effort_topic or cfg.drive is not None:
            raise FrictionIdError("~/run_experiment records and checks the joint_states' own positions and efforts on "
                                  "the joint side: not with effort_topic or drive_file")
        robot, _ = robot_of(get_system(cfg.system), cfg.system)
        buffered = list(self._inputs.joints)
        missing = [j for j in robot.joints if j not in buffered]
        if missing:
            raise FrictionIdError(f"the joint states lack joint(s) {missing} of {robot.name} (buffered: "
                                  f"{buffered or 'none yet'})")
        return robot, np.array([buffered.index(j) for j in robot.joints])

    def _running(self, s: Settings, robot, cols, control: JobControl) -> ExperimentAnswer:
        """The experiment, in the identification slot."""
        self.running, self.status, self.watch_gap_s = True, Status(), 0.0
        try:
            return self._run(s, robot, cols, control)
        finally:
            self.running = False

    def _run(self, s: Settings, robot, cols, control: JobControl) -> ExperimentAnswer:
        cfg = self._settings()
        t0 = time.monotonic()
        stamp = time.strftime("%Y%m%d-%H%M%S") + f"-{time.time_ns() % NS // 1_000_000:03d}"
        folder = Path(cfg.results_dir) / "experiments" / stamp
        try:
            folder.mkdir(parents=True, exist_ok=False)
        except OSError as exc:
            return ExperimentAnswer(False, f"{folder}: cannot create the experiment's folder ({exc.strerror or exc}); "
                                           "nothing moved")
        report: dict = {"format": "frictionid_ros/experiment/1", "folder": str(folder), "robot": robot.name,
                        "system": cfg.system, "joints": list(robot.joints),
                        "command": {"interface": s.interface, "topic": s.topic, "rate_hz": s.rate_hz},
                        "thresholds": s.thresholds.to_dict(), "approach_speed": s.approach_speed,
                        "validation_share": s.validation_share, "max_floor_ratio": s.max_floor_ratio,
                        "max_relerr_pct": s.max_relerr_pct, "dry_run": s.dry_run, "wall_s": {},
                        "aborted": False, "accepted": False, "applied": False}
        answer = ExperimentAnswer(False, "", report=report)
        commander = monitor = None
        try:
            q_now = self._pose_now(cols, s)
            plan = self._in_worker(PlanTask(cfg.system, s.excitation_file, s.design, str(folder), tuple(q_now),
                                            s.approach_speed, s.rate_hz), control, "plan", cfg)
            report.update(excitation=plan.report, excitation_file=plan.excitation_file, screen=plan.screened,
                          approach={"from": q_now.tolist(), "to": plan.excitation.start.tolist(),
                                    "duration_s": plan.approach.duration})
            report["wall_s"]["plan"] = time.monotonic() - t0
            monitor = Monitor(list(robot.joints), _effort_limits(robot), s.thresholds)
            commander = self._commander(s.interface, s.topic, list(robot.joints), s.rate_hz)
            t1 = time.monotonic()
            self.status.phase = "approach"
            self._move(commander, plan.approach, SETTLE_S, monitor, cols, s, control, "approach")
            report["wall_s"]["approach"] = time.monotonic() - t1
            answer.bag, split_s, n_recorded = self._excite(commander, plan.excitation, monitor, cols, s, control,
                                                            folder, report)
        except Stopped as stop:
            return self._stopped(stop.abort, commander, monitor, cols, answer, folder, t0)
        except Exception as exc:  # whatever went wrong while the robot may move: it is told to hold
            if control.cancelled:
                return self._stopped(Abort("cancel", control.reason, time.time()), commander, monitor, cols, answer,
                                     folder, t0)
            if not isinstance(exc, (FrictionIdError, Cancelled)):
                self._log.error("run_experiment:\n" + "".join(traceback.format_exception(exc)))
                exc = FrictionIdError(f"{type(exc).__name__}: {exc}")
            if commander is not None:
                return self._stopped(Abort("error", str(exc), time.time()), commander, monitor, cols, answer, folder,
                                     t0)
            answer.message = str(exc)
            report["error"] = str(exc)
            self._write_report(folder, report, t0)
            return answer
        finally:
            if commander is not None:
                commander.close()
        report["monitor"] = monitor.figures()
        try:
            return self._judge(s, answer, folder, split_s, n_recorded, control, cfg, t0)
        except (FrictionIdError, Cancelled) as exc:
            answer.message = ("cancelled by the client during the identification; nothing applied" if control.cancelled
                              else f"identification failed: {exc}; nothing applied")
            answer.cancelled = control.cancelled
            report["error"] = answer.message
            self._write_report(folder, report, t0)
            return answer

    # ------------------------------------------------------------------ motion
    def _pose_now(self, cols, s: Settings) -> np.ndarray:
        """The robot's pose from its newest joint state, which must be fresh and carry every position
        and effort."""
        ring = self._inputs.ring
        if ring is None or ring.count == 0:
            raise FrictionIdError("no joint states received yet: the robot's pose is unknown")
        with ring.lock:
            k = ring.last_row(0)
            rx, q, effort = int(ring.rx_ns[k]), ring.position[k][cols].copy(), ring.effort[k][cols].copy()
        age = (time.time_ns() - rx) / NS
        if age > s.thresholds.silence_s:
            raise FrictionIdError(f"no joint states for {age:.3g} s (silence limit {s.thresholds.silence_s:g} s): "
                                  "the robot's pose is unknown")
        if not np.all(np.isfinite(q)):
            raise FrictionIdError("the newest joint state lacks positions: the robot's pose is unknown")
        if not np.all(np.isfinite(effort)):
            raise FrictionIdError("the joint states carry no effort: an experiment needs every joint's effort "
                                  "(it is recorded and checked against the limits)")
        return q

    def _move(self, commander, motion, after_s: float, monitor: Monitor, cols, s: Settings, control, phase: str,
              start_ns: int | None = None, on_tick=None) -> int:
        """Command ``motion`` (from ``start_ns``, default now + START_DELAY_S) and watch it until the
        robot's stamps are ``after_s`` past its end; Stopped on an abort. Returns the start stamp [ns].

        A trajectory's times are the robot's (:meth:`_clock`): its start stamp and the joint states'
        stamps (a controller runs on its own clock; only the silence is measured on this node's); the watch
        ends at the latest CLOCK_SLACK_S after the motion's end by this node's time. A stream's commands are
        timed by this node's clock, and so is the watch: the joint states by their receipt."""
        start_ns = start_ns or self._clock(s) + int(START_DELAY_S * NS)
        commander.send(motion, start_ns)
        end_ns = start_ns + int((motion.duration + after_s) * NS)
        give_up = time.monotonic() + motion.duration + after_s + START_DELAY_S + LEAD_S + CLOCK_SLACK_S
        ring = self._inputs.ring
        with ring.lock:
            cursor = ring.total
        since = time.time()
        newest = 0  # the newest stamp seen [ns]
        period = WATCH_PERIOD_S if s.interface == "trajectory" else 1.0 / s.rate_hz
        last_ns = time.time_ns()
        while True:
            now_ns = time.time_ns()
            self.watch_gap_s = max(self.watch_gap_s, (now_ns - last_ns) / NS)  # this thread's longest pause
            last_ns = now_ns
            if control.cancelled:
                raise Stopped(Abort("cancel", control.reason, now_ns / NS))
            commander.tick(now_ns)
            cursor, rows = _new_rows(ring, cursor)
            if rows is not None:
                t_ns, rx_ns, q, effort = rows
                at = t_ns if s.interface == "trajectory" else rx_ns
                newest = max(newest, int(at[-1]))
                q_ref, _, _ = motion.at((at - start_ns) / NS)
                abort = monitor.check(t_ns / NS, q[:, cols], effort[:, cols], q_ref, rx=rx_ns / NS)
                if abort is not None:
                    raise Stopped(abort)
            abort = monitor.silent(now_ns / NS, since)
            if abort is not None:
                raise Stopped(abort)
            self.status.phase = phase if newest < start_ns + int(motion.duration * NS) else "settle"
            self.status.progress = min(1.0, max(0.0, (newest - start_ns) / max(1, end_ns - start_ns)))
            self.status.tracking_error = monitor.last_tracking
            self.status.max_effort_ratio = float(monitor.max_effort_ratio.max(initial=0.0))
            if on_tick is not None:
                on_tick()
            if newest >= end_ns or time.monotonic() > give_up:
                return start_ns
            time.sleep(period)

    def _clock(self, s: Settings) -> int:
        """Now [ns] on the clock of the commands: the robot's for a trajectory (its newest joint state's
        stamp, moved on by the time since its receipt: a controller takes a trajectory's start stamp on its
        own clock, which may run apart from this node's), this node's for a stream."""
        now = time.time_ns()
        ring = self._inputs.ring
        if s.interface != "trajectory" or ring is None:
            return now
        with ring.lock:
            k = ring.last_row(0)
            if k is None:
                return now
            stamp, rx = int(ring.t_ns[k]), int(ring.rx_ns[k])
        return stamp + (now - rx)

    def _excite(self, commander, excitation, monitor, cols, s: Settings, control, folder: Path, report: dict):
        """The excitation, recorded: (the bag, the split [s from its first sample], messages recorded)."""
        t0 = time.monotonic()
        recorder = BagRecorder(folder / "joint_states", self._topics["joint_states"])
        self._recorder = recorder
        start_ns = self._clock(s) + int(LEAD_S * NS)
        report["excitation_start_ns"] = start_ns
        try:
            self._move(commander, excitation, TAIL_S, monitor, cols, s, control, "excitation", start_ns,
                       on_tick=recorder.flush)
        finally:
            self._recorder = None
            recorder.close()
            report.update(bag=str(recorder.path), recorded_messages=recorder.count)
            report["wall_s"]["excitation"] = time.monotonic() - t0
        first = _first_stamp(recorder.path, self._topics["joint_states"])
        split_s = (start_ns - first) / NS + (1.0 - s.validation_share) * excitation.duration
        report["split_s"] = split_s
        return str(recorder.path), split_s, recorder.count

    def _stopped(self, abort: Abort, commander, monitor, cols, answer: ExperimentAnswer, folder: Path,
                 t0: float) -> ExperimentAnswer:
        """Hold the robot after ``abort``; nothing is identified or applied."""
        report = answer.report
        detected = time.time_ns()
        q_last = self._last_pose(cols)
        if commander is not None:
            self.status.phase = "hold"
            try:
                commander.hold(q_last)
            except Exception as exc:  # the answer must still come
                self._log.error(f"run_experiment: hold failed: {type(exc).__name__}: {exc}")
            held_at = time.time_ns()
            report["stopped_after_s"] = self._watch_stop(cols, detected)
        report.update(aborted=commander is not None, abort_reason=abort.kind, abort_text=abort.text,
                      abort_stamp_ns=int(abort.t * NS), detected_ns=detected,
                      hold_sent_ns=held_at if commander is not None else None)
        if monitor is not None:
            report["monitor"] = monitor.figures()
        answer.aborted, answer.abort_reason = commander is not None, abort.kind
        answer.cancelled = abort.kind == "cancel"
        answer.bag = report.get("bag", "")
        what = {"cancel": "cancelled", "error": "stopped by an error"}.get(abort.kind, "aborted")
        answer.message = (f"experiment {what}: {abort.text}; the robot was told to hold"
                          + ("" if commander is not None else " (it had not moved)") + "; nothing applied")
        answer.reason = answer.message
        self._write_report(folder, report, t0)
        return answer

    def _last_pose(self, cols) -> np.ndarray | None:
        ring = self._inputs.ring
        with ring.lock:
            k = ring.last_row(0)
            return None if k is None else ring.position[k][cols].copy()

    def _watch_stop(self, cols, since_ns: int) -> float | None:
        """Seconds from ``since_ns`` (this node's clock) until a joint state received with every joint
        slower than STOPPED_SPEED (None: not seen within STOP_WATCH_S, e.g. the joint states stopped)."""
        ring = self._inputs.ring
        with ring.lock:
            cursor = ring.total
        deadline = time.monotonic() + STOP_WATCH_S
        while time.monotonic() < deadline:
            time.sleep(WATCH_PERIOD_S)
            cursor, rows = _new_rows(ring, cursor, velocity=True)
            if rows is None:
                continue
            rx_ns, v = rows[1], rows[2][:, cols]
            still = np.all(np.abs(v) < STOPPED_SPEED, axis=1)
            if still.any():
                return max(0.0, (int(rx_ns[int(np.argmax(still))]) - since_ns) / NS)
        return None

    # ------------------------------------------------------------------ judgement
    def _judge(self, s: Settings, answer: ExperimentAnswer, folder: Path, split_s: float, n: int, control, cfg,
               t0: float) -> ExperimentAnswer:
        report = answer.report
        t1 = time.monotonic()
        self.status.phase, self.status.progress = "identification", 0.0
        fit = self._in_worker(FitTask(answer.bag, self._topics["joint_states"], s.request, split_s), control,
                              "identification", cfg)
        report["wall_s"]["identification"] = time.monotonic() - t1
        self.status.phase = "judgement"
        result, validation = fit.result, fit.validation
        result_file = folder / "result.json"
        write_json(result_file, result.to_dict())
        answer.result_file, answer.validation = str(result_file), validation
        verdict = judge(validation, s.max_floor_ratio, s.max_relerr_pct)
        stamp = time.time_ns()
        identified = Results(split_identification(result, stamp, fit.limits), result, 0, 0, n, stamp)
        answer.identified = identified
        reason, applied = "" if verdict.accepted else verdict.reason, ""
        screened = True
        try:
            self._active.screen.check(identified)
        except FrictionIdError as exc:
            screened, reason = False, str(exc)
        accepted = verdict.accepted and screened
        if accepted and s.dry_run:
            reason = "dry run: nothing applied"
        elif accepted:
            try:
                applied = self._active.activate(identified)
            except FrictionIdError as exc:
                accepted, reason = False, str(exc)
        answer.ok, answer.accepted, answer.applied, answer.reason = True, accepted, accepted and not s.dry_run, reason
        report.update(result_file=str(result_file), validation={k: validation.get(k) for k in (
            "relerr_pct", "noise_floor_pct", "rmse", "r2", "samples", "per_joint")}, verdict=verdict.reason,
            screened=screened, accepted=accepted, applied=answer.applied, reason=reason, params=dict(result.params))
        answer.message = (f"experiment done: {verdict.reason}; "
                          + ("applied to the feed-forward" + applied if answer.applied else
                             f"NOT applied: {reason}") + f" (bag {answer.bag})")
        self._write_report(folder, report, t0)
        return answer

    def _in_worker(self, task, control: JobControl, phase: str, cfg):
        """Run ``task`` in the identification worker (or a thread): its outcome; FrictionIdError or
        Cancelled as an identification's."""
        self.status.phase, self.status.progress = phase, 0.0
        sub = JobControl(cfg.max_wall_s)
        self._sub = sub
        try:
            if control.cancelled:
                raise Cancelled(control.reason)
            reply = (self._worker.run(None, task, sub) if self._worker is not None
                     else run_identification(None, task, sub.report))
            return checked_result(reply, self._log.error)[0]
        finally:
            self._sub = None

    def _write_report(self, folder: Path, report: dict, t0: float) -> None:
        report["wall_s"]["total"] = time.monotonic() - t0
        report["watch_max_interval_s"] = self.watch_gap_s
        try:
            write_json(folder / "experiment.json", _plain(report))
        except FrictionIdError as exc:
            self._log.error(f"run_experiment: {exc}")

    def diagnostics(self) -> tuple[bool, str, dict]:
        """(ok, message, values) for /diagnostics: the last experiment's answer, and the phase of one under way."""
        return self.last_ok, self.last_status[:300], {"last_success": self.last_ok, "last_status": self.last_status,
                                                      "phase": self.status.phase if self.running else ""}


def _effort_limits(robot) -> np.ndarray:
    from frictionid_core.excitation import robot_limits

    return robot_limits(robot).effort


def _new_rows(ring, cursor: int, velocity: bool = False):
    """(new cursor, (stamps, receipts [ns], positions — or velocities —, efforts) of the ring's rows
    written since ``cursor``, or None)."""
    with ring.lock:
        total, head, count = ring.total, ring.head, ring.count
        n = min(total - cursor, count)
        if n <= 0:
            return total, None
        idx = (head - n + np.arange(n)) % ring.capacity
        out = (ring.t_ns[idx], ring.rx_ns[idx], (ring.velocity if velocity else ring.position)[idx], ring.effort[idx])
    return total, out


def _first_stamp(bag: Path, topic: str) -> int:
    from frictionid_core.io import first_bag_stamp

    return first_bag_stamp(bag, topic)


def _plain(obj):
    """``obj`` with numpy values and non-finite floats made JSON-ready."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    return obj

