"""The ``~/identify`` request validated into a :class:`Job`, and the answer's text (no ROS import).

:func:`parse_request` reads the fields of a ``frictionid_interfaces/srv/Identify`` request into
the core's :class:`~frictionid_core.identification.IdentifyRequest` (:func:`node_request`: the
node's parameters are its defaults; empty strings and zeros in the request take them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from frictionid_core import FrictionIdError, IdentifyRequest, IdentifyResult, InputError, PreprocessingOverrides
from frictionid_ros.inputs import NS, stamp_ns
from frictionid_ros.joint_names import shown_names
from frictionid_ros.parameters import Config, solve_options


@dataclass(frozen=True)
class Job:
    """A validated identification request.

    Attributes:
        joints: joints to identify, a subset of the buffered ones.
        request: what the core identifies (its joints are ``joints``).
        window_seconds: the last ``window_seconds`` of the buffer [s]; 0 with a stamp range,
            or for the whole buffer.
        start_ns, end_ns: stamp range [ns since the epoch]; 0 = open bound.
        dry_run: only answer; keep the active parameters.
    """

    joints: list[str]
    request: IdentifyRequest
    window_seconds: float = 0.0
    start_ns: int = 0
    end_ns: int = 0
    dry_run: bool = False


def node_request(cfg: Config, joints: list[str], where: str = "request field", **fields) -> IdentifyRequest:
    """The identification of ``joints`` the node runs: its parameters (``cfg.solve``: system,
    friction_model, asymmetric, solver, seed; ``consistent`` and ``prior_weight``;
    ``filter_cutoff_hz``/``decimation`` over the system's pre-processing; ``drive_file``;
    ``known_rigid_body``: the request field of that name) with the ROS-named ``fields`` of a
    request over them; an error names the field (``{where} 'friction_model': …``)."""
    prior = cfg.consistent and cfg.prior_weight > 0.0
    overrides = {k: v for k, v in (("cutoff_hz", cfg.filter_cutoff_hz), ("decimate", cfg.decimation)) if v > 0}
    drive = cfg.drive.to_dict() if cfg.drive is not None else None
    base = replace(cfg.solve, joints=tuple(joints) or None, drive=drive,
                   preprocessing=PreprocessingOverrides(**overrides), known_rigid_body=cfg.known_rigid_body,
                   consistent=cfg.consistent,
                   prior="urdf" if prior else None, prior_weight=cfg.prior_weight if prior else 1.0)
    return solve_options(where, base, **fields)


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
        raise InputError(f"unknown joint(s) {shown_names(unknown)}; buffered joints: "
                         f"{shown_names(buffered) if buffered else 'none yet'}")
    if len(set(joints)) != len(joints):
        raise InputError(f"duplicated joint names in {shown_names(joints)}")
    default = cfg.solve
    seed = int(req.seed) if req.seed > 0 else default.solver.seed if req.seed == 0 else \
        int(np.random.SeedSequence().entropy % 2**63)
    fields = dict(asymmetric=bool(req.asymmetric or default.asymmetric), seed=seed, budget=int(req.budget),
                  population=int(req.population))
    fields.update((k, v) for k, v in (("friction_model", req.friction_model), ("solver", req.solver)) if v)
    request = node_request(cfg, joints, "request field", **fields)
    ws, start, end = parse_window(req, cfg)
    return Job(joints, request, ws, start, end, bool(req.dry_run))


def parse_window(req, cfg: Config) -> tuple[float, int, int]:
    """(window_seconds [s], window_start, window_end [ns since the epoch; 0 = open]) of a request's
    window fields (Identify, IdentifyPayload): at most one of the two, within ``max_window_seconds``;
    neither: the node's ``window_seconds``. InputError naming the field."""
    ws = float(req.window_seconds)
    for name in ("window_start", "window_end"):
        stamp = getattr(req, name)
        if not (0 <= stamp.nanosec < NS and stamp.sec >= 0):
            raise InputError(f"request field '{name}' = {stamp.sec} s + {stamp.nanosec} ns is not a time stamp "
                             f"(sec >= 0, 0 <= nanosec < {NS})")
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
    return ws, start, end


def consistency_text(result: IdentifyResult) -> str:
    """``FEASIBLE (…)`` of a consistent identification (its ``consistency`` block), else ""."""
    c = result.consistency
    if not c:
        return ""
    weight = f" W={c['prior_weight']:g}" if c["prior"] != "none" else ""
    return (f"{'FEASIBLE' if c['feasible'] else 'NOT FEASIBLE'} (SDP {c['sdp_wall_s']:.2f} s, prior {c['prior']}"
            f"{weight}, cost +{c['cost_increase_pct']:.3g} %)")


def summary(job: Job, result: IdentifyResult, samples: int, seconds: float) -> str:
    """One line on an identification: model, solver, window, duration [s], consistency and parameters."""
    r = result
    consistency = consistency_text(r)
    return (f"identified {r.system}/{r.friction}{'-asym' if r.asymmetric else ''} with {r.solver} "
            f"on {samples} samples of {job.joints} in {seconds:.2f} s"
            + (f"; consistency: {consistency}" if consistency else "") + ": "
            + ", ".join(f"{k}={v:.6g}" for k, v in r.params.items()))
