"""The ``~/identify`` request validated into a :class:`Job`, and the answer's text (no ROS import).

:func:`parse_request` reads the fields of a ``frictionid_interfaces/srv/Identify`` request;
empty strings and zeros take the node's defaults (:attr:`Config.solve`, ``window_seconds``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from frictionid_core import FrictionIdError, InputError, SolveOptions
from frictionid_ros.buffer import NS, stamp_ns
from frictionid_ros.config import Config, solve_options


@dataclass(frozen=True)
class Job:
    """A validated identification request.

    Attributes:
        joints: joints to identify, a subset of the buffered ones.
        options: friction model, solver, seed (resolved) and budgets.
        window_seconds: the last ``window_seconds`` of the buffer [s]; 0 with a stamp range,
            or for the whole buffer.
        start_ns, end_ns: stamp range [ns since the epoch]; 0 = open bound.
        dry_run: only answer; keep the active parameters.
    """

    joints: list[str]
    options: SolveOptions
    window_seconds: float = 0.0
    start_ns: int = 0
    end_ns: int = 0
    dry_run: bool = False

    def identify_kwargs(self, system: str, preprocessing=None) -> dict:
        """Keywords of :func:`frictionid_core.identification.identify` for this job."""
        o = self.options
        kwargs = dict(system=system, friction=o.friction, asymmetric=o.asymmetric, solver=o.solver, seed=o.seed,
                      **o.solver_options())
        if preprocessing is not None:
            kwargs["preprocessing"] = preprocessing
        return kwargs


def parse_request(req, cfg: Config, buffered: list[str]) -> Job:
    """Validate an Identify request (service request or action goal: the same fields) against the
    node's settings ``cfg`` and ``buffered`` joints.

    Seed: > 0 as given, 0 the configured seed, < 0 a random one. Raises FrictionIdError (InputError
    for joints and window) naming the field, or the limit (``max_budget``, ``max_population``,
    ``max_window_seconds``) a value is over.
    """
    for name, limit in (("budget", cfg.max_budget), ("population", cfg.max_population)):
        if int(getattr(req, name)) > limit:
            raise FrictionIdError(f"request field '{name}' = {getattr(req, name)} is over the node's limit "
                                  f"max_{name} = {limit}")
    joints = list(req.joints) or list(buffered)
    unknown = [j for j in joints if j not in buffered]
    if unknown:
        raise InputError(f"unknown joint(s) {unknown}; buffered joints: {buffered or 'none yet'}")
    if len(set(joints)) != len(joints):
        raise InputError(f"duplicated joint names in {joints}")
    default = cfg.solve
    seed = int(req.seed) if req.seed > 0 else default.seed if req.seed == 0 else \
        int(np.random.SeedSequence().entropy % 2**63)
    options = solve_options("request field", friction_model=req.friction_model or default.friction,
                            asymmetric=bool(req.asymmetric or default.asymmetric), solver=req.solver or default.solver,
                            seed=seed, budget=int(req.budget), population=int(req.population))
    ws = float(req.window_seconds)
    start, end = stamp_ns(req.window_start), stamp_ns(req.window_end)
    if not math.isfinite(ws) or ws < 0.0:
        raise InputError(f"window_seconds must be >= 0, got {ws}")
    if ws > 0.0 and (start or end):
        raise InputError("both window_seconds and window_start/window_end given; use one of them")
    if start and end and end <= start:
        raise InputError("window_end must be after window_start")
    span = ws or ((end - start) / NS if start and end else 0.0)
    if span > cfg.max_window_seconds:
        what = f"window_seconds = {ws:g} s" if ws else f"window_start..window_end = {span:g} s"
        raise InputError(f"request field {what} is over the node's limit max_window_seconds = "
                         f"{cfg.max_window_seconds:g} s")
    if ws == 0.0 and not (start or end):
        ws = cfg.window_seconds
    return Job(joints, options, ws, start, end, bool(req.dry_run))


def consistency_kwargs(cfg: Config) -> dict:
    """Keywords of :func:`frictionid_core.identification.identify` for the node's ``consistent`` and
    ``prior_weight`` parameters ({} when not consistent)."""
    if not cfg.consistent:
        return {}
    if cfg.prior_weight > 0.0:
        return dict(consistent=True, prior="urdf", prior_weight=cfg.prior_weight)
    return dict(consistent=True)


def consistency_text(result: dict) -> str:
    """``FEASIBLE (…)`` of a consistent identification (its ``consistency`` block), else ""."""
    c = result.get("consistency")
    if not c:
        return ""
    return (f"{'FEASIBLE' if c['feasible'] else 'NOT FEASIBLE'} (SDP {c['sdp_wall_s']:.2f} s, prior {c['prior']}"
            f"{' W=%g' % c['prior_weight'] if c['prior'] != 'none' else ''}, cost +{c['cost_increase_pct']:.3g} %)")


def summary(job: Job, result: dict, samples: int, seconds: float) -> str:
    """One line on an identification: model, solver, window, duration [s], consistency and parameters."""
    d = result
    consistency = consistency_text(d)
    return (f"identified {d['system']}/{d['friction']}{'-asym' if d['asymmetric'] else ''} with {d['solver']} "
            f"on {samples} samples of {job.joints} in {seconds:.2f} s"
            + (f"; consistency: {consistency}" if consistency else "") + ": "
            + ", ".join(f"{k}={v:.6g}" for k, v in d["params"].items()))
