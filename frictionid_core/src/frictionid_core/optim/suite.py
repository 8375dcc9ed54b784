"""The suite's registry of methods (:data:`METHODS`, one module ``optim/<id>.py`` each, imported on
first use) and the one call that runs any of them, :func:`minimize`."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import TYPE_CHECKING

from frictionid_core import lazy
from frictionid_core.errors import OptimError

if TYPE_CHECKING:
    import numpy as np

    from frictionid_core.optim.problem import OptimResult, Problem

# The optimisers, one module ``optim/<id>.py`` each (a new solver: its module and its id here).
METHOD_IDS = ("lm", "ga", "aco", "bbo", "de", "pso", "bo", "dt", "hybrid")
POPULATION_METHODS = ("ga", "aco", "bbo", "de", "pso")
# Methods whose budget is a number of cost calls (the population methods count generations).
CALL_METHODS = ("lm", "bo", "dt")
# Every solver id of identify(): "ls" (closed-form least squares) then the optimisers.
SOLVERS = ("ls", *METHOD_IDS)
BUDGETS = ("pop", "generations", "calls")


class _Methods(Mapping):
    """Method id → its ``solve`` function; each method's module (``optim/<id>.py``) is
    imported on first use, so importing this package stays light."""

    _ids = METHOD_IDS

    def __getitem__(self, method: str) -> Callable[..., OptimResult]:
        if method not in self._ids:
            raise KeyError(method)
        return lazy.attribute(f"frictionid_core.optim.{method}", "solve")

    def __iter__(self) -> Iterator[str]:
        return iter(self._ids)

    def __len__(self) -> int:
        return len(self._ids)

    def __contains__(self, method: object) -> bool:
        return method in self._ids


METHODS: Mapping[str, Callable[..., OptimResult]] = _Methods()

def _keyword_options(solve: Callable) -> frozenset[str]:
    import inspect

    return frozenset(
        name for name, p in inspect.signature(solve).parameters.items() if p.kind is p.KEYWORD_ONLY
    )


def method_options(method: str) -> frozenset[str]:
    """The keywords ``method``'s ``solve`` takes (its budgets among them): what :func:`minimize`
    accepts for it."""
    return _keyword_options(METHODS[method])


def call_method(
    problem: Problem,
    method: str,
    rng: np.random.Generator,
    *,
    pop: int | None,
    generations: int | None,
    calls: int | None,
    options: dict,
) -> OptimResult:
    """Run METHODS[method] with the budgets it uses; unused budgets are noted in the message."""
    solve = METHODS[method]
    accepted = _keyword_options(solve)
    unknown = sorted(set(options) - accepted)
    if unknown:
        raise OptimError(
            f"{method}: unknown option(s) {unknown}; it accepts {sorted(accepted)}"
        )
    kwargs = dict(options)
    ignored = []
    for name, value in (("pop", pop), ("generations", generations), ("calls", calls)):
        if value is None:
            continue
        if name not in accepted:
            ignored.append(name)
            continue
        if name in kwargs:
            raise OptimError(f"{method}: {name} given twice (as a budget and in the options)")
        kwargs[name] = value
    result = solve(problem, rng, **kwargs)
    if ignored:
        result.message += f"; ignored {', '.join(ignored)} (not used by {method})"
    return result


def minimize(
    problem: Problem,
    method: str,
    *,
    seed: int | np.random.Generator | None = 0,
    pop: int | None = None,
    generations: int | None = None,
    calls: int | None = None,
    **options,
) -> OptimResult:
    """Minimise ``problem.batch_cost`` within the bounds with ``method``.

    Args:
        problem: parameters, bounds and cost (validated again here).
        method: one of :data:`METHODS` (ga, aco, bbo, de, pso, lm, bo, dt, hybrid).
        seed: integer seed (or a Generator) for ``numpy.random.default_rng``.
        pop: population size of population methods (default 50).
        generations: generations of population methods, the initial one included (default 100).
        calls: cost calls of bo/dt (default 100) or evaluation budget of lm / the hybrid polish.
        **options: method-specific settings (see each module's ``solve``), e.g. F=0.5 for de.

    Budgets a method does not use are ignored and mentioned in the result's message.

    Raises:
        OptimError: unknown method or option, bad bounds, bad budget, or every
            evaluation returned NaN/inf.
    """
    import numpy as np

    from frictionid_core.optim.problem import Problem

    if method not in METHODS:
        raise OptimError(f"unknown optimiser {method!r}; available: {', '.join(METHODS)}")
    if not isinstance(problem, Problem):
        raise OptimError(f"minimize needs a Problem, got {type(problem).__name__}")
    problem.check()
    rng = np.random.default_rng(seed)
    return call_method(problem, method, rng, pop=pop, generations=generations, calls=calls, options=options)
