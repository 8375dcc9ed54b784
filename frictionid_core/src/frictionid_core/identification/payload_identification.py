"""A payload identified from a loaded log and a base result (:func:`identify_payload`), its request
(:class:`PayloadRequest`), its result and file (:class:`PayloadResult`, :func:`read_payload`),
and a base result with a payload applied (:func:`loaded_result`).

The base result (rigid body, friction, drive: an identification of the robot without the payload)
is reloaded on the loaded log with the payload's ten columns added
(:func:`~frictionid_core.identification.validation.model_from_result`); everything the base holds stays
as it is, and what it leaves unexplained is fitted by the payload (and, with
``refit_friction``, the friction levels Fv, Fc, Fs, which rise with the load in geared
joints): :func:`~frictionid_core.identification.payload_fit.fit_payload`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.identification.model_building import Sources, as_sources, model_metrics
from frictionid_core.identification.payload_fit import base_columns, fit_payload, sigma_block
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.identification.settings import PreprocessingOverrides
from frictionid_core.identification.validation import model_from_result, validation_record
from frictionid_core.model import parameter_kind
from frictionid_core.robots import PAYLOAD_NAMES, Payload, link_frame

# The friction levels ``refit_friction`` fits again (the linear friction parameters of every law).
FRICTION_LEVELS = ("Fv", "Fc", "Fs")


@dataclass(frozen=True)
class PayloadRequest:
    """What to identify of a payload and on which data.

    Attributes:
        link: the link it is fixed to (None: the last link of the chain).
        refit_friction: also fit the friction levels (Fv, Fc, Fs) again.
        joints: the data joints to fit (None: the base result's).
        hold, hold_missing: model joints held still (over the base request's), as ``identify``'s.
        preprocessing: settings the user fixes (the others as a cross-test chooses them).
        window: (start_s, end_s) of each source, s from its first sample.
    """

    link: str | None = None
    refit_friction: bool = False
    joints: list[str] | None = None
    hold: dict[str, float] | None = None
    hold_missing: bool | None = None
    preprocessing: PreprocessingOverrides | None = None
    window: tuple[float | None, float | None] | None = None


@dataclass(frozen=True)
class PayloadResult:
    """A payload file (:meth:`to_dict`: the ``payload`` block first).

    Attributes:
        payload: the identified payload.
        system, source, joints: the base's system, the loaded log(s), the joints fitted.
        base: the base result's file (or None).
        friction: with ``refit_friction``: {"params": {name: value}, "std": {name: σ},
            "base": {name: the base's value}} of the friction levels, else None.
        metrics, metrics_base: the loaded log's metrics (per joint under ``per_joint``) with the
            payload, and with the base alone.
        held: {quantity: value} held (not resolved).
        fit: how it was obtained (SDP, σ, thresholds, the unconstrained estimate).
        preprocessing: the cross-test's pre-processing block.
        warnings: what the user should know.
        wall_s: the fit's wall time (s).
    """

    payload: Payload
    system: str
    source: str | list[str]
    joints: list[str]
    base: str | None = None
    friction: dict | None = None
    metrics: dict = field(default_factory=dict)
    metrics_base: dict = field(default_factory=dict)
    held: dict[str, float] = field(default_factory=dict)
    fit: dict = field(default_factory=dict)
    preprocessing: dict | None = None
    warnings: list[str] = field(default_factory=list)
    wall_s: float = 0.0

    def to_dict(self) -> dict:
        return {"payload": self.payload.to_dict(), "system": self.system, "source": self.source,
                "joints": list(self.joints), "base": self.base, "friction_refit": self.friction,
                "metrics": self.metrics, "metrics_base": self.metrics_base, "held": dict(self.held), "fit": self.fit,
                "preprocessing": self.preprocessing, "warnings": list(self.warnings), "wall_s": self.wall_s}

    def friction_params(self) -> dict[str, float]:
        """{name: value} of the re-fitted friction levels (empty without)."""
        return dict((self.friction or {}).get("params") or {})

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "payload file") -> PayloadResult:
        """A payload file's contents (only ``payload`` is required: a payload typed by hand, or the
        ``payload`` block of ``export --yaml``); InputError naming the key at fault."""
        if not isinstance(data, Mapping) or "payload" not in data:
            raise InputError(f"{where}: no 'payload' block; expected the JSON written by 'frictionid payload'")
        payload = Payload.from_dict(data["payload"], f"{where}: key 'payload'")
        friction = data.get("friction_refit")
        if friction is not None:
            params = friction.get("params") if isinstance(friction, Mapping) else None
            if not isinstance(params, Mapping) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)
                    for v in params.values()):
                raise InputError(f"{where}: key 'friction_refit.params' must map friction parameter names to finite "
                                 f"numbers, got {params!r:.200}")
            friction = dict(friction)
        return cls(payload, str(data.get("system") or ""), data.get("source") or "", list(data.get("joints") or []),
                   data.get("base"), friction, dict(data.get("metrics") or {}), dict(data.get("metrics_base") or {}),
                   dict(data.get("held") or {}), dict(data.get("fit") or {}), data.get("preprocessing"),
                   list(data.get("warnings") or []), float(data.get("wall_s") or 0.0))


def read_payload(path: str | Path) -> PayloadResult:
    """The payload in the file ``path`` (``frictionid payload --json``, or a parameters file of
    ``export --yaml`` that carries one); InputError naming the file."""
    from frictionid_core.files import read_json

    return PayloadResult.from_dict(read_json(path, "a payload file"), where=str(path))


def loaded_result(base: IdentifyResult | Mapping, payload: PayloadResult) -> dict:
    """The base result's JSON with the payload's re-fitted friction levels over its own (the
    payload itself goes to :func:`~frictionid_core.identification.validation.model_from_result`);
    FrictionIdError when a level is not one of the base's parameters (another robot's payload)."""
    base = base.to_dict() if isinstance(base, IdentifyResult) else dict(base)
    levels = payload.friction_params()
    unknown = [n for n in levels if n not in base["params"]]
    if unknown:
        raise FrictionIdError(f"the payload's re-fitted friction levels {unknown} are not parameters of the base "
                              "result: a payload identified with another base")
    return {**base, "params": {**base["params"], **levels}}


def payload_of(base: IdentifyResult, params_file: str | Path, payload_file: str | Path | None = None
               ) -> tuple[dict, Payload | None]:
    """(the base result's JSON with the payload's re-fitted friction levels, the payload) of
    ``payload_file`` or, without it, of the payload the parameters file ``params_file`` carries
    (``export --yaml --payload``); (the result's JSON, None) without either."""
    from frictionid_core.files import read_json

    if payload_file is not None:
        loaded = read_payload(payload_file)
    else:
        data = read_json(params_file, "an identification result")
        if not isinstance(data, Mapping) or "payload" not in data:
            return base.to_dict(), None
        loaded = PayloadResult.from_dict({"payload": data["payload"]}, where=str(params_file))
    return loaded_result(base, loaded), loaded.payload


def _with_holds(base: dict, request: PayloadRequest) -> dict:
    """The base result with the request's holds over its request's (what the reload holds)."""
    if request.hold is None and request.hold_missing is None:
        return base
    asked = dict(base.get("request") or {})
    if request.hold is not None:
        asked["hold"] = {**(asked.get("hold") or {}), **request.hold}
    if request.hold_missing is not None:
        asked["hold_missing"] = bool(request.hold_missing)
    return {**base, "request": asked}


LOAD_ROUNDS = 20  # refits of a load-dependent base's levels with the payload's torque in them, at most


def identify_payload(series: Sources, base: IdentifyResult | Mapping, request: PayloadRequest = PayloadRequest(),
                     base_file: str | None = None) -> PayloadResult:
    """The payload of ``request`` on the loaded log ``series`` (one source or several) with the
    unloaded ``base`` result held (module doc); ``base_file`` names it in the result."""
    from frictionid_core.systems import result_system

    t0 = time.perf_counter()
    base = _with_holds(base.to_dict() if isinstance(base, IdentifyResult) else dict(base), request)
    system = result_system(base)
    if system.robot is None:
        raise InputError(f"the base result's system '{system.name}' has no robot model: a payload needs a result of "
                         "tx40 or urdf:PATH")
    link, _, _ = link_frame(system.robot.model, request.link)
    empty = Payload(link, 0.0, (0.0, 0.0, 0.0), ((0.0,) * 3,) * 3)
    model, x = model_from_result(series, base, joints=request.joints, preprocessing=request.preprocessing,
                                 window=request.window, payload=empty)
    linear = [model.names[i] for i in model.linear_index]
    payload_cols = [linear.index(n) for n in PAYLOAD_NAMES]
    friction_cols = [k for k, n in enumerate(linear) if request.refit_friction and parameter_kind(n) in FRICTION_LEVELS
                     and model.linear_index[k] not in model.fixed_values]
    c = x[model.linear_index]
    others = [k for k in range(len(linear)) if k not in payload_cols and k not in friction_cols]
    nonnegative = np.array([parameter_kind(linear[k]) in FRICTION_LEVELS for k in friction_cols], dtype=bool)
    fit, previous = None, np.zeros(len(PAYLOAD_NAMES))
    for _ in range(LOAD_ROUNDS):  # a load-dependent base: the payload's torque raises the Coulomb levels too
        X = model.design() if model.is_linear else model.design(x[None])[0]
        fit = fit_payload(X[:, payload_cols], X[:, friction_cols],
                          model.obs.y - X[:, others] @ c[others] - X[:, friction_cols] @ c[friction_cols],
                          model.obs.used, model.obs.n_samples, nonnegative, c[friction_cols],
                          base_columns(X[:, others], [linear[k] for k in others], base))
        if model.load_rigid is None or np.max(np.abs(fit.z - previous)) <= 1e-9 * np.max(np.abs(fit.z)):
            break
        previous, rigid = fit.z, model.load_rigid.copy()
        rigid[[model.obs.rigid_names.index(n) for n in PAYLOAD_NAMES]] = fit.z
        model = replace(model, load_rigid=rigid)
    payload = Payload.from_standard(link, fit.z, sigma=sigma_block(fit.sigma), resolved=tuple(fit.resolved))
    x_loaded = x.copy()
    x_loaded[model.linear_index[payload_cols]] = fit.z
    x_loaded[model.linear_index[friction_cols]] = fit.friction
    friction = None
    if request.refit_friction:
        names = [linear[k] for k in friction_cols]
        friction = {"params": dict(zip(names, map(float, fit.friction))),
                    "std": dict(zip(names, map(float, fit.friction_sigma))),
                    "base": dict(zip(names, map(float, c[friction_cols])))}
    names = [s.source for s in as_sources(series)]
    return PayloadResult(payload, system.name, names[0] if len(names) == 1 else names, list(model.obs.joints),
                         base_file, friction, model_metrics(model, x_loaded), model_metrics(model, x),
                         fit.held, fit.record, validation_record(model), _warnings(fit), time.perf_counter() - t0)


def _warnings(fit) -> list[str]:
    """A line naming what the log did not resolve and where it is held, and one for an infeasible estimate."""
    out = []
    if fit.held:
        held = ", ".join(f"{k} = {v:.4g}" for k, v in fit.held.items())
        out.append(f"the log does not resolve the payload's {', '.join(fit.held)}: held at a point mass' values "
                   f"({held}; centre of mass at the link origin where not resolved); record faster motion of the "
                   "wrist joints to resolve its inertia")
    return out


def payload_summary(result: PayloadResult) -> str:
    """One line: mass ± σ, centre of mass (mm), link, resolved count."""
    p = result.payload
    s = p.sigma or {}
    mass_sigma = s.get("mass")
    com = ", ".join(f"{1e3 * v:.1f}" for v in p.com)
    return (f"payload on {p.link}: {p.mass:.4g} kg" + (f" ± {mass_sigma:.2g}" if mass_sigma is not None else "")
            + f", centre of mass [{com}] mm, {'feasible' if p.feasible else 'NOT feasible'}, resolved "
            f"{len(p.resolved)} of 10")

