"""What an identification produced: :class:`IdentifyResult`, and its JSON (the result file).

The JSON keys are a contract (scripts read them): :meth:`IdentifyResult.to_dict` writes the
fields in their order, leaving out the optional blocks that do not apply (the optimiser's without
an optimiser, the consistent fit's without one, the output-error ones, the request of a result
built by hand); :meth:`IdentifyResult.from_dict` reads such a file back, also one written by
hand or by an earlier version (only ``system``, ``friction``, ``asymmetric`` and ``params`` are
required; keys it does not know are ignored).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.checks import FieldError
from frictionid_core.identification.request import IdentifyRequest, window_record
from frictionid_core.identification.result_fields import REQUIRED_KEYS, result_fields

# Keys left out of the JSON when their field is None.
OPTIONAL_KEYS = ("optimizer", "varpro", "warm_start", "consistency", "standard_parameters", "output_error", "idm",
                 "idm_params", "identifiability", "held_joints", "no_effort_joints", "unexcited_joints", "request",
                 "uncertainty", "velocity_range", "holdout", "plausibility", "law_choice")


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
        metrics: fit metrics on the estimation data (see :mod:`frictionid_core.model.metrics`), with
            ``cost`` and ``cond``; per joint under ``per_joint``.
        wall_s: the identification's wall time [s].
        warnings, notes: what the user should know (one line each), and what the data said.
        drive: the drive's keys (:meth:`frictionid_core.drive.transmission.Drive.to_dict`), or None.
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
        unexcited_joints: data joints not fitted in some source because their motion there (noise,
            a tremble) does not excite their columns: held still there at their logged positions
            (robot systems), each named with its reason in the warnings.
        request: the request that produced it (None: built by hand).
        uncertainty: how ``std`` and ``std_robust`` were obtained (the HAC bandwidth).
        velocity_range: {friction row (joint or motor): [slowest, fastest] |velocity| of the rows
            fitted} (what ``export`` matches a law over).
        holdout: a nonlinear law against its linear special case (Coulomb) on held-back rows:
            {held_back_rows, law_relerr_pct, linear_relerr_pct, beats_linear[, returned]}.
        plausibility: robot systems: the links (fitted or reconstructed) against the robot model's,
            with the thresholds used (:func:`frictionid_core.consistency.check.link_plausibility`).
        law_choice: ``--friction auto``: the law chosen by what it predicts, every candidate's
            cross-validated error and why (:mod:`frictionid_core.identification.law_choice`).
        at_bound: {name: the bound} of the parameters that end at a bound of their search or of the
            closed form (held at 0 by a sign constraint too): not identified values, σ NaN
            (:mod:`~frictionid_core.identification.at_bound`).
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
    unexcited_joints: list[str] | None = None
    request: IdentifyRequest | None = None
    std_robust: dict[str, float] = field(default_factory=dict)
    uncertainty: dict | None = None
    velocity_range: dict[str, list[float]] | None = None
    holdout: dict | None = None
    plausibility: dict | None = None
    law_choice: dict | None = None
    at_bound: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The result's JSON: the keys of ``frictionid identify --json`` in their order."""
        head = ("system", "joint_map", "friction", "asymmetric", "solver", "source", "joints", "params", "std",
                "std_robust", "at_bound", "metrics", "wall_s", "warnings", "notes", "drive", "window", "fixed",
                "bounds", "optimizer", "varpro", "warm_start", "consistency", "standard_parameters", "preprocessing",
                "layout", "output_error", "idm", "idm_params", "identifiability", "held_joints", "no_effort_joints",
                "unexcited_joints", "request", "uncertainty", "velocity_range", "holdout", "plausibility", "law_choice")
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

    def nonlinear_at_bound(self) -> list[str]:
        """The nonlinear friction parameters (vs, delta, v0, …) that end at a bound: the law needed a
        bound to fit (:func:`~frictionid_core.identification.at_bound.nonlinear_at_bound`)."""
        from frictionid_core.identification.at_bound import nonlinear_at_bound

        return nonlinear_at_bound(self)

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
            values = result_fields(data, [f.name for f in fields(cls)])
            if values.get("request") is not None:
                values["request"] = IdentifyRequest.from_dict(values["request"], where=f"{where}: request key")
        except FieldError as exc:
            raise FrictionIdError(f"{where}: key '{exc.path}'{exc.problem}") from None
        return cls(**values)


def read_result(path: str | Path) -> IdentifyResult:
    """The identification result in the file ``path`` (JSON written by ``frictionid identify``, or
    the YAML of ``frictionid export --yaml``): the one reader of a result file; FrictionIdError
    naming the file and the key at fault."""
    from frictionid_core.files import read_json

    return IdentifyResult.from_dict(read_json(path, "an identification result"), where=str(path))
