"""Real-coded genetic algorithm (thesis §3.2.1, Algorithm 1).

Thesis settings (tables 6.11, 6.16): population 50, 100 generations, 2 elites
(N_GA), mutation rate 0.02 (rho_c), single-point crossover (X_over). Per generation:

* elitism: the ``elites`` best individuals pass unchanged (and are not re-evaluated);
* selection: roulette wheel (thesis eq. 3-8, p_i = fit_i / sum fit) on rank-scaled fitness
  fit = 1/sqrt(rank) (MATLAB ``fitscalingrank``), which works for any cost sign or scale
  and gives NaN/inf costs the lowest probability; ``selection="tournament"`` uses binary
  tournaments instead;
* crossover: with probability ``crossover_rate`` (0.8, MATLAB's default crossover
  fraction; not given in the thesis) single-point crossover at a random gene c: the genes
  after c are swapped and, with ``crossover="blend"`` (default; the continuous single-point
  crossover of Haupt & Haupt, *Practical Genetic Algorithms*, §3.2.4), gene c itself becomes
  m_c − β(m_c − f_c) and f_c + β(m_c − f_c) with β ~ U(0, 1), so crossover also creates new
  values; ``crossover="swap"`` only swaps (cut point drawn in 1…k−1);
* mutation: each gene of each child mutates with probability ``mutation_rate``.
  ``mutation="gaussian"`` (default) adds N(0, sigma_g) with sigma_g shrinking linearly from
  ``mutation_scale`` (fraction of the bound range) at generation 1 to 0 at the last one
  (MATLAB ``mutationgaussian`` with shrink 1); ``mutation="uniform"`` redraws the gene
  uniformly in its bounds (MATLAB ``mutationuniform``). Single-point crossover only
  reshuffles existing gene values, so the mutation operator is the GA's only source of
  new values with ``crossover="swap"``: uniform redraws then make it a random search per
  gene, the shrinking Gaussian lets it refine.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import OptimError
from frictionid_core.optim._engine import PopulationRun, check_count, check_fraction
from frictionid_core.optim.problem import OptimResult, Problem

SELECTIONS = ("roulette", "tournament")
CROSSOVERS = ("blend", "swap")
MUTATIONS = ("gaussian", "uniform")


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    pop: int = 50,
    generations: int = 100,
    elites: int = 2,
    mutation_rate: float = 0.02,
    crossover_rate: float = 0.8,
    selection: str = "roulette",
    mutation: str = "gaussian",
    mutation_scale: float = 0.1,
    crossover: str = "blend",
) -> OptimResult:
    """Minimise ``problem`` with a real-coded GA.

    Args:
        pop: population size (>= elites + 2).
        generations: generations including the initial one;
            nfev = pop + (generations - 1) * (pop - elites).
        elites: best individuals copied unchanged into the next generation.
        mutation_rate: per-gene mutation probability.
        crossover_rate: probability that a selected pair is crossed over.
        selection: "roulette" (rank-scaled fitness) or "tournament" (binary).
        mutation: "gaussian" (shrinking, default) or "uniform" (redraw in bounds).
        mutation_scale: initial Gaussian sigma as a fraction of each bound range.
        crossover: "blend" (single-point with a blended cut gene, default) or "swap".
    """
    pop = check_count(pop, "pop", "ga", minimum=2)
    generations = check_count(generations, "generations", "ga")
    if isinstance(elites, bool) or not isinstance(elites, (int, np.integer)) or not 0 <= elites <= pop - 2:
        raise OptimError(f"ga: elites must be a whole number in [0, pop - 2 = {pop - 2}], got {elites!r}")
    mutation_rate = check_fraction(mutation_rate, "mutation_rate", "ga")
    crossover_rate = check_fraction(crossover_rate, "crossover_rate", "ga")
    mutation_scale = check_fraction(mutation_scale, "mutation_scale", "ga", 0.0, 10.0)
    if selection not in SELECTIONS:
        raise OptimError(f"ga: selection must be one of {SELECTIONS}, got {selection!r}")
    if crossover not in CROSSOVERS:
        raise OptimError(f"ga: crossover must be one of {CROSSOVERS}, got {crossover!r}")
    if mutation not in MUTATIONS:
        raise OptimError(f"ga: mutation must be one of {MUTATIONS}, got {mutation!r}")
    k = problem.k
    run = PopulationRun(problem, "ga", generations)
    n_children = pop - elites
    n_pairs = (n_children + 1) // 2
    rank_cdf = np.cumsum(1.0 / np.sqrt(np.arange(1, pop + 1)))
    rank_cdf /= rank_cdf[-1]
    genes = np.arange(k)

    u = run.initial(rng, pop)
    f = run.evaluate(u)
    run.record(u)
    for g in range(1, generations):
        order = np.argsort(f, kind="stable")
        u, f = u[order], f[order]  # best first
        if selection == "roulette":
            parents = np.minimum(np.searchsorted(rank_cdf, rng.random(2 * n_pairs), side="right"), pop - 1)
        else:
            contenders = rng.integers(0, pop, size=(2 * n_pairs, 2))
            parents = contenders.min(axis=1)  # sorted population: lower index = better
        mother, father = u[parents[0::2]], u[parents[1::2]]
        crossing = (rng.random(n_pairs) < crossover_rate)[:, None]
        if crossover == "blend":
            cut = rng.integers(0, k, size=n_pairs)
            beta = rng.random(n_pairs)[:, None]
            swap = (genes[None, :] > cut[:, None]) & crossing
            at_cut = (genes[None, :] == cut[:, None]) & crossing
            spread = beta * (mother - father)
            first = np.where(swap, father, np.where(at_cut, mother - spread, mother))
            second = np.where(swap, mother, np.where(at_cut, father + spread, father))
        else:
            swap = (genes[None, :] >= rng.integers(1, max(k, 2), size=n_pairs)[:, None]) & crossing & (k > 1)
            first, second = np.where(swap, father, mother), np.where(swap, mother, father)
        children = np.concatenate((first, second))[:n_children]
        mutate = rng.random((n_children, k)) < mutation_rate
        if mutation == "gaussian":
            sigma = mutation_scale * (1.0 - (g - 1) / max(generations - 1, 1))
            children = np.where(mutate, children + sigma * rng.standard_normal((n_children, k)), children)
            children = np.clip(children, 0.0, 1.0)
        else:
            children = np.where(mutate, rng.random((n_children, k)), children)
        f_children = run.evaluate(children)
        u = np.concatenate((u[:elites], children))
        f = np.concatenate((f[:elites], f_children))
        run.record(u)
    return run.result(
        f"{selection} selection, single-point {crossover} crossover {crossover_rate:g}, {mutation} mutation "
        f"{mutation_rate:g}, {elites} elites, {generations} generations x {pop} population"
    )
