"""What one identification is asked for: :class:`IdentifyRequest`, validated once, on creation.

Every caller builds one, through the one validator of its fields (``__post_init__``): Python
(``IdentifyRequest(system="emps", friction="coulomb")``), the command line (its flags, or a YAML
file: ``frictionid identify --request FILE``) and the node (its ``~/identify`` fields over its
parameters), the last two through :meth:`IdentifyRequest.from_dict`, which names a bad value by
the caller's own name for it (``--pop``, ``request field 'population'``, ``r.yaml: key 'solver.pop'``).
A request holds names and values only (the system's name, the drive's file, bundled name or
keys), so it is a YAML file (:func:`read_request`, :func:`write_request`) and pickles to the
node's worker process.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.checks import (
    FieldError,
    bound_value,
    choice,
    drive_value,
    flag,
    joint_names,
    known_keys,
    mapping,
    number,
    system_name,
    window_value,
)
from frictionid_core.identification.settings import PreprocessingOverrides, SolverOptions

ROBOT_SYSTEMS = "tx40, urdf:PATH"  # the systems with body parameters, for messages
EFFORT_SIGNS = ("auto", "as-logged")  # effort_sign: take a clearly better negated effort, or keep the log's


@dataclass(frozen=True)
class IdentifyRequest:
    """One identification's choices (validated on creation: a bad value is a :class:`FieldError`
    naming its field).

    Attributes:
        system: the inverse dynamic model: ``emps``, ``joint``, ``friction-only``, ``tx40-j2``,
            ``tx40`` or ``urdf:PATH`` (see :data:`frictionid_core.systems.SYSTEM_NAMES`).
        joints: the data joints to fit, in this order (None: every joint of the data).
        joint_map: {data joint: model joint} of a robot system where the names differ.
        drive: the log's transmission: a drive YAML file or bundled name (``tx40``), or the
            drive's keys (:func:`frictionid_core.drive.transmission.drive_from_dict`); None: a joint-side log.
        friction: the friction law (one of :data:`frictionid_core.friction.FRICTIONS`).
        asymmetric: separate parameters for v > 0 and v < 0.
        solver: the solver and its options (a method name alone is ``SolverOptions(method=name)``).
        preprocessing: settings replacing the system's pre-processing defaults.
        window: (start_s, end_s) of every source, s from its first sample (None: an open end);
            None: all of it.
        fixed: {name: value} parameters held at a value in every solver path (σ 0); a name is a
            full parameter name, a base name (``offset``) or a family (``vs``).
        bounds: {name: (lo, hi)} the user's bounds, held by every solver path (names as ``fixed``).
        consistent: robot systems: physically consistent standard parameters (the result gains
            ``standard_parameters`` and ``consistency``).
        prior: robot systems: ``urdf`` holds the directions the data do not resolve at the robot
            model's own values (see ``identifiability`` in the result) and, with ``consistent``,
            pulls each link toward the model's inertials (log-det divergence weighted by
            ``prior_weight``); None: no prior (unresolved directions are dropped).
        prior_weight: weight of that divergence against the data term (≥ 0).
        stribeck_order: with ``consistent``: also Fs ≥ Fc.
        hold: robot systems: {model joint: position (rad or m)} joints held still at that position
            in every source (a logged column of that joint is not used).
        hold_missing: robot systems: every model joint absent from a source is held still at 0
            (or at the drive's ``position_offset`` of that joint).
        gravity: system ``joint``: each joint also gets ``g_sin``·sin q + ``g_cos``·cos q.
        known_rigid_body: robot systems: the robot model's rigid body held (its links as
            modelled), the rotor inertia (armature) of each joint or motor identified (≥ 0) with
            the friction and offsets; the result's base parameters are the links' with the
            identified rotor inertias in them, each rotor inertia also by its own name
            (``<joint>.Ia``). The node's ``known_rigid_body`` parameter.
        effort_sign: ``auto``: joints whose friction ends ≤ 0 are fitted again with their efforts
            negated, and the negated fit is returned when it is clearly better (its drive then
            holds the signs: :mod:`~frictionid_core.identification.effort_sign`); ``as-logged``:
            the log's signs, with a warning when negating would fit clearly better.
        elements: the ``gms`` law's number of Maxwell-slip elements (None: 4).
        load_dependent: robot systems: each row joint's Coulomb level rises with its rigid-body
            torque, Fc + Fc_load·|τ_rigid| (``<joint>/Fc_load``, identified with the rest).
    """

    system: str = "emps"
    joints: tuple[str, ...] | None = None
    joint_map: dict[str, str] = field(default_factory=dict)
    drive: str | dict | None = None
    friction: str = "coulomb"
    asymmetric: bool = False
    solver: SolverOptions = field(default_factory=SolverOptions)
    preprocessing: PreprocessingOverrides = field(default_factory=PreprocessingOverrides)
    window: tuple[float | None, float | None] | None = None
    fixed: dict[str, float] = field(default_factory=dict)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    consistent: bool = False
    prior: str | None = None
    prior_weight: float = 1.0
    stribeck_order: bool = False
    hold: dict[str, float] = field(default_factory=dict)
    hold_missing: bool = False
    gravity: bool = False
    known_rigid_body: bool = False
    effort_sign: str = "auto"
    elements: int | None = None
    load_dependent: bool = False

    def __post_init__(self) -> None:
        from frictionid_core.friction import FRICTIONS

        set_ = object.__setattr__
        set_(self, "system", system_name(self.system))
        set_(self, "joints", joint_names(self.joints))
        joint_map = mapping("joint_map", self.joint_map)
        if not all(isinstance(v, str) and v for v in joint_map.values()):
            raise FieldError("joint_map", f" must map data joint names to model joint names, got {joint_map!r}")
        set_(self, "joint_map", joint_map)
        set_(self, "drive", drive_value(self.drive))
        choice("friction", self.friction, (*FRICTIONS, "auto"), "friction model")
        choice("effort_sign", self.effort_sign, EFFORT_SIGNS, "effort sign policy")
        set_(self, "asymmetric", flag("asymmetric", self.asymmetric))
        set_(self, "solver", _nested("solver", self.solver, SolverOptions, "method"))
        set_(self, "preprocessing", _nested("preprocessing", self.preprocessing, PreprocessingOverrides))
        set_(self, "window", window_value(self.window))
        set_(self, "fixed", {k: number(f"fixed.{k}", v) for k, v in mapping("fixed", self.fixed).items()})
        set_(self, "bounds", {k: bound_value(f"bounds.{k}", v) for k, v in mapping("bounds", self.bounds).items()})
        if self.elements is not None and self.friction != "auto":
            from frictionid_core.friction import get_model

            try:
                get_model(self.friction, self.asymmetric, self.elements)
            except FrictionIdError as exc:
                raise FieldError("elements", f": {exc}") from None
        self._check_consistency()

    def _check_consistency(self) -> None:
        set_ = object.__setattr__
        for name in ("consistent", "stribeck_order", "hold_missing", "gravity", "known_rigid_body", "load_dependent"):
            set_(self, name, flag(name, getattr(self, name)))
        hold = {k: number(f"hold.{k}", v) for k, v in mapping("hold", self.hold).items()}
        bad = [k for k, v in hold.items() if not math.isfinite(v)]
        if bad:
            raise FieldError(f"hold.{bad[0]}", f" must be a finite position (rad or m), got {hold[bad[0]]}")
        set_(self, "hold", hold)
        if self.prior == "none":
            set_(self, "prior", None)
        if self.prior is not None:
            choice("prior", self.prior, ("urdf",), "prior")
        weight = number("prior_weight", self.prior_weight)
        if not 0.0 <= weight < math.inf:
            raise FieldError("prior_weight", f" must be >= 0, got {weight}")
        set_(self, "prior_weight", weight)
        robot = self.system == "tx40" or self.system.startswith("urdf:")
        for name, used in (("consistent", self.consistent), ("prior", self.prior is not None),
                           ("hold", bool(self.hold)), ("hold_missing", self.hold_missing),
                           ("load_dependent", self.load_dependent)):
            if used and not robot:
                raise FieldError(name, f": needs a robot system ({ROBOT_SYSTEMS}) with body parameters; "
                                       f"system '{self.system}' has none")
        if self.stribeck_order and not self.consistent:
            raise FieldError("stribeck_order", ": applies to the consistent fit only: set consistent")
        if self.gravity and self.system != "joint":
            raise FieldError("gravity", f": adds g_sin·sin q + g_cos·cos q to the one-joint model (system 'joint'); "
                                        f"system '{self.system}' "
                             + ("has its own gravity terms" if robot else "has none"))
        if self.known_rigid_body:
            if not robot:
                raise FieldError("known_rigid_body", f": needs a robot system ({ROBOT_SYSTEMS}) whose model has the "
                                                     f"rigid body; system '{self.system}' has none")
            if self.consistent:
                raise FieldError("known_rigid_body", ": holds the model's rigid body, which consistent fits; "
                                                     "choose one")

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "request field", names: Mapping[str, str] | None = None
                  ) -> IdentifyRequest:
        """The request of a mapping (YAML, the node's fields; nested ``solver``/``preprocessing``
        mappings, ``window`` as {start_s, end_s}): see :meth:`to_dict`. A bad value is a
        FrictionIdError ``{where} '{name}'…`` with ``names`` (field path → the caller's name for it)."""
        names = dict(names or {})
        try:
            if not isinstance(data, Mapping):
                raise FieldError("", f" must be a mapping of fields, got {type(data).__name__}")
            known_keys("", data, cls)
            return cls(**data)
        except FieldError as exc:
            label = names.get(exc.path, exc.path)
            raise FrictionIdError(f"{where} '{label}'{exc.problem}" if where else f"{label}{exc.problem}") from None

    def to_dict(self) -> dict:
        """Plain values (YAML/JSON), read back by :meth:`from_dict`."""
        out = {f.name: copy.deepcopy(getattr(self, f.name)) for f in fields(self)}
        out.update(joints=None if self.joints is None else list(self.joints), solver=self.solver.to_dict(),
                   preprocessing=self.preprocessing.to_dict(), window=window_record(self.window),
                   bounds={k: list(v) for k, v in self.bounds.items()})
        return out


def window_record(window: tuple[float | None, float | None] | None) -> dict | None:
    """A window (start_s, end_s) as a result and a request file keep it: {"start_s", "end_s"} (s;
    None: open), or None."""
    return None if window is None else dict(zip(("start_s", "end_s"), window))


def _nested(path: str, value, cls, shorthand: str | None = None):
    if isinstance(value, cls):
        return value
    if shorthand is not None and isinstance(value, str):
        value = {shorthand: value}
    if not isinstance(value, Mapping):
        raise FieldError(path, f" must be a {cls.__name__} or a mapping of its fields, got {value!r}")
    known_keys(path, value, cls)
    return cls(**value)


def read_request(path: str | Path) -> IdentifyRequest:
    """The request in a YAML (or JSON) file: a request's mapping (:meth:`IdentifyRequest.to_dict`),
    or an identification result holding one (its ``request`` key)."""
    from frictionid_core.files import read_yaml

    data = read_yaml(path, "an identification request")
    if "request" in data and "params" in data:  # a result of 'frictionid identify --json'
        data = data["request"]
    return IdentifyRequest.from_dict(data, where=f"{path}: key")


def write_request(path: str | Path, request: IdentifyRequest) -> Path:
    """Write ``request`` as YAML to ``path`` atomically; returns the absolute path."""
    import yaml

    from frictionid_core.files import write_text

    return write_text(path, yaml.safe_dump(request.to_dict(), sort_keys=False, allow_unicode=True))
