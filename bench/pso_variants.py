#!/usr/bin/env python
"""Why frictionid's PSO ends above mealpy's at 50 x 100: the algorithms differ, not the code.

    .venv/bin/python bench/pso_variants.py [--seeds 21]

frictionid's ``pso`` is the thesis's local-neighbourhood PSO (6 nearest particles, K_F 0.25,
mu 2.5, |v| clamped, particles stop at the walls). mealpy 3.0.3's ``OriginalPSO`` is another
algorithm: global best, a particle moves only when its new position is better (greedy),
components leaving the box are redrawn at random, and the velocity is never clamped. This
script runs our PSO with the thesis settings, then with the settings the thesis leaves open
(v_max, the neighbourhood topology; the neighbourhood stays local), then with the update rule
switched, one piece at a time, to mealpy's choices, on the EMPS costs of ``bench/optimizers.py``
(population 50 x 100 generations, seeds 0..N-1), and prints the median final costs beside
mealpy's medians from ``bench/results/optimizers_21seeds.json`` (run ``optimizers.py --seeds
21`` first). The mealpy-rule variants exist only here: the product keeps the thesis's PSO.
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import numpy as np

from frictionid_core.identification import build_model
from frictionid_core.io import load
from frictionid_core.optim import Problem, minimize
from frictionid_core.optim._engine import PopulationRun

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"tustin-asym": ("tustin", True), "stribeck": ("stribeck", False)}
W, MU = 0.25, 2.5  # the thesis's K_F and max learning rate (mealpy run with w 0.25, c1 = c2 2.5)


def variant_pso(problem: Problem, seed: int, *, greedy: bool, random_walls: bool, clamp: float | None,
                pop: int = 50, generations: int = 100) -> float:
    """Global-best PSO with mealpy's choices switchable; returns the best cost."""
    rng = np.random.default_rng(seed)
    run = PopulationRun(problem, "pso-variant", generations)
    k = problem.k
    x = run.initial(rng, pop)
    v = np.zeros((pop, k))
    f = run.evaluate(x)
    best_x, best_f = x.copy(), f.copy()
    run.record(x)
    for _ in range(1, generations):
        leader = best_x[np.argmin(best_f)]
        v = W * v + rng.random((pop, k)) * MU * (best_x - x) + rng.random((pop, k)) * MU * (leader - x)
        if clamp is not None:
            speed = np.linalg.norm(v, axis=1)
            v *= np.minimum(1.0, clamp * np.sqrt(k) / np.maximum(speed, 1e-300))[:, None]
        x_new = x + v
        outside = (x_new < 0.0) | (x_new > 1.0)
        if random_walls:
            x_new = np.where(outside, rng.random((pop, k)), x_new)
        else:
            x_new = np.clip(x_new, 0.0, 1.0)
            v[outside] = 0.0
        f_new = run.evaluate(x_new)
        improved = f_new < best_f
        best_x[improved], best_f[improved] = x_new[improved], f_new[improved]
        x = best_x.copy() if greedy else x_new
        run.record(x)
    return run.best_f


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=21)
    a = ap.parse_args(argv)
    seeds = range(a.seeds)
    ref_path = ROOT / "bench" / "results" / "optimizers_21seeds.json"
    ref = json.loads(ref_path.read_text()) if ref_path.exists() else None
    series = load(str(ROOT / "bags" / "emps_estimation"))
    # the thesis leaves v_max (and how the walls act) open; these keep its local neighbourhood
    thesis_choices = {
        "thesis pso (frictionid)": {},
        "  v_max 0.05": dict(v_max=0.05),
        "  v_max 0.1": dict(v_max=0.1),
        "  v_max 0.5": dict(v_max=0.5),
        "  ring neighbourhood": dict(topology="ring"),
        "  ring neighbourhood, v_max 0.1": dict(topology="ring", v_max=0.1),
    }
    mealpy_steps = {
        "global best, walls, clamp 0.2": dict(greedy=False, random_walls=False, clamp=0.2),
        "+ greedy moves": dict(greedy=True, random_walls=False, clamp=0.2),
        "+ random walls": dict(greedy=True, random_walls=True, clamp=0.2),
        "+ no clamp (mealpy's rule)": dict(greedy=True, random_walls=True, clamp=None),
    }
    print(f"median final cost over {a.seeds} seeds, population 50 x 100 generations")
    for label, (friction, asym) in MODELS.items():
        model = build_model(series, "emps", friction, asym)
        lo, hi = model.bounds()
        problem = Problem(list(model.names), lo, hi, model.batch_cost)
        print(f"\n{label}")
        for name, opts in thesis_choices.items():
            costs = [minimize(problem, "pso", seed=s, **opts).fun for s in seeds]
            print(f"  {name:32} {statistics.median(costs):10.1f}")
        for name, opts in mealpy_steps.items():
            costs = [variant_pso(problem, s, **opts) for s in seeds]
            print(f"  {name:32} {statistics.median(costs):10.1f}")
        if ref is not None:
            runs = ref["models"][label]["runs"].get("mealpy", {}).get("pso", [])
            if runs:
                print(f"  {'mealpy OriginalPSO (21 seeds)':32} {statistics.median(r['fun'] for r in runs):10.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
