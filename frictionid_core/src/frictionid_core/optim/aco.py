"""Ant colony optimisation for continuous domains, ACO_R (Socha & Dorigo 2008).

The thesis (table 6.10) runs ACO with population 50, 100 generations, initial pheromone
tau0 = 1e-6, evaporation rate rho = 0.9 and N_ACO = 2 elite ants: settings of a
pheromone-per-bin ant system (Simon 2013). ACO_R keeps its "pheromone" as an archive of the
best solutions found, each weighted by rank, and samples new ants from Gaussian kernels
centred on archive members. The thesis settings are mapped as follows:

* population 50 -> archive size ``pop`` = 50 and 50 new ants per generation (the same
  50 evaluations per generation as the other methods; generation 1 fills the archive);
* rho = 0.9 -> xi = 0.9, ACO_R's width factor, which Socha & Dorigo introduce as the
  analogue of the evaporation rate (higher = slower convergence); the kernel width of
  dimension j around guide l is sigma_lj = xi * mean_e |s_ej - s_lj|;
* N_ACO = 2 elite ants -> rank weights w_l = exp(-l^2 / (2 (q pop)^2)) (l = 0 best) with
  q * pop = 2, i.e. q = 2/50 = 0.04: the guides of new ants are drawn essentially from
  the ~2 best archive members (within one standard deviation of rank). The archive keeps
  the best ``pop`` of archive + ants, so the elite solutions are never lost;
* tau0 = 1e-6 -> floor of sigma, as a fraction of the bound range: the background
  pheromone that keeps every kernel from collapsing to zero width.

Ants leaving the box are clipped to it. One guide is drawn per ant (all dimensions).
"""

from __future__ import annotations

import numpy as np

from frictionid_core.optim._engine import PopulationRun, check_count, check_fraction
from frictionid_core.optim.problem import OptimResult, Problem


def _mean_abs_distance(archive: np.ndarray) -> np.ndarray:
    """(P, k): for each member and dimension, mean_e |s_ej - s_lj| over the other P - 1 members.

    Sorted-column prefix sums: O(P k log P) time and O(P k) memory (no P x P x k array).
    """
    pop = len(archive)
    order = np.argsort(archive, axis=0)
    srt = np.take_along_axis(archive, order, axis=0)
    below = np.cumsum(srt, axis=0)  # sum of values up to and including each sorted position
    above = below[-1] - below
    n_below = np.arange(1, pop + 1)[:, None]
    total = (srt * n_below - below) + (above - srt * (pop - n_below))
    out = np.empty_like(archive)
    np.put_along_axis(out, order, np.maximum(total, 0.0) / (pop - 1), axis=0)
    return out


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    pop: int = 50,
    generations: int = 100,
    tau0: float = 1e-6,
    rho: float = 0.9,
    elite_ants: int = 2,
    q: float | None = None,
) -> OptimResult:
    """Minimise ``problem`` with ACO_R.

    Args:
        pop: archive size and ants per generation (>= 2).
        generations: generations including the initial one; nfev = pop * generations.
        tau0: minimum kernel width, fraction of the bound range.
        rho: evaporation rate, used as ACO_R's xi (kernel width factor), in [0, 10].
        elite_ants: archive members that effectively guide the ants (sets q = elite_ants/pop).
        q: ACO_R locality parameter; overrides ``elite_ants`` when given.
    """
    pop = check_count(pop, "pop", "aco", minimum=2)
    generations = check_count(generations, "generations", "aco")
    tau0 = check_fraction(tau0, "tau0", "aco", 0.0, 1.0)
    rho = check_fraction(rho, "rho", "aco", 0.0, 10.0)
    elite_ants = check_count(elite_ants, "elite_ants", "aco")
    if q is None:
        q, q_source = elite_ants / pop, f"{elite_ants} elite ants"
    else:
        q, q_source = check_fraction(q, "q", "aco", 1e-12, 1e6), "given"
    k = problem.k
    run = PopulationRun(problem, "aco", generations)
    rank = np.arange(pop)
    guide_cdf = np.cumsum(np.exp(-(rank**2) / (2.0 * (q * pop) ** 2)))
    guide_cdf /= guide_cdf[-1]

    archive = run.initial(rng, pop)
    f = run.evaluate(archive)
    order = np.argsort(f, kind="stable")
    archive, f = archive[order], f[order]
    run.record(archive)
    for _ in range(1, generations):
        guide = np.minimum(np.searchsorted(guide_cdf, rng.random(pop), side="right"), pop - 1)
        centre = archive[guide]
        sigma = np.maximum(rho * _mean_abs_distance(archive)[guide], tau0)
        ants = np.clip(centre + sigma * rng.standard_normal((pop, k)), 0.0, 1.0)
        f_ants = run.evaluate(ants)
        merged = np.concatenate((archive, ants))
        f_merged = np.concatenate((f, f_ants))
        keep = np.argsort(f_merged, kind="stable")[:pop]
        archive, f = merged[keep], f_merged[keep]
        run.record(archive)
    return run.result(
        f"archive {pop}, xi(rho) {rho:g}, q {q:g} ({q_source}), "
        f"sigma floor(tau0) {tau0:g}, {generations} generations"
    )
