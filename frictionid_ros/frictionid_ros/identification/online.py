"""Online re-identification behind the safety gate (no ROS import).

Every ``online_period_s`` the node calls :meth:`Online.tick`: the last ``online_window_s`` of
buffered data is split in time, the older (1 − ``online_holdout``) share is identified (in the
worker, with the node's friction model, solver and ``known_rigid_body``) and the newest share is
held back; :func:`frictionid_core.safety.gate.review`, run in the worker too (its predictions
would otherwise take the GIL from the 1 kHz inputs), decides whether the candidate replaces the
active parameters (it must predict the held-back slice better). ``~/load`` goes through the
same gate while online re-identification is on (:meth:`Online.offer`). A re-identification yields
to a requested one (``~/identify``, ``~/identify_payload``): it holds the slot as a background job,
which the request cancels (:meth:`~frictionid_ros.identification.IdentifyService.slot`). Every decision is
kept for ``/diagnostics`` (:meth:`Online.status`) and logged.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

from frictionid_core import FrictionIdError
from frictionid_core.safety import Decision
from frictionid_ros.identification.request import Job, node_request
from frictionid_ros.identification.window import Selection
from frictionid_ros.store import Results, read_results, split_identification
from frictionid_ros.worker import Cancelled, Gate, JobControl

LOAD_PREEMPTS = "preempted by a ~/load through the gate"  # the cancel reason of a re-identification a load stops


def split(series, holdout: float):
    """(fit, held back): the older (1 − holdout) share of ``series`` and its newest ``holdout`` share."""
    n = len(series.t)
    k = int(round(n * (1.0 - holdout)))
    return series.slice(0, k), series.slice(k, n)


class Online:
    """Periodic re-identification and gated loads of a node: ``settings()`` (its Config),
    ``service`` (IdentifyService: the slot, window and worker), ``active`` (ActiveParameters),
    ``joints()`` (buffered joints), ``log`` (rclpy-like logger)."""

    def __init__(self, settings, service, active, joints, log):
        self._settings, self._service, self._active, self._joints, self._log = settings, service, active, joints, log
        self.reviews = self.accepted = self.rejected = self.skipped = 0
        self.last: Decision | None = None
        self.last_source = ""
        self.last_note = "no review yet"

    def _job(self, seconds: float) -> Job:
        """A dry run of the node's own identification on the last ``seconds`` of the buffer."""
        joints = list(self._joints())
        return Job(joints, node_request(self._settings(), joints, "parameter"), window_seconds=seconds, dry_run=True)

    def tick(self) -> Decision | None:
        """One re-identification and its review; None when skipped (busy, too little data, failed)."""
        cfg = self._settings()
        control = JobControl(cfg.max_wall_s)
        with self._service.slot(background=control) as free:  # a requested identification cancels it
            if not free:
                return self._skip("an identification is running")
            try:
                job = self._job(cfg.online_window_s)
                sel = self._service.window(job)
                fit, held = split(sel.series, cfg.online_holdout)
                gate = Gate(self._active.results.last, held, cfg.gate_max_abs)
                result, decision, _ = self._service.run_job(job, control,
                                                            Selection(fit, sel.start_ns, sel.end_ns, sel.notes), gate)
            except (FrictionIdError, Cancelled) as exc:
                return self._skip(str(exc))
            if decision.accepted:
                stamp = time.time_ns()
                limits = self._service.limits(result, fit)
                try:
                    self._active.activate(Results(split_identification(result, stamp, limits), result, sel.start_ns,
                                                  sel.end_ns, len(fit.t), stamp))
                except FrictionIdError as exc:  # the safety screen
                    decision = Decision(False, f"rejected: {exc}", decision.current_rmse, decision.candidate_rmse)
            return self._record(decision, "online re-identification")

    def offer(self, path) -> tuple[bool, str]:
        """``~/load`` through the gate: the file's parameters pass the safety screen, then are judged
        on the newest ``online_window_s·online_holdout`` of data and activated only if accepted.
        An online re-identification in the worker yields it (cancelled, as to a requested
        identification: re-identifications that run back to back left a load no gap); answered "busy"
        at once while a requested identification holds it."""
        cfg = self._settings()
        with self._service.slot(preempt=LOAD_PREEMPTS) as free:
            if not free:
                return False, f"{path}: not loaded: busy: an identification is running; try again later"
            try:
                loaded = replace(read_results(path), stamp_ns=time.time_ns())
                if loaded.last is None:
                    raise FrictionIdError(f"{path}: no complete identification result to judge")
                try:
                    self._active.screen.check(loaded)
                    decision = None
                except FrictionIdError as exc:
                    decision = Decision(False, f"rejected: {exc}")
                if decision is None:  # the predictions run in the worker (they would take the GIL here)
                    job = self._job(cfg.online_window_s * cfg.online_holdout)
                    sel = self._service.window(job)
                    gate = Gate(self._active.results.last, sel.series, cfg.gate_max_abs, candidate=loaded.last)
                    decision = self._service.run_job(job, JobControl(cfg.max_wall_s), sel, gate)[1]
            except (FrictionIdError, Cancelled) as exc:
                return False, f"not loaded: {exc}"
            decision = self._record(decision, f"load {path}")
            if not decision.accepted:
                return False, f"{path}: safety gate: {decision.reason}; active parameters unchanged"
            try:
                self._active.activate(loaded)
            except FrictionIdError as exc:
                return False, f"{path}: not loaded: {exc}; active parameters unchanged"
        return True, f"loaded parameters of {sorted(loaded.per_joint)} from {path}; safety gate: {decision.reason}"

    def _skip(self, why: str) -> None:
        self.skipped += 1
        self.last_note = f"skipped: {why}"
        return None

    def _record(self, decision: Decision, source: str) -> Decision:
        self.reviews += 1
        self.accepted += decision.accepted
        self.rejected += not decision.accepted
        self.last, self.last_source, self.last_note = decision, source, ""
        if decision.accepted:  # rclpy forbids one call site logging at two severities
            self._log.info(f"safety gate ({source}): {decision.reason}")
        else:
            self._log.warning(f"safety gate ({source}): {decision.reason}")
        return decision

    def status(self) -> tuple[bool, str, dict]:
        """(ok, message, values) for /diagnostics: ok unless the last decision was a rejection."""
        d = self.last
        message = f"{self.last_source}: {d.reason}" if d is not None else self.last_note
        if d is not None and self.last_note:
            message += f" (then {self.last_note})"
        fmt = lambda x: "" if x is None or not math.isfinite(x) else f"{x:.6g}"
        return (d is None or d.accepted), message[:300], {
            "reviews": self.reviews, "accepted": self.accepted, "rejected": self.rejected, "skipped": self.skipped,
            "last_accepted": "" if d is None else d.accepted, "last_source": self.last_source,
            "current_rmse": fmt(d and d.current_rmse), "candidate_rmse": fmt(d and d.candidate_rmse),
            "online_period_s": self._settings().online_period_s}
