"""Differential evolution DE/rand/1/bin (thesis §3.2.4, Algorithm 4; Storn & Price 1997).

Thesis settings (tables 6.10, 6.16): population 50, 100 generations, F = 0.4, CR = 0.9.
Generation 1 is the random initial population; each further generation builds one trial
vector per member (mutant x_r1 + F (x_r2 - x_r3), r1, r2, r3 distinct and != i; binomial
crossover with one forced gene), evaluates all trials in one ``batch_cost`` call and keeps
the trial where f(trial) <= f(member) (<= lets the population drift across plateaus and
out of NaN regions). Trials leaving the box are clipped to it.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.optim._engine import PopulationRun, check_count, check_fraction
from frictionid_core.optim.problem import OptimResult, Problem


def distinct_other_indices(rng: np.random.Generator, pop: int, n: int) -> np.ndarray:
    """(pop, n) indices: row i holds n distinct members, all != i, uniformly drawn."""
    excluded = np.arange(pop)[:, None]  # sorted along axis 1
    out = np.empty((pop, n), dtype=np.intp)
    for c in range(n):
        r = rng.integers(0, pop - 1 - c, size=pop)
        for e in range(excluded.shape[1]):  # shift past each excluded index, ascending
            r += r >= excluded[:, e]
        out[:, c] = r
        excluded = np.sort(np.concatenate((excluded, r[:, None]), axis=1), axis=1)
    return out


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    pop: int = 50,
    generations: int = 100,
    F: float = 0.4,
    CR: float = 0.9,
) -> OptimResult:
    """Minimise ``problem`` with DE/rand/1/bin.

    Args:
        pop: population size (>= 4).
        generations: generations including the initial one; nfev = pop * generations.
        F: differential weight (step scale), > 0.
        CR: crossover rate in [0, 1].
    """
    pop = check_count(pop, "pop", "de", minimum=4)
    generations = check_count(generations, "generations", "de")
    F = check_fraction(F, "F", "de", 0.0, 2.0)
    CR = check_fraction(CR, "CR", "de")
    k = problem.k
    run = PopulationRun(problem, "de", generations)
    rows = np.arange(pop)

    u = run.initial(rng, pop)
    f = run.evaluate(u)
    run.record(u)
    for _ in range(1, generations):
        r = distinct_other_indices(rng, pop, 3)
        mutant = u[r[:, 0]] + F * (u[r[:, 1]] - u[r[:, 2]])
        take = rng.random((pop, k)) < CR
        take[rows, rng.integers(0, k, size=pop)] = True
        trial = np.clip(np.where(take, mutant, u), 0.0, 1.0)
        f_trial = run.evaluate(trial)
        better = f_trial <= f
        u = np.where(better[:, None], trial, u)
        f = np.where(better, f_trial, f)
        run.record(u)
    return run.result(f"rand/1/bin, F {F:g}, CR {CR:g}, {generations} generations x {pop} population")
