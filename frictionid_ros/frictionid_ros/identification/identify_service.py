"""The ``~/identify`` service and action without ROS: one identification at a time, answered in one line."""

from __future__ import annotations

import contextlib
import threading
import time
import traceback
from dataclasses import dataclass
from typing import TYPE_CHECKING

from frictionid_core import FrictionIdError
from frictionid_core.safety import Limit, data_limits
from frictionid_ros.identification.request import Job, consistency_text, parse_request, summary
from frictionid_ros.identification.window import Selection, window_series
from frictionid_ros.inputs import Inputs
from frictionid_ros.store import ActiveParameters, Results, split_identification
from frictionid_ros.worker import (
    KILLED_NOTE,
    Cancelled,
    Gate,
    JobControl,
    WorkerProcess,
    checked_result,
    run_identification,
)

if TYPE_CHECKING:
    from frictionid_core import IdentifyResult
    from frictionid_core.identification import PayloadResult
    from frictionid_core.safety import Decision

WAIT_PERIOD_S = 0.05  # how often a waiting request checks the wall time and calls on_wait [s]
PREEMPT_WAIT_S = 2.0  # how long a request waits for a cancelled background job to let the slot go [s]


@dataclass
class Answer:
    """The answer to one request: ``ok``, one-line ``message``, the identification (or the payload)
    if ``ok``; ``cancelled``: stopped by a cancel (client, ``~/reset``) or the wall-time limit."""

    ok: bool
    message: str
    identified: Results | None = None
    cancelled: bool = False
    payload: PayloadResult | None = None  # the payload of an ~/identify_payload answer


class IdentifyService:
    """Answers Identify requests on the data of ``inputs``.

    A request arriving while an identification runs is answered "busy" at once, unless what runs
    is a background job (online re-identification, :meth:`slot` with ``background``): that one is
    cancelled and the request runs once it has let the slot go (within :data:`PREEMPT_WAIT_S`). The
    identification runs in ``worker`` (a child process) or, without one, a thread, while the
    caller's thread waits; it is stopped by :meth:`cancel_running`, by the wall-time limit
    ``max_wall_s`` and when :attr:`stopping` is set. ``settings()`` returns the node's current
    :class:`~frictionid_ros.parameters.Config`; ``topics`` the resolved ``joint_states`` (and
    ``effort``) topic names; ``log`` has ``.error``. The last answer is kept for the diagnostics
    (:attr:`last_ok`, :attr:`last_status`), and the last cancel's latency (cancel → identification
    stopped) in :attr:`last_cancel_ms`.
    """

    def __init__(self, settings, inputs: Inputs, active: ActiveParameters, topics: dict[str, str],
                 worker: WorkerProcess | None, log):
        self._settings = settings
        self._inputs = inputs
        self._active = active
        self._topics = topics
        self._worker = worker
        self._log = log
        self.stopping = threading.Event()
        self._busy = threading.Lock()
        self._running: JobControl | None = None
        self._background: JobControl | None = None  # the job in the slot a request may cancel
        self.last_ok, self.last_status = True, "no identification yet"
        self.last_consistency = ""  # consistency_text of the last successful identification
        self.last_cancel_ms = float("nan")

    @property
    def busy(self) -> bool:
        return self._busy.locked()

    @property
    def running(self) -> JobControl | None:
        """The control of the identification under way, if any."""
        return self._running

    def status(self, **values) -> tuple[bool, str, dict]:
        """(ok, message, values) of the identification for /diagnostics; ``values`` are added."""
        busy, running = self.busy, self._running
        return self.last_ok, ("busy; last: " if busy else "") + self.last_status[:300], {
            "busy": busy, "last_success": self.last_ok, "last_status": self.last_status,
            "consistency": self.last_consistency, "last_cancel_ms": f"{self.last_cancel_ms:.1f}",
            "running_s": f"{time.monotonic() - running.t_start:.1f}" if running is not None else "", **values}

    @contextlib.contextmanager
    def slot(self, background: JobControl | None = None, preempt: str | None = None):
        """Hold the one identification slot if it is free: yields True, or False when busy.
        ``background``: the control of a job that yields the slot to a request (cancelled by it);
        ``preempt``: take the slot from such a job (cancelled with this reason, :meth:`_preempt`)
        rather than answer busy."""
        got = self._take(preempt)
        try:
            if got:
                self._background = background
            yield got
        finally:
            if got:
                self._background = None
                self._busy.release()

    def cancel_running(self, reason: str) -> bool:
        """Stop the identification under way (its request is answered ``reason``); False if none."""
        control = self._running
        return control is not None and control.cancel(reason)

    def handle(self, req, control: JobControl | None = None, on_wait=None) -> Answer:
        """Answer an Identify request (or action goal). ``control``: lets the caller cancel the
        identification and read its progress; ``on_wait(control)`` is called every WAIT_PERIOD_S
        while it runs (the action publishes its feedback there)."""
        control = control or JobControl()
        control.wall_s = self._settings().max_wall_s  # the watchdog of the worker too (JobControl.check_wall)
        try:
            job = parse_request(req, self._settings(), self._inputs.joints)
        except FrictionIdError as exc:
            return self._record(False, str(exc))
        return self.exclusive(lambda: self.run_job(job, control), control, on_wait,
                              lambda value: self._identified(job, control, value))

    def exclusive(self, work, control: JobControl, on_wait, done) -> Answer:
        """Run ``work()`` in the one identification slot ("busy" at once when it is taken), in a
        thread while this one waits: stopped by a cancel, the wall-time limit or :attr:`stopping`
        (answered so); a FrictionIdError answered with its message; else ``done(its value)``
        answers. ``on_wait(control)`` as in :meth:`handle`."""
        if not self._take("preempted by a requested identification"):
            running = self._running  # not recorded: the running one is the news
            since = f" (for {time.monotonic() - running.t_start:.1f} s)" if running is not None else ""
            return Answer(False, f"busy: an identification is already running{since}; try again later")
        try:
            self._running = control
            return self._wait(work, control, on_wait, done)
        finally:
            self._running = None
            self._busy.release()

    def _take(self, preempt: str | None) -> bool:
        """Take the slot if it is free, else (``preempt``: the cancel reason) from a background job."""
        return self._busy.acquire(blocking=False) or (preempt is not None and self._preempt(preempt))

    def _preempt(self, reason: str) -> bool:
        """Cancel a background job holding the slot (``reason``) and take the slot once it lets go
        (True), or False: the slot holds a request's identification, or the job did not stop in time."""
        background = self._background
        if background is None:
            return False
        background.cancel(reason)
        return self._busy.acquire(timeout=PREEMPT_WAIT_S)

    def _wait(self, work, control: JobControl, on_wait, done) -> Answer:
        box: dict = {}
        finished = threading.Event()

        def run():
            try:
                box["result"] = work()
            except BaseException as exc:  # reported to the caller below, never kills the node
                box["error"] = exc
            finally:
                control.stopped_at = control.stopped_at or time.monotonic()
                finished.set()

        threading.Thread(target=run, name="frictionid-identify", daemon=True).start()
        while not finished.wait(WAIT_PERIOD_S):
            if self.stopping.is_set():
                control.cancel("node shutting down")
                return self._record(False, "node shutting down")
            control.check_wall()
            if on_wait is not None:
                on_wait(control)
        exc = box.get("error")
        if control.cancelled or isinstance(exc, Cancelled):
            self.last_cancel_ms = (control.stopped_at - control.cancelled_at) * 1e3
            killed = f"; {KILLED_NOTE}" if control.killed else ""
            return self._record(False, f"{control.reason or exc} after {control.stopped_at - control.t_start:.2f} s "
                                       f"(identification stopped {self.last_cancel_ms:.0f} ms after the cancel"
                                       f"{killed}); active parameters unchanged", cancelled=True)
        if exc is not None:
            if isinstance(exc, FrictionIdError):
                return self._record(False, str(exc))
            self._log.error("identification crashed:\n" + "".join(traceback.format_exception(exc)))
            return self._record(False, f"identification failed: {type(exc).__name__}: {exc}")
        return done(box["result"])

    def _identified(self, job: Job, control: JobControl, value) -> Answer:
        """The answer of a finished identification: screened, activated unless a dry run."""
        result, _, sel = value
        stamp = time.time_ns()
        n = len(sel.series)
        identified = Results(split_identification(result, stamp, self.limits(result, sel.series)), result,
                             sel.start_ns, sel.end_ns, n, stamp)
        text = summary(job, result, n, time.monotonic() - control.t_start)
        self.last_consistency = consistency_text(result)
        try:
            self._active.screen.check(identified)
            text += " (dry run: active parameters unchanged)" if job.dry_run else self._active.activate(identified)
        except FrictionIdError as exc:
            return self._record(False, f"{text}; {exc}; active parameters unchanged")
        if sel.notes:
            text += "; notes: " + "; ".join(sel.notes)
        return self._record(True, text, identified)

    def limits(self, result: IdentifyResult, series) -> dict[str, Limit]:
        """{owner: Limit} of the data ``series`` an identification ``result`` ran on
        (:func:`frictionid_core.safety.data_limits`, through the node's drive), kept with its parameters."""
        try:
            return data_limits(series, self._settings().drive, result.friction_rows())
        except FrictionIdError:  # joints that do not match the drive: the screen's default limit then
            return {}

    def window(self, job: Job) -> Selection:
        """The buffered data window of ``job`` (InputError if unusable)."""
        inputs = self._inputs
        return window_series(job, self._settings(), inputs.ring, self._topics["joint_states"], inputs.effort_ring,
                             self._topics.get("effort", ""))

    def run_job(self, job: Job, control: JobControl, sel: Selection | None = None, gate: Gate | None = None
                ) -> tuple[IdentifyResult, Decision | None, Selection]:
        """Identify the job's window (or ``sel``'s series): (the core's result, the safety gate's
        decision with a ``gate``, else None, the window); with ``gate.candidate`` that result is
        judged instead of identifying one (:func:`frictionid_ros.worker.run_identification`: in the worker)."""
        sel = sel or self.window(job)
        reply = (self._worker.run(sel.series, job.request, control, gate) if self._worker is not None
                 else run_identification(sel.series, job.request, control.report, gate))
        return *checked_result(reply, self._log.error), sel

    def _record(self, ok: bool, message: str, identified: Results | None = None, cancelled: bool = False,
                payload=None) -> Answer:
        self.last_ok, self.last_status = ok, message
        return Answer(ok, message, identified, cancelled, payload)
