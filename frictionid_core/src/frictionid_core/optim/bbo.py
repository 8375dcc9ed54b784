"""Biogeography-based optimisation (thesis §3.2.3, Algorithm 3; Simon 2008, 2013).

Thesis settings (table 6.10): population 50, 100 generations, sinusoidal migration,
migration blend parameter 0.5. Per generation, with habitats sorted best first
(rank r = 0 .. n-1, s = (n-1-r)/(n-1) in [0, 1] the normalised species count):

* sinusoidal migration model (Ma 2010): immigration lambda = (cos(pi s) + 1)/2,
  emigration mu = (1 - cos(pi s))/2, so the best habitat has lambda = 0, mu = 1;
* partial immigration: each SIV (gene) of habitat i immigrates with probability lambda_i
  from a source habitat drawn by roulette on mu; blended migration
  z = blend * x_i + (1 - blend) * x_source (blend 0.5);
* mutation: each SIV is redrawn uniformly in its bounds with probability ``mutation_rate``
  (0.01, Simon's default; the thesis does not give one);
* elitism: the ``elites`` best habitats (2, Simon's default) pass unchanged and are not
  re-evaluated. The new habitats replace the old ones (generational).

Blended migration is a convex combination, so new values beyond the population's current
range come only from mutation: an optimum on a bound is approached (typically within a
few % of the range at the default budget) but, unlike the other methods, rarely hit exactly.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import OptimError
from frictionid_core.optim._engine import PopulationRun, check_count, check_fraction
from frictionid_core.optim.problem import OptimResult, Problem


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    pop: int = 50,
    generations: int = 100,
    blend: float = 0.5,
    mutation_rate: float = 0.01,
    elites: int = 2,
) -> OptimResult:
    """Minimise ``problem`` with BBO (sinusoidal migration, blended partial immigration).

    Args:
        pop: number of habitats (>= elites + 1, >= 2).
        generations: generations including the initial one;
            nfev = pop + (generations - 1) * (pop - elites).
        blend: weight of the immigrating habitat's own value in blended migration, [0, 1].
        mutation_rate: per-SIV probability of a uniform redraw.
        elites: best habitats kept unchanged.
    """
    pop = check_count(pop, "pop", "bbo", minimum=2)
    generations = check_count(generations, "generations", "bbo")
    blend = check_fraction(blend, "blend", "bbo")
    mutation_rate = check_fraction(mutation_rate, "mutation_rate", "bbo")
    if isinstance(elites, bool) or not isinstance(elites, (int, np.integer)) or not 0 <= elites <= pop - 1:
        raise OptimError(f"bbo: elites must be a whole number in [0, pop - 1 = {pop - 1}], got {elites!r}")
    k = problem.k
    run = PopulationRun(problem, "bbo", generations)
    species = (pop - 1 - np.arange(pop)) / (pop - 1)  # 1 for the best habitat, 0 for the worst
    immigration = 0.5 * (np.cos(np.pi * species) + 1.0)
    emigration_cdf = np.cumsum(0.5 * (1.0 - np.cos(np.pi * species)))
    emigration_cdf /= emigration_cdf[-1]
    genes = np.arange(k)[None, :]

    u = run.initial(rng, pop)
    f = run.evaluate(u)
    run.record(u)
    for _ in range(1, generations):
        order = np.argsort(f, kind="stable")
        u, f = u[order], f[order]  # best first, matching the rate tables
        immigrate = rng.random((pop, k)) < immigration[:, None]
        source = np.minimum(np.searchsorted(emigration_cdf, rng.random((pop, k)), side="right"), pop - 1)
        z = np.where(immigrate, blend * u + (1.0 - blend) * u[source, genes], u)
        z = np.where(rng.random((pop, k)) < mutation_rate, rng.random((pop, k)), z)
        z[:elites] = u[:elites]
        f_new = run.evaluate(z[elites:])
        u = z
        f = np.concatenate((f[:elites], f_new))
        run.record(u)
    return run.result(
        f"sinusoidal migration, blend {blend:g}, mutation {mutation_rate:g}, {elites} elites, "
        f"{generations} generations x {pop} habitats"
    )
