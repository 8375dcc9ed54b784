"""The ``~/identify_payload`` service and action without ROS: a payload from the buffered joint
states with the active robot parameters as the base (:func:`frictionid_core.identification.identify_payload`).

The base is the active parameters' identification (``results.last``: a ``tx40`` or ``urdf:PATH``
result; its friction levels where the active per-joint ones differ, e.g. re-fitted by an earlier
payload). The fit runs in the identification slot (one at a time, "busy" otherwise, cancel, the
wall-time limit) and in the worker process like ``~/identify``; its result passes the safety
screen (the payload: :func:`frictionid_core.safety.payload_refusals`; re-fitted friction levels:
the parameters' screen) and, unless a dry run, becomes the node's payload: published on
``~/payload``, in ``/diagnostics`` and saved with the parameters.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

from frictionid_core import FrictionIdError, IdentifyResult, InputError
from frictionid_core.identification import PayloadRequest, PayloadResult, identify_payload
from frictionid_ros.identification.identify_service import Answer, IdentifyService
from frictionid_ros.identification.request import Job, parse_window
from frictionid_ros.store import ActiveParameters, Results, split_identification
from frictionid_ros.worker import JobControl, WorkerProcess, checked_result, run_identification


@dataclass(frozen=True)
class PayloadTask:
    """What the worker runs for ``~/identify_payload``: :meth:`run` on a window."""

    base: IdentifyResult
    request: PayloadRequest

    def run(self, series) -> PayloadResult:
        return identify_payload(series, self.base, self.request, base_file="the node's active parameters")


def base_result(results: Results) -> IdentifyResult:
    """The base of a payload: the active identification of a robot system, with the active
    per-joint friction levels over its own; FrictionIdError when there is none."""
    last = results.last
    if last is None or not (last.system == "tx40" or last.system.startswith("urdf:")):
        have = f"the active parameters are of '{last.system}'" if last is not None else "no active parameters"
        raise FrictionIdError(f"no active robot parameters to use as the base ({have}): identify the robot without "
                              "its payload with system tx40 or urdf:PATH first, or ~/load such a result")
    rows = last.friction_rows()
    params = dict(last.params)
    for row in rows:
        active = results.per_joint.get(row)
        if active is None:
            continue
        prefix = f"{row}/" if len(rows) > 1 else ""
        params.update((prefix + k, v) for k, v in active.params.items() if prefix + k in params)
    return replace(last, params=params)


class PayloadService:
    """Answers IdentifyPayload requests (service or action goal) on the buffer of ``service``
    (:class:`~frictionid_ros.identification.IdentifyService`, whose slot and window it shares) in
    ``worker`` (or a thread); ``joints()``: the buffered joints. A new payload reaches the node
    through ``active`` (its ``on_change``)."""

    def __init__(self, settings, service: IdentifyService, active: ActiveParameters, worker: WorkerProcess | None,
                 joints, log):
        self._settings = settings
        self._service = service
        self._joints = joints
        self._active = active
        self._worker = worker
        self._log = log
        self.last_ok, self.last_status = True, "no payload identified yet"

    def handle(self, req, control: JobControl | None = None, on_wait=None) -> Answer:
        control = control or JobControl()
        cfg = self._settings()
        control.wall_s = cfg.max_wall_s
        try:
            base = base_result(self._active.results)
            buffered = list(self._joints())
            missing = [j for j in base.joints if j not in buffered]
            if missing:
                raise InputError(f"the buffer lacks joint(s) {missing} of the active parameters (buffered: "
                                 f"{buffered or 'none yet'})")
            ws, start, end = parse_window(req, cfg)
            request = PayloadRequest(link=req.link or None, refit_friction=bool(req.refit_friction))
        except FrictionIdError as exc:
            return self._record(Answer(False, str(exc)))
        job = Job(list(base.joints), base.request, ws, start, end, bool(req.dry_run))
        task = PayloadTask(base, request)
        answer = self._service.exclusive(lambda: self._run(job, task, control), control, on_wait,
                                         lambda value: self._identified(job, base, control, *value))
        return self._record(answer)

    def _run(self, job: Job, task: PayloadTask, control: JobControl):
        sel = self._service.window(job)
        reply = (self._worker.run(sel.series, task, control) if self._worker is not None
                 else run_identification(sel.series, task, control.report))
        return checked_result(reply, self._log.error)[0], sel

    def _identified(self, job: Job, base: IdentifyResult, control: JobControl, result: PayloadResult, sel) -> Answer:
        """Screen the payload (and re-fitted friction levels), activate it unless a dry run."""
        p = result.payload
        sigma = (p.sigma or {}).get("mass")
        text = (f"payload on {p.link}: {p.mass:.4g} kg" + (f" ± {sigma:.2g}" if sigma is not None else "")
                + f", centre of mass [{', '.join(f'{1e3 * c:.1f}' for c in p.com)}] mm, "
                f"{'feasible' if p.feasible else 'NOT feasible'}, resolved {len(p.resolved)} of 10, on "
                f"{len(sel.series)} samples in {time.monotonic() - control.t_start:.2f} s; relerr "
                f"{result.metrics_base.get('relerr_pct', float('nan')):.3g} % → "
                f"{result.metrics.get('relerr_pct', float('nan')):.3g} %")
        levels = result.friction_params()
        loaded = replace(base, params={**base.params, **levels})
        per_joint = split_identification(loaded, time.time_ns()) if levels else {}
        candidate = Results({j: replace(self._active.results.per_joint.get(j, v), params=v.params)
                             for j, v in per_joint.items()}, loaded, sel.start_ns, sel.end_ns, len(sel.series),
                            time.time_ns(), p)
        try:
            self._active.screen.check(candidate)
            if job.dry_run:
                text += " (dry run: the node's payload unchanged)"
            else:
                text += self._active.activate(candidate)
        except FrictionIdError as exc:
            return Answer(False, f"{text}; {exc}; the node's payload unchanged")
        if result.held:
            text += f"; held (not resolved): {', '.join(result.held)}"
        return Answer(True, text, candidate, payload=result)

    def _record(self, answer: Answer) -> Answer:
        if not answer.message.startswith("busy"):
            self.last_ok, self.last_status = answer.ok, answer.message
        return answer

    def status(self) -> tuple[bool, str, dict]:
        """(ok, message, values) of the payload for /diagnostics: the active one and the last answer."""
        p = self._active.results.payload
        values = {"last_success": self.last_ok, "last_status": self.last_status}
        if p is not None:
            values.update(link=p.link, mass_kg=f"{p.mass:.6g}", com_m=",".join(f"{c:.6g}" for c in p.com),
                          feasible=p.feasible, resolved=",".join(p.resolved))
        message = f"{p.mass:.4g} kg on {p.link}" if p is not None else "no payload"
        return self.last_ok, message + ("" if self.last_ok else f"; last: {self.last_status[:200]}"), values
