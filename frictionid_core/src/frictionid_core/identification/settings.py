"""The nested settings of a request: its solver (:class:`SolverOptions`) and the pre-processing
settings it overrides (:class:`PreprocessingOverrides`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace

from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.checks import FieldError, choice, flag, integer, mapping


def budget_field(method: str) -> str:
    """The budget a method counts: ``calls`` (lm, bo, dt) or ``generations`` (population methods, hybrid)."""
    from frictionid_core.optim import CALL_METHODS

    return "calls" if method in CALL_METHODS else "generations"


@dataclass(frozen=True)
class SolverOptions:
    """The solver of an identification and its options.

    Attributes:
        method: ``ls`` (closed-form least squares of a model linear in its parameters) or an
            optimiser of :mod:`frictionid_core.optim` (lm, ga, aco, bbo, de, pso, bo, dt, hybrid).
        seed: seed of stochastic solvers.
        pop: population size of population methods (and the hybrid's global stage); None or 0:
            the method's default.
        generations: generations of population methods (the hybrid's global stage); None or 0: default.
        calls: cost calls of lm/bo/dt (the hybrid's polish); None or 0: default.
        varpro: variable projection: only the nonlinear friction parameters (vs, delta, v0) are
            searched, every other one solved in closed form per candidate. None: on for the
            robot systems (tx40, urdf:PATH), whose tens of base parameters a global search over
            every parameter does not find, and for a law with a dip (a population of 50 over
            100 generations stops short of the optimum in the nine dimensions of a TX40
            joint-2 Stribeck fit, in its two shape parameters it converges); off with
            ``warm_start`` off (the thesis protocol: every parameter searched from a random start)
            and otherwise (:meth:`resolved`).
        warm_start: global methods evaluate the closed-form start point first (no result worse
            than the nested linear model) and, searching the shape parameters (``varpro``), have
            their best point polished by lm; False: a purely random start and the search's own
            answer, the thesis protocol.
        options: the method's own keywords (see its module's ``solve``), e.g. ``{"F": 0.5}`` for de.
    """

    method: str = "ls"
    seed: int = 0
    pop: int | None = None
    generations: int | None = None
    calls: int | None = None
    varpro: bool | None = None
    warm_start: bool = True
    options: dict = field(default_factory=dict)

    def resolved(self, robot: bool, friction: str) -> SolverOptions:
        """These options with ``varpro`` decided (see the attribute) for a robot system or not
        and the law ``friction``."""
        if self.varpro is not None:
            return self
        from frictionid_core.friction import LAWS

        shaped = bool(LAWS[friction].nonlinear) if friction in LAWS else False
        return replace(self, varpro=robot or (shaped and self.warm_start))

    def __post_init__(self) -> None:
        from frictionid_core.optim import SOLVERS

        choice("solver.method", self.method, SOLVERS, "solver")
        set_ = object.__setattr__
        set_(self, "seed", integer("solver.seed", self.seed, optional=False))
        for name in ("pop", "generations", "calls"):  # 0: the method's default, as None
            set_(self, name, integer(f"solver.{name}", getattr(self, name)) or None)
        set_(self, "varpro", flag("solver.varpro", self.varpro, optional=True))
        set_(self, "warm_start", flag("solver.warm_start", self.warm_start))
        set_(self, "options", mapping("solver.options", self.options))
        if self.options:
            self._check_options()

    def _check_options(self) -> None:
        from frictionid_core.optim import METHODS, method_options

        if self.method not in METHODS:
            raise FieldError("solver.options", f": '{self.method}' takes no options, got {sorted(self.options)}")
        accepted = method_options(self.method) - {"pop", "generations", "calls"}
        unknown = sorted(set(self.options) - accepted)
        if unknown:
            raise FieldError("solver.options", f": unknown option(s) {unknown} of {self.method}; it accepts "
                                               f"{sorted(accepted)}")

    def to_dict(self) -> dict:
        return asdict(self)


# Pre-processing settings a request may override (see frictionid_core.preprocess.Preprocessing).
OVERRIDABLE = ("cutoff_hz", "order", "decimate", "trim_start_s", "trim_end_s", "min_speed", "velocity", "filter",
               "metric", "reversal_periods")


@dataclass(frozen=True)
class PreprocessingOverrides:
    """Pre-processing settings that replace the system's defaults (None: the system's, whose own
    None settings are chosen from the data): see :class:`frictionid_core.preprocess.Preprocessing`
    for each setting and its unit."""

    cutoff_hz: float | None = None
    order: int | None = None
    decimate: int | None = None
    trim_start_s: float | None = None
    trim_end_s: float | None = None
    min_speed: float | dict | None = None
    velocity: str | None = None
    filter: str | None = None
    metric: str | None = None
    reversal_periods: float | None = None

    def __post_init__(self) -> None:
        from frictionid_core.preprocess import Preprocessing

        for name, value in self.changes().items():
            if isinstance(value, Mapping):
                object.__setattr__(self, name, dict(value))
            try:
                Preprocessing(**{name: value})
            except (FrictionIdError, TypeError) as exc:
                raise FieldError(f"preprocessing.{name}", f": {exc}") from None

    @classmethod
    def from_settings(cls, settings) -> PreprocessingOverrides:
        """Every setting of ``settings`` (a Preprocessing, e.g. a result's resolved one:
        ``Preprocessing.from_dict(result["preprocessing"])``); its settings left None take the
        system's default, not the data's choice."""
        return cls(**{name: getattr(settings, name) for name in OVERRIDABLE})

    def changes(self) -> dict:
        """{setting: value} of the settings given."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}

    def apply(self, default):
        """``default`` (a Preprocessing) with these settings over it (``default`` itself without any)."""
        from dataclasses import replace

        changes = self.changes()
        return replace(default, **changes) if changes else default

    def to_dict(self) -> dict:
        return asdict(self)
