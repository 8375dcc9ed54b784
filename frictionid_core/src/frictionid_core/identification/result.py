"""What an identification produced: :class:`IdentifyResult`, and its JSON (the result file).

The JSON keys are a contract (scripts read them): :meth:`IdentifyResult.to_dict` writes the
fields in their order, leaving out the optional blocks that do not apply (the optimiser's without
an optimiser, the consistent fit's without one, the output-error ones, the request of a result
built by hand); :meth:`IdentifyResult.from_dict` reads such a file back, also one written by
hand or by an earlier version (only ``system``, ``friction``, ``asymmetric`` and ``params`` are
required; keys it does not know are ignored).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from numbers import Real
from pathlib import Path

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.checks import FieldError, choice, flag, integer, mapping, number
from frictionid_core.identification.request import IdentifyRequest, _bound, _window, window_record

# Keys left out of the JSON when their field is None.
OPTIONAL_KEYS = ("optimizer", "varpro", "warm_start", "consistency", "standard_parameters", "output_error", "idm",
                 "idm_params", "identifiability", "held_joints", "no_effort_joints", "request", "uncertainty",
                 "velocity_range", "holdout", "plausibility")
REQUIRED_KEYS = ("system", "friction", "asymmetric", "params")
MAX_PARAMETER = 1e15  # |value| beyond: not an identified parameter in SI units (an overflow, a typo)


@dataclass(frozen=True)
class IdentifyResult:
    """The parameters of one identification, their σ, its metrics and how it was obtained.

    Attributes:
        system, joint_map, friction, asymmetric: the model fitted (as in the request).
        solver: the solver method.
        source: the source's name, or a list with several sources fitted together.
        joints: the data joints fitted, in order.
        params, std: {name: value} and {name: σ} (σ 0 for a fixed parameter, NaN where not
            determined or held at a bound), SI units; σ assumes white residuals.
        std_robust: {name: σ} robust to coloured and heteroscedastic residuals (HAC; same names,
            same conventions); ``uncertainty`` says how both were obtained.
        metrics: fit metrics on the estimation data (see :mod:`frictionid_core.metrics`), with
            ``cost`` and ``cond``; per joint under ``per_joint``.
        wall_s: the identification's wall time [s].
        warnings, notes: what the user should know (one line each), and what the data said.
        drive: the drive's keys (:meth:`frictionid_core.drive.Drive.to_dict`), or None.
        window: (start_s, end_s) of every source [s from its first sample], or None.
        fixed: {full parameter name: value} held fixed.
        bounds: the user's bounds {name: (lo, hi)} as requested.
        optimizer: the optimiser's record (:meth:`frictionid_core.optim.OptimResult.to_dict`);
            None for a closed-form solution, as ``varpro`` and ``warm_start`` (what it ran with).
        consistency, standard_parameters: the consistent fit's record and its standard
            parameters per link (None without ``consistent``).
        preprocessing: the pre-processing settings resolved, what the data said and
            ``overridden`` (the settings that differ from the system's).
        layout: the CSV layout file the source was read with (the command line), or None.
        output_error, idm, idm_params: an output-error identification: True, the IDM start's
            metrics and parameters (None otherwise).
        identifiability: what the data resolve: {rank, columns, unresolved, action, …} (see
            :class:`~frictionid_core.identification.identifiability.Identifiability`).
        held_joints: robot systems: {model joint: position (rad or m)} held still in every
            source (None for the other systems).
        no_effort_joints: data joints that moved without a usable effort, left out of the fit.
        request: the request that produced it (None: built by hand).
        uncertainty: how ``std`` and ``std_robust`` were obtained (the HAC bandwidth).
        velocity_range: {friction row (joint or motor): [slowest, fastest] |velocity| of the rows
            fitted} (what ``export`` matches a law over).
        holdout: a nonlinear law against its linear special case (Coulomb) on held-back rows:
            {held_back_rows, law_relerr_pct, linear_relerr_pct, beats_linear[, returned]}.
        plausibility: robot systems: the links (fitted or reconstructed) against the robot model's,
            with the thresholds used (:func:`frictionid_core.robots.consistency_check.link_plausibility`).
    """

    system: str
    friction: str
    asymmetric: bool
    solver: str
    source: str | list[str]
    joints: list[str]
    params: dict[str, float]
    std: dict[str, float]
    metrics: dict
    wall_s: float
    joint_map: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    drive: dict | None = None
    window: tuple[float | None, float | None] | None = None
    fixed: dict[str, float] = field(default_factory=dict)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    optimizer: dict | None = None
    varpro: bool | None = None
    warm_start: bool | None = None
    consistency: dict | None = None
    standard_parameters: dict | None = None
    preprocessing: dict | None = None
    layout: str | None = None
    output_error: bool | None = None
    idm: dict | None = None
    idm_params: dict[str, float] | None = None
    identifiability: dict | None = None
    held_joints: dict[str, float] | None = None
    no_effort_joints: list[str] | None = None
    request: IdentifyRequest | None = None
    std_robust: dict[str, float] = field(default_factory=dict)
    uncertainty: dict | None = None
    velocity_range: dict[str, list[float]] | None = None
    holdout: dict | None = None
    plausibility: dict | None = None

    def to_dict(self) -> dict:
        """The result's JSON: the keys of ``frictionid identify --json`` in their order."""
        head = ("system", "joint_map", "friction", "asymmetric", "solver", "source", "joints", "params", "std",
                "std_robust", "metrics", "wall_s", "warnings", "notes", "drive", "window", "fixed", "bounds",
                "optimizer", "varpro", "warm_start", "consistency", "standard_parameters", "preprocessing", "layout",
                "output_error", "idm", "idm_params", "identifiability", "held_joints", "no_effort_joints", "request",
                "uncertainty", "velocity_range", "holdout", "plausibility")
        out = {}
        for key in head:
            value = getattr(self, key)
            if value is None and key in OPTIONAL_KEYS:
                continue
            out[key] = value
        out.update(window=window_record(self.window), bounds={k: [float(lo), float(hi)] for k, (lo, hi) in
                                                              self.bounds.items()})
        if self.request is not None:
            out["request"] = self.request.to_dict()
        return out

    def friction_rows(self) -> list[str]:
        """Who owns the friction and offset parameters (the ``<name>/`` prefixes): the drive's
        motors (``motor_<k>``) when its friction acts on the motors, else the joints."""
        from frictionid_core.drive import friction_rows

        return friction_rows({"drive": self.drive, "joints": self.joints})

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "identification result") -> IdentifyResult:
        """The result of its JSON (:meth:`to_dict`); FrictionIdError ``{where}: key 'name' …``
        naming the first key that is missing, of the wrong type or, for a parameter, not a finite
        number within ±:data:`MAX_PARAMETER` (σ and metrics may be NaN: not determined)."""
        if not isinstance(data, Mapping):
            raise FrictionIdError(f"{where}: not an identification result (expected a JSON object, got "
                                  f"{type(data).__name__}); expected the JSON written by 'frictionid identify'")
        missing = [k for k in REQUIRED_KEYS if k not in data]
        if "params" in missing and ("base_parameters" in data or "bags" in data):
            raise FrictionIdError(f"{where}: a ground truth ('frictionid synth --truth'), not an identification "
                                  "result (compare takes it with --truth)")
        if missing:
            raise FrictionIdError(f"{where} lacks {', '.join(map(repr, missing))}: not an identification result; "
                                  "expected the JSON written by 'frictionid identify'")
        try:
            values = result_fields(data)
            if values.get("request") is not None:
                values["request"] = IdentifyRequest.from_dict(values["request"], where=f"{where}: request key")
        except FieldError as exc:
            raise FrictionIdError(f"{where}: key '{exc.path}'{exc.problem}") from None
        return cls(**values)


def read_result(path: str | Path) -> IdentifyResult:
    """The identification result in the file ``path`` (JSON written by ``frictionid identify``, or
    the YAML of ``frictionid export --yaml``): the one reader of a result file; FrictionIdError
    naming the file and the key at fault."""
    from frictionid_core.jsonfile import read_json

    return IdentifyResult.from_dict(read_json(path, "an identification result"), where=str(path))


# ------------------------------------------------------------------------------ field checks
def result_fields(data: Mapping) -> dict:
    """The dataclass fields of a result's JSON ``data``, each checked (FieldError naming its key);
    keys it does not know are left out, a key missing or null takes its field's default."""
    from frictionid_core.friction import FRICTIONS

    given = {f.name: data[f.name] for f in fields(IdentifyResult) if data.get(f.name) is not None}
    defaults = {"solver": "", "source": "", "joints": [], "std": {}, "std_robust": {}, "metrics": {},
                "wall_s": 0.0}
    checks = {
        "system": lambda k, v: _text(k, v),
        "friction": lambda k, v: choice(k, v, FRICTIONS, "friction model"),
        "asymmetric": flag, "varpro": flag, "warm_start": flag, "output_error": flag,
        "solver": lambda k, v: _text(k, v, empty=True),
        "layout": lambda k, v: _text(k, v, empty=True),
        "source": _source,
        "joints": _names,
        "params": _parameters, "fixed": _parameters, "idm_params": _parameters,
        "std": _sigmas, "std_robust": _sigmas,
        "metrics": _metrics,
        "wall_s": lambda k, v: number(k, v),
        "joint_map": _joint_map,
        "warnings": _lines, "notes": _lines,
        "drive": _drive,
        "window": lambda k, v: _window(mapping(k, v)),
        "bounds": lambda k, v: {n: _bound(f"{k}.{n}", b) for n, b in mapping(k, v).items()},
        "optimizer": mapping, "consistency": mapping, "idm": mapping,
        "uncertainty": mapping, "holdout": mapping, "plausibility": mapping,
        "velocity_range": _velocity_range,
        "standard_parameters": _standard_parameters,
        "preprocessing": _preprocessing,
        "identifiability": mapping,
        "held_joints": _parameters,  # {model joint: position (rad or m)}, each finite
        "no_effort_joints": _names,
        "request": lambda k, v: v,  # IdentifyRequest.from_dict checks it
    }
    nulls = [k for k in REQUIRED_KEYS if data[k] is None]
    if nulls:
        raise FieldError(nulls[0], " must be given, got null")
    return {**defaults, **{k: checks[k](k, v) for k, v in given.items()}}


def _text(key: str, value, empty: bool = False) -> str:
    if not isinstance(value, str) or not (value or empty):
        raise FieldError(key, f" must be {'a' if empty else 'a non-empty'} string, got {value!r}")
    return value


def _source(key: str, value) -> str | list[str]:
    if isinstance(value, str) or (isinstance(value, list) and value and all(isinstance(v, str) for v in value)):
        return value
    raise FieldError(key, f" must be a source name or a list of them, got {value!r}")


def _names(key: str, value) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(j, str) and j for j in value):
        raise FieldError(key, f" must be a list of joint names, got {value!r}")
    repeated = sorted({j for j in value if value.count(j) > 1})
    if repeated:
        raise FieldError(key, f" repeats {repeated}")
    return value


def _lines(key: str, value) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(line, str) for line in value):
        raise FieldError(key, f" must be a list of strings, got {value!r}")
    return value


def _finite(key: str, value) -> float:
    """``value`` if it is a number, finite and within ±MAX_PARAMETER."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise FieldError(key, f" must be a number, got {'null' if value is None else repr(value)}")
    if not math.isfinite(value) or abs(value) > MAX_PARAMETER:
        raise FieldError(key, f" must be a finite number within ±{MAX_PARAMETER:g}, got {value!r}")
    return value


def _parameters(key: str, value) -> dict[str, float]:
    return {name: _finite(f"{key}.{name}", v) for name, v in mapping(key, value).items()}


def _sigmas(key: str, value) -> dict[str, float]:
    for name, v in mapping(key, value).items():
        if isinstance(v, bool) or not isinstance(v, Real):
            raise FieldError(f"{key}.{name}", f" must be a number (NaN: not determined), got {v!r}")
    return value


def _velocity_range(key: str, value) -> dict[str, list[float]]:
    """{row: [slowest, fastest]} speeds, each a number ≥ 0."""
    out = {}
    for row, speeds in mapping(key, value).items():
        if (not isinstance(speeds, list) or len(speeds) != 2
                or not all(isinstance(v, Real) and not isinstance(v, bool) and v >= 0 for v in speeds)):
            raise FieldError(f"{key}.{row}", f" must be [slowest, fastest] speeds ≥ 0, got {speeds!r}")
        out[row] = [float(v) for v in speeds]
    return out


def _metrics(key: str, value) -> dict:
    metrics = mapping(key, value)
    for name, v in metrics.items():
        if name == "per_joint":
            for joint, row in mapping(f"{key}.per_joint", v).items():
                if not isinstance(row, Mapping):
                    raise FieldError(f"{key}.per_joint.{joint}", f" must be a mapping of metrics, got {row!r}")
                for metric, x in row.items():
                    if x is not None and (isinstance(x, bool) or not isinstance(x, Real)):
                        raise FieldError(f"{key}.per_joint.{joint}.{metric}", f" must be a number, got {x!r}")
        elif not (v is None or isinstance(v, (Real, str, Mapping))):
            raise FieldError(f"{key}.{name}", f" must be a number, got {v!r}")
    return value


def _joint_map(key: str, value) -> dict[str, str]:
    joint_map = mapping(key, value)
    if not all(isinstance(v, str) and v for v in joint_map.values()):
        raise FieldError(key, f" must map data joint names to model joint names, got {value!r}")
    return value


def _drive(key: str, value) -> dict:
    from frictionid_core.drive import drive_from_dict

    drive = mapping(key, value)
    if drive:
        try:
            drive_from_dict(drive, "the drive")
        except FrictionIdError as exc:
            raise FieldError(key, f": {exc}") from None
    return value


LINK_KEYS = ("mass", "com", "inertia", "rotor", "rotor_inertia")
INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _standard_parameters(key: str, value) -> dict:
    """Per link {mass, com [x, y, z], inertia {ixx … izz}, rotor, rotor_inertia}
    (:func:`frictionid_core.robots.consistency_check.standard_record`), every number finite."""
    for link, record in mapping(key, value).items():
        where = f"{key}.{link}"
        record = mapping(where, record)
        missing = [k for k in LINK_KEYS if k not in record]
        if missing:
            raise FieldError(where, f" lacks {missing}")
        _finite(f"{where}.mass", record["mass"])
        _finite(f"{where}.rotor_inertia", record["rotor_inertia"])
        com = record["com"]
        if not isinstance(com, list) or len(com) != 3:
            raise FieldError(f"{where}.com", f" must be [x, y, z], got {com!r}")
        for axis, x in zip("xyz", com):
            _finite(f"{where}.com.{axis}", x)
        inertia = mapping(f"{where}.inertia", record["inertia"])
        for name in INERTIA_KEYS:
            if name not in inertia:
                raise FieldError(f"{where}.inertia", f" lacks '{name}'")
            _finite(f"{where}.inertia.{name}", inertia[name])
        if record["rotor"] is not None:
            _text(f"{where}.rotor", record["rotor"])
    return value


def _preprocessing(key: str, value) -> dict:
    """The settings of a ``preprocessing`` block (its other keys are a report): types, finite
    numbers, then :class:`~frictionid_core.preprocess.Preprocessing`'s own checks."""
    from frictionid_core.preprocess import Preprocessing

    block = mapping(key, value)
    for name in ("cutoff_hz", "trim_start_s", "trim_end_s", "trim_start", "trim_end"):
        if block.get(name) is not None:
            _finite(f"{key}.{name}", block[name])
    for name in ("order", "decimate", "thin"):
        if name in block:
            integer(f"{key}.{name}", block[name], low=1, optional=name == "decimate")
    for name in ("min_speed", "dip_scale"):
        speeds = block.get(name)
        if isinstance(speeds, Mapping):
            _parameters(f"{key}.{name}", speeds)
        elif speeds is not None:
            _finite(f"{key}.{name}", speeds)
    for name in ("velocity", "filter", "metric"):
        if name in block:
            _text(f"{key}.{name}", block[name])
    try:
        Preprocessing.from_dict(block, 1.0)
    except FrictionIdError as exc:
        raise FieldError(key, f": {exc}") from None
    return value
