"""Particle swarm optimisation with a local neighbourhood (thesis §3.2.5, Algorithm 5).

Thesis settings (tables 6.11, 6.16): swarm 50, 100 generations, constriction coefficient
K_F = 0.25, neighbourhood size 6, maximum learning rate mu_l = 2.5. Algorithm 5 / eq. 3-11
update the velocity as w v + phi1 (b - x) + phi2 (h - x) with phi1, phi2 ~ U[0, mu_l] per
dimension and clamp |v| <= v_max; the table's K_F is the only setting that can fill the
role of the velocity weight, so the default ``form="inertia"`` uses

    v <- K_F v + phi1 (b - x) + phi2 (h - x),   |v| <= v_max,   x <- x + v

(a constant inertia weight w = K_F; eq. 3-13 with w_min = w_max). ``form="clerc"`` is
the Clerc & Kennedy reading, v <- K_F [v + phi1 (b - x) + phi2 (h - x)]: with K_F = 0.25
that swarm contracts by ~0.5 per generation and stalls before reaching the optimum
(median error 0.56 on a 3-D sphere in [-5, 5]^3), so it is not the default.

* b is the particle's personal best; h is the best personal best among the particle itself
  and its ``neighbourhood`` neighbours. ``topology="nearest"`` (default) takes the 6
  particles nearest in the search space, as Algorithm 5 line 10 ("the P nearest
  neighbors of x_i") and Simon's reference code; ``topology="ring"`` takes 3 index
  neighbours on each side (lbest ring).
* v_max = ``v_max`` * sqrt(k) in bound-normalised units (a fraction of the box diagonal;
  Algorithm 5 lines 16-17 rescale v to that norm). Particles leaving the box are put on
  the wall and lose the velocity component that pushed them out.
* Velocities start at zero; generation 1 is the random initial swarm.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import OptimError
from frictionid_core.optim._engine import PopulationRun, check_count, check_fraction
from frictionid_core.optim.problem import OptimResult, Problem

TOPOLOGIES = ("nearest", "ring")
FORMS = ("inertia", "clerc")


def _ring_members(pop: int, size: int) -> np.ndarray:
    """(pop, size+1) indices: each particle and its ring neighbours (ceil(size/2) after it)."""
    after = (size + 1) // 2
    offsets = np.concatenate(([0], np.arange(1, after + 1), -np.arange(1, size - after + 1)))
    return (np.arange(pop)[:, None] + offsets[None, :]) % pop


def solve(
    problem: Problem,
    rng: np.random.Generator,
    *,
    pop: int = 50,
    generations: int = 100,
    constriction: float = 0.25,
    neighbourhood: int = 6,
    max_learning_rate: float = 2.5,
    topology: str = "nearest",
    v_max: float = 0.2,
    form: str = "inertia",
) -> OptimResult:
    """Minimise ``problem`` with a local-best PSO.

    Args:
        pop: swarm size (>= 2).
        generations: generations including the initial one; nfev = pop * generations.
        constriction: K_F in [0, 1]: inertia weight (form "inertia") or multiplier of the
            whole velocity update (form "clerc").
        neighbourhood: neighbours per particle (clipped to pop - 1).
        max_learning_rate: mu_l, upper end of the uniform phi1, phi2 draws.
        topology: "nearest" (search-space neighbours, thesis) or "ring" (index neighbours).
        v_max: velocity norm limit as a fraction of the normalised box diagonal.
        form: "inertia" (K_F as the weight w of eq. 3-11, default) or "clerc".
    """
    pop = check_count(pop, "pop", "pso", minimum=2)
    generations = check_count(generations, "generations", "pso")
    neighbourhood = min(check_count(neighbourhood, "neighbourhood", "pso"), pop - 1)
    constriction = check_fraction(constriction, "constriction", "pso")
    max_learning_rate = check_fraction(max_learning_rate, "max_learning_rate", "pso", 0.0, 10.0)
    v_max = check_fraction(v_max, "v_max", "pso", 0.0, 10.0)
    if topology not in TOPOLOGIES:
        raise OptimError(f"pso: topology must be one of {TOPOLOGIES}, got {topology!r}")
    if form not in FORMS:
        raise OptimError(f"pso: form must be one of {FORMS}, got {form!r}")
    k = problem.k
    run = PopulationRun(problem, "pso", generations)
    rows = np.arange(pop)
    v_limit = v_max * np.sqrt(k)
    ring = _ring_members(pop, neighbourhood) if topology == "ring" else None

    x = run.initial(rng, pop)
    v = np.zeros((pop, k))
    f = run.evaluate(x)
    best_x, best_f = x.copy(), f.copy()
    run.record(x)
    for _ in range(1, generations):
        if ring is None:
            sq = np.einsum("ij,ij->i", x, x)
            d2 = sq[:, None] + sq[None, :] - 2.0 * (x @ x.T)
            d2[rows, rows] = -np.inf  # the particle itself always belongs to its neighbourhood
            members = np.argpartition(d2, neighbourhood, axis=1)[:, : neighbourhood + 1]
        else:
            members = ring
        leader = members[rows, np.argmin(best_f[members], axis=1)]
        phi1 = rng.random((pop, k)) * max_learning_rate
        phi2 = rng.random((pop, k)) * max_learning_rate
        if form == "inertia":
            v = constriction * v + phi1 * (best_x - x) + phi2 * (best_x[leader] - x)
        else:
            v = constriction * (v + phi1 * (best_x - x) + phi2 * (best_x[leader] - x))
        speed = np.sqrt(np.einsum("ij,ij->i", v, v))
        too_fast = speed > v_limit
        if too_fast.any():
            v[too_fast] *= (v_limit / speed[too_fast])[:, None]
        x = x + v
        outside = (x < 0.0) | (x > 1.0)
        if outside.any():
            x = np.clip(x, 0.0, 1.0)
            v[outside] = 0.0
        f = run.evaluate(x)
        improved = f < best_f
        best_x[improved] = x[improved]
        best_f[improved] = f[improved]
        run.record(x)
    return run.result(
        f"{topology} neighbourhood {neighbourhood}, K_F {constriction:g} ({form}), "
        f"max learning rate {max_learning_rate:g}, {generations} generations x {pop} particles"
    )
