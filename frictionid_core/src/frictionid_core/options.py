"""What an identification may be asked for, validated in one place.

The command line (``frictionid identify``), the node's ``~/identify`` service and its YAML
configuration all build a :class:`SolveOptions` and so share one validation and one
mapping of a budget to the solver's own unit (generations or cost calls).
"""

from __future__ import annotations

from dataclasses import dataclass

from frictionid_core.errors import FrictionIdError
from frictionid_core.optim import CALL_METHODS, SOLVERS

# Clocks of the EMPS closed-loop simulation (frictionid_core.emps_simulation): the recorded stamps,
# or the benchmark's constant period.
CLOCKS = ("true", "benchmark")
# Where identification takes q̇ from (frictionid_core.preprocess): the central difference of the
# filtered position, or the logged velocity low-passed the same way.
VELOCITY_SOURCES = ("position", "recorded")


def check_choice(field: str, value: str, choices, what: str | None = None) -> str:
    """``value`` if it is one of ``choices``, else FrictionIdError naming ``field``."""
    if value not in choices:
        raise FrictionIdError(f"{field}: unknown {what or field} '{value}'; choose one of {', '.join(choices)}")
    return value


def budget_options(solver: str, budget: int | None = None, pop: int | None = None) -> dict[str, int]:
    """Solver keyword budgets: ``budget`` counts cost calls for lm/bo/dt and generations for the
    population methods (and the hybrid's global stage); ``pop`` is the population size.
    None or 0 leaves the solver's default."""
    out = {}
    if budget:
        out["calls" if solver in CALL_METHODS else "generations"] = int(budget)
    if pop:
        out["pop"] = int(pop)
    return out


@dataclass(frozen=True)
class SolveOptions:
    """Friction model and solver of one identification (validated on creation).

    Attributes:
        friction: friction law (one of :data:`frictionid_core.friction.FRICTIONS`).
        asymmetric: separate parameters for v > 0 and v < 0.
        solver: ``ls`` or an optimiser of :mod:`frictionid_core.optim`.
        seed: seed of stochastic solvers.
        budget: generations (population methods, hybrid) or calls (lm, bo, dt); 0: default.
        pop: population size of population methods; 0: default.
    """

    friction: str = "coulomb"
    asymmetric: bool = False
    solver: str = "ls"
    seed: int = 0
    budget: int = 0
    pop: int = 0

    def __post_init__(self) -> None:
        from frictionid_core.friction import FRICTIONS

        check_choice("friction", self.friction, FRICTIONS, "friction model")
        check_choice("solver", self.solver, SOLVERS)
        for name in ("budget", "pop"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise FrictionIdError(f"{name} must be an integer >= 0, got {value!r}")

    def solver_options(self) -> dict[str, int]:
        """The budgets as :func:`frictionid_core.identification.identify` keywords."""
        return budget_options(self.solver, self.budget, self.pop)
