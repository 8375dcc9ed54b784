"""One identification job: what it carries besides the data (:class:`Gate`, a review by the safety
gate), how it runs (:func:`run_identification`: in the worker's child, or in a thread of the node)
and how its reply is read back (:func:`checked_result`) (no ROS import)."""

from __future__ import annotations

import math
import traceback
from dataclasses import dataclass
from typing import TYPE_CHECKING

from frictionid_ros.worker.job_control import Cancelled

if TYPE_CHECKING:
    from frictionid_core import IdentifyRequest, IdentifyResult
    from frictionid_core.safety import Decision


@dataclass(frozen=True)
class Gate:
    """A review by the safety gate (:func:`frictionid_core.safety.gate.review`) of an identification:
    ``candidate`` (None: the identification's own result) against ``current`` (None: no active
    set) on the held-back series ``holdout``; ``max_abs``: largest parameter magnitude accepted."""

    current: IdentifyResult | None
    holdout: object  # JointSeries
    max_abs: float
    candidate: IdentifyResult | None = None


def run_identification(series, request: IdentifyRequest, progress=None, gate: Gate | None = None) -> tuple:
    """One identification → ("ok", (result, decision)) | ("error" | "cancelled" | "crash", message).

    ``gate``: the result (or ``gate.candidate``, judged instead of identifying) is also judged by
    the safety gate; the decision is None without one. ``progress``: the optimiser's hook (see
    :func:`frictionid_core.identification.identify`); it cancels the run by raising :class:`Cancelled`."""
    from frictionid_core import FrictionIdError, IdentifyRequest, identify

    try:
        if gate is not None and gate.candidate is not None:
            result = gate.candidate
        elif isinstance(request, IdentifyRequest):
            result = identify(series, request, progress=progress)
        else:  # a task of its own (~/identify_payload's: frictionid_ros.identification.payload_service.PayloadTask)
            result = request.run(series)
        decision = None
        if gate is not None:  # judged here too: the prediction of the held-back slice is CPU work
            from frictionid_core.safety import review

            decision = review(gate.current, result, gate.holdout, gate.max_abs)
        return ("ok", (result, decision))
    except Cancelled as exc:
        return ("cancelled", str(exc))
    except FrictionIdError as exc:
        return ("error", str(exc))
    except ImportError as exc:
        what = f"solver '{request.solver.method}'" if isinstance(request, IdentifyRequest) else "a module"
        return ("error", f"{what} is unavailable ({type(exc).__name__}: {exc})")
    except Exception as exc:  # reported to the caller, never kills the worker
        return ("crash", f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}")


def checked_result(reply: tuple, log_crash) -> tuple[IdentifyResult, Decision | None]:
    """(the result, the gate's decision or None) of a :func:`run_identification` reply;
    FrictionIdError for an error, a crash (whose full text goes to ``log_crash``) or non-finite
    parameters; :class:`Cancelled` for a cancelled run."""
    from frictionid_core import FrictionIdError

    status, payload = reply
    if status == "cancelled":
        raise Cancelled(payload)
    if status == "error":
        raise FrictionIdError(payload)
    if status == "crash":
        log_crash(f"identification crashed: {payload}")
        raise FrictionIdError(f"identification failed: {payload.splitlines()[0]}")
    from frictionid_core import IdentifyResult

    result = payload[0]
    if isinstance(result, IdentifyResult):
        values = result.params
    elif hasattr(result, "payload"):  # a PayloadResult
        values = result.payload.parameters()
    else:  # another task's outcome (frictionid_ros.experiment.tasks): its parameters()
        values = result.parameters()
    bad = [k for k, v in values.items() if not math.isfinite(v)]
    if bad:
        raise FrictionIdError(f"identification failed: non-finite parameter(s) {bad}")
    return payload
