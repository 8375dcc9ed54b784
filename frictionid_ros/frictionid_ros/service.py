"""The ``~/identify`` service without ROS: one identification at a time, answered in one line."""

from __future__ import annotations

import threading
import time
import traceback

from frictionid_core.errors import FrictionIdError

from frictionid_ros.config import preprocessing_override
from frictionid_ros.inputs import Inputs
from frictionid_ros.request import Job, parse_request, summary
from frictionid_ros.store import ActiveParameters, Results, split_identification
from frictionid_ros.window import Selection, window_series
from frictionid_ros.worker import WorkerProcess, checked_result, run_identification


class IdentifyService:
    """Answers Identify requests on the data of ``inputs``.

    A request arriving while an identification runs is answered "busy" at once. The
    identification runs in ``worker`` (a child process) or, without one, a thread, while the
    caller's thread waits and gives up when :attr:`stopping` is set. ``settings()`` returns the
    node's current :class:`~frictionid_ros.config.Config`; ``topics`` the resolved
    ``joint_states`` (and ``effort``) topic names; ``log`` has ``.error``. The last answer is
    kept for the diagnostics (:attr:`last_ok`, :attr:`last_status`).
    """

    def __init__(self, settings, inputs: Inputs, active: ActiveParameters, topics: dict[str, str],
                 worker: WorkerProcess | None, log):
        self._settings = settings
        self._inputs = inputs
        self._active = active
        self._topics = topics
        self._worker = worker
        cfg = settings()
        self._pre = preprocessing_override(cfg.system, cfg.filter_cutoff_hz, cfg.decimation)  # read-only parameters
        self._log = log
        self.stopping = threading.Event()
        self._busy = threading.Lock()
        self._busy_since = 0.0
        self.last_ok, self.last_status = True, "no identification yet"

    @property
    def busy(self) -> bool:
        return self._busy.locked()

    def handle(self, req) -> tuple[bool, str, Results | None]:
        """Answer an Identify request: (success, message, the identification if successful)."""
        t_start = time.monotonic()
        try:
            job = parse_request(req, self._settings(), self._inputs.joints)
        except FrictionIdError as exc:
            return self._record(False, str(exc))
        if not self._busy.acquire(blocking=False):  # not recorded: the running one is the news
            return False, (f"busy: an identification is already running (for "
                           f"{time.monotonic() - self._busy_since:.1f} s); try again later"), None
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
                if self.stopping.is_set():
                    return self._record(False, "node shutting down")
            if "error" in box:
                exc = box["error"]
                if isinstance(exc, FrictionIdError):
                    return self._record(False, str(exc))
                self._log.error("identification crashed:\n" + "".join(traceback.format_exception(exc)))
                return self._record(False, f"identification failed: {type(exc).__name__}: {exc}")
            d, sel = box["result"]
            stamp = time.time_ns()
            n = len(sel.series)
            identified = Results(split_identification(d, stamp), d, sel.start_ns, sel.end_ns, n, stamp)
            text = summary(job, d, n, time.monotonic() - t_start)
            text += " (dry run: active parameters unchanged)" if job.dry_run else self._active.activate(identified)
            if sel.notes:
                text += "; notes: " + "; ".join(sel.notes)
            return self._record(True, text, identified)
        finally:
            self._busy.release()

    def _run(self, job: Job) -> tuple[dict, Selection]:
        """Identify the job's window: (the core's result dict, the window)."""
        cfg = self._settings()
        inputs = self._inputs
        sel = window_series(job, cfg, inputs.ring, self._topics["joint_states"], inputs.effort_ring,
                            self._topics.get("effort", ""))
        kwargs = job.identify_kwargs(cfg.system, self._pre)
        kwargs["drive"] = cfg.drive  # read-only: the one of start-up
        reply = (self._worker.run(sel.series, kwargs, self.stopping) if self._worker is not None
                 else run_identification(sel.series, kwargs))
        return checked_result(reply, self._log.error), sel

    def _record(self, ok: bool, message: str, identified: Results | None = None):
        self.last_ok, self.last_status = ok, message
        return ok, message, identified
