"""mealpy side of ``bench/optimizers.py`` (runs in bench/.venv-mealpy: mealpy 3.0.3, numpy 1.26).

mealpy 3.0.3 pins numpy <= 1.26.0, so this process cannot import frictionid_core. It gets the
identification cost as DATA: ``optimizers.py`` exports the decimated observation and the
model's structure (fixed design columns, linear parameter indices, the nonlinear "dip" terms)
to an .npz, and :func:`batch_cost` below recomputes ``IdentificationModel.batch_cost`` with
the same numpy operations in the same order. ``optimizers.py`` checks the two agree (``check``
mode) before any timing.

    python _mealpy_worker.py check DATA.npz POINTS.npy OUT.npy
    python _mealpy_worker.py run   DATA.npz JOB.json   OUT.json

JOB: {"algos": [...], "seeds": [...], "pop": 50, "generations": 100, "settings": {algo: {...}}}
(optional: "run_timeout_s", "cost_timing_calls": calls timing the cost alone, default 1000).
Each run gets ``epoch = generations - 1`` (mealpy evaluates the initial population, then
``pop`` new candidates per epoch) and one candidate per cost call, as mealpy requires.
"""

from __future__ import annotations

import json
import signal
import sys
import time

import numpy as np

_E3 = 1.0 - np.exp(-3.0)


class ExportedCost:
    """Sum of squared torque residuals, rebuilt from ``IdentificationModel`` arrays."""

    def __init__(self, path: str) -> None:
        d = np.load(path, allow_pickle=False)
        self.friction = str(d["friction"])
        self.y = d["y"]
        self.fixed_T = np.ascontiguousarray(d["fixed"].T)  # model: coef @ self._fixed.T
        self.linear_index = d["linear_index"]
        self.k = int(d["k"])
        self.nd = int(d["nd"])
        self.lower, self.upper = d["lower"], d["upper"]
        n_dips = int(d["n_dips"])
        self.dips = [(int(d[f"dip{i}_joint"]), d[f"dip{i}_nl"], d[f"dip{i}_mask"], d[f"dip{i}_speed"])
                     for i in range(n_dips)]
        # (column in coef, dip id, sign) in the model's term order
        self.dip_terms = [(int(c), int(b), float(s)) for c, b, s in d["dip_terms"]]

    def _shape(self, theta_nl: np.ndarray, speed: np.ndarray) -> np.ndarray:
        a = np.asarray(speed, dtype=float)[None, :]
        t = np.atleast_2d(theta_nl)
        if self.friction == "threlfall":
            v0 = t[:, 0:1]
            with np.errstate(over="ignore", invalid="ignore"):
                g = (1.0 - np.exp(-3.0 * a / v0)) / _E3
            return np.where(a <= v0, 1.0 - g, 0.0)
        if self.friction == "tustin":
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                return np.exp(-(a / t[:, 0:1]))
        if self.friction == "stribeck":
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                return np.exp(-((a / t[:, 0:1]) ** t[:, 1:2]))
        raise ValueError(f"no dip for friction law {self.friction!r}")

    def batch_cost(self, params: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(np.asarray(params, dtype=float))
        coef = p[:, self.linear_index]
        pred = coef @ self.fixed_T
        if self.dips:
            dipcols = [self._shape(p[:, nl], speed) * mask[None, :] for (_, nl, mask, speed) in self.dips]
            nd = self.nd
            for col, b, sign in self.dip_terms:
                j = self.dips[b][0]
                pred[:, j * nd:(j + 1) * nd] += sign * coef[:, col][:, None] * dipcols[b]
        r = self.y[None, :] - pred
        return np.einsum("pr,pr->p", r, r)


def _algorithm(name: str, epoch: int, pop: int, settings: dict):
    from mealpy import ACOR, BBO, DE, GA, PSO

    cls = {"ga": GA.BaseGA, "aco": ACOR.OriginalACOR, "bbo": BBO.OriginalBBO,
           "de": DE.OriginalDE, "pso": PSO.OriginalPSO}[name]
    return cls(epoch=epoch, pop_size=pop, **settings)


def run(data: str, job_path: str, out_path: str) -> None:
    import mealpy
    from mealpy import FloatVar

    job = json.load(open(job_path))
    cost = ExportedCost(data)
    calls = [0]

    def obj(x):
        calls[0] += 1
        return float(cost.batch_cost(x[None, :])[0])

    problem = {"bounds": FloatVar(lb=cost.lower.tolist(), ub=cost.upper.tolist()),
               "minmax": "min", "obj_func": obj, "log_to": None}
    pop, gens = int(job["pop"]), int(job["generations"])
    # time of the cost alone, per candidate (to split mealpy's own overhead from the cost)
    rng = np.random.default_rng(0)
    n_timing = int(job.get("cost_timing_calls", 1000))
    pts = cost.lower + rng.random((n_timing, cost.k)) * (cost.upper - cost.lower)
    for x in pts[:100]:
        obj(x)
    t0 = time.perf_counter()
    for x in pts:
        obj(x)
    cost_per_call = (time.perf_counter() - t0) / len(pts)
    out = {"mealpy": mealpy.__version__, "numpy": np.__version__, "cost_s_per_call": cost_per_call,
           "settings": job["settings"], "runs": {}}
    limit = int(job.get("run_timeout_s", 300))

    def on_alarm(signum, frame):
        raise TimeoutError(f"a run took more than {limit} s")

    signal.signal(signal.SIGALRM, on_alarm)
    for name in job["algos"]:
        settings = job["settings"].get(name, {})
        runs, seed = [], "warm-up"
        try:
            signal.alarm(limit)
            _algorithm(name, 2, pop, settings).solve(problem, seed=12345)  # warm-up, untimed
            for seed in job["seeds"]:
                algo = _algorithm(name, gens - 1, pop, settings)
                calls[0] = 0
                signal.alarm(limit)
                c0, t0 = time.process_time(), time.perf_counter()
                best = algo.solve(problem, seed=int(seed))
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                signal.alarm(0)
                hist = [float(v) for v in algo.history.list_global_best_fit]
                runs.append({"seed": int(seed), "fun": float(best.target.fitness), "wall_s": wall, "cpu_s": cpu,
                             "nfev": calls[0], "x": [float(v) for v in best.solution], "history_fmin": hist})
        except Exception as exc:
            signal.alarm(0)
            out.setdefault("errors", {})[name] = f"seed {seed}: {type(exc).__name__}: {exc}"
            print(f"mealpy {name}: {out['errors'][name]}", file=sys.stderr, flush=True)
            continue
        out["runs"][name] = runs
        print(f"mealpy {name}: done", file=sys.stderr, flush=True)
    json.dump(out, open(out_path, "w"))


def check(data: str, points: str, out: str) -> None:
    cost = ExportedCost(data)
    x = np.load(points)
    # both the vectorised form and the one-candidate-at-a-time form mealpy uses
    np.save(out, np.stack([cost.batch_cost(x), np.array([cost.batch_cost(r[None, :])[0] for r in x])]))


if __name__ == "__main__":
    mode, *args = sys.argv[1:]
    {"check": check, "run": run}[mode](*args)
