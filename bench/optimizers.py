#!/usr/bin/env python
"""Optimiser benchmark: frictionid's population methods vs scipy, pymoo and mealpy.

    .venv/bin/python bench/optimizers.py            # full: 2 models x 5 seeds x 100 generations
    .venv/bin/python bench/optimizers.py --quick    # smoke: tustin-asym, 1 seed, 20 generations
    .venv/bin/python bench/optimizers.py --seeds 21 # more seeds: is a cost difference real?

EMPS estimation bag, ``tustin`` asymmetric and ``stribeck`` symmetric. Every method gets the
thesis budget (population 50 x 100 generations, the initial one included = 5000 evaluations),
the model's bounds and the model's cost:

* frictionid ga/aco/bbo/de/pso: ``minimize(Problem(..., model.batch_cost), method)``;
* scipy ``differential_evolution`` (this venv): rand1bin, F 0.4, CR 0.9, an initial population
  of exactly 50, maxiter = generations - 1, polish off, tol 0 (full budget), vectorized with
  updating='deferred' so each generation is one ``model.batch_cost`` call;
* pymoo GA/DE/PSO (bench/.venv-peers, numpy 2, frictionid_core on the path): a vectorised
  pymoo Problem whose _evaluate is ``model.batch_cost``;
* mealpy BaseGA/OriginalACOR/OriginalBBO/OriginalDE/OriginalPSO (bench/.venv-mealpy, numpy
  1.26): one candidate per call, as mealpy requires, to the cost rebuilt from exported arrays
  by ``_mealpy_worker.py`` (checked against ``model.batch_cost`` before any timing).

Peer settings follow the thesis settings wherever the peer has the same knob (DE F/CR/rand/1/bin,
PSO inertia/learning rates, GA crossover/mutation rates, BBO mutation/elites, ACO_R archive,
q and xi); everything else is the peer's default. Each peer runs in its own process; every
implementation gets one untimed warm-up run per algorithm first. Wall times are medians over
seeds measured around the optimiser call (process start, imports and data loading excluded).

Also: "time to quality" (C* = best final cost of any run on the model; the variable-projection
``solve_model(model, SolverOptions("lm", varpro=True))`` path vs mealpy DE) and, in full mode, bo/dt with
100 calls (first 3 seeds). Results: bench/results/optimizers.{json,txt} (quick: optimizers_quick;
--seeds N other than 5: optimizers_Nseeds). A two-sided Mann-Whitney U p-value tells whether
our final costs and mealpy's differ at all.
The peer venvs are created on first use from requirements-peers.txt / requirements-mealpy.txt;
a peer that cannot be installed or imported is reported as unavailable.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
BAG = ROOT / "bags" / "emps_estimation"
RESULTS = BENCH / "results"
MODELS = {"tustin-asym": ("tustin", True), "stribeck": ("stribeck", False)}
ALGOS = ("ga", "aco", "bbo", "de", "pso")
POP, GENERATIONS, SEEDS = 50, 100, (0, 1, 2, 3, 4)
IMPLS = ("frictionid", "scipy", "pymoo", "mealpy")

# project targets
MEALPY_SPEEDUP = 8.0       # each population method >= 8x faster than the same mealpy algorithm
COST_TOL = 0.01            # ... with a median final cost no worse than mealpy's + 1 %
VARPRO_SPEEDUP = 20.0      # variable projection (start sample + lm) >= 20x faster than mealpy DE
QUALITY_TOL = 1e-3         # ... reaching C* within 0.1 %
BO_MAX_S, DT_MAX_S = 30.0, 15.0

SCIPY_DE = dict(strategy="rand1bin", mutation=0.4, recombination=0.9, polish=False,
                updating="deferred", vectorized=True, tol=0.0, atol=0.0)
PYMOO_SETTINGS = {
    "ga": {},  # pymoo defaults: tournament, SBX, polynomial mutation, duplicate elimination
    "de": {"variant": "DE/rand/1/bin", "F": 0.4, "CR": 0.9},
    "pso": {"w": 0.25, "c1": 2.5, "c2": 2.5, "adaptive": False},
}
MEALPY_SETTINGS = {
    # selection stays mealpy's default (tournament): its roulette for minimisation loops forever
    # (`while id_c2 == id_c1`) once a single member holds all the probability, as happens here.
    "ga": {"pc": 0.8, "pm": 0.02, "crossover": "one_point"},
    "aco": {"sample_count": POP, "intent_factor": 0.04, "zeta": 0.9},
    "bbo": {"p_m": 0.01, "n_elites": 2},
    "de": {"wf": 0.4, "cr": 0.9, "strategy": 0},
    "pso": {"c1": 2.5, "c2": 2.5, "w": 0.25},
}
PYMOO_ALGOS = ("ga", "de", "pso")
SUBPROCESS_TIMEOUT = 3600
RUN_TIMEOUT = 300  # s, one mealpy run (a hung peer run is left out, not waited for)


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def median(values):
    values = [v for v in values if v is not None]
    return float(statistics.median(values)) if values else None


# ----------------------------------------------------------------------------- venvs
def _base_python() -> str:
    return getattr(sys, "_base_executable", None) or sys.executable


def ensure_venv(name: str, requirements: Path, *, install: bool, post=None) -> tuple[Path | None, str | None]:
    """bench/.venv-<name> built from ``requirements`` (rebuilt when the file changes).
    Returns (python, None) or (None, reason)."""
    venv = BENCH / f".venv-{name}"
    py = venv / "bin" / "python"
    stamp = venv / ".bench-stamp"
    want = hashlib.sha256(requirements.read_bytes()).hexdigest()
    if py.exists() and stamp.exists() and stamp.read_text() == want:
        return py, None
    if not install:
        return None, f"{venv.name} missing or out of date (run without --no-install to create it)"
    log(f"[setup] creating {venv.relative_to(ROOT)} from {requirements.name} (first run only) ...")
    install_log = venv / "install.log"
    try:
        if not py.exists():
            subprocess.run([_base_python(), "-m", "venv", str(venv)], check=True, capture_output=True, timeout=600)
        with open(install_log, "w") as fh:
            r = subprocess.run([str(py), "-m", "pip", "install", "-r", str(requirements)], stdout=fh,
                               stderr=subprocess.STDOUT, timeout=3600)
        if r.returncode:
            return None, f"pip install -r {requirements.name} failed (see {install_log.relative_to(ROOT)})"
        if post is not None:
            post(py)
        stamp.write_text(want)
    except Exception as exc:
        return None, f"cannot create {venv.name}: {exc}"
    return py, None


def _add_core_to_path(py: Path) -> None:
    """Put frictionid_core/src on the peers venv's path (same code as the product venv)."""
    purelib = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             check=True, capture_output=True, text=True).stdout.strip()
    Path(purelib, "frictionid_core_src.pth").write_text(str(ROOT / "frictionid_core" / "src") + "\n")


def run_worker(cmd: list[str], what: str) -> tuple[bool, str]:
    log(f"[{what}] {' '.join(Path(c).name if i < 2 else c for i, c in enumerate(cmd))}")
    try:
        r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    except subprocess.TimeoutExpired:
        return False, f"{what} timed out after {SUBPROCESS_TIMEOUT} s"
    if r.returncode:
        tail = (r.stderr or r.stdout).strip().splitlines()[-6:]
        return False, f"{what} failed (exit {r.returncode}): " + " | ".join(tail)
    return True, ""


# ----------------------------------------------------------------------------- histories
def time_to_reach(history, wall: float, generations: int, target: float):
    """Wall time at which the best-so-far first reached ``target``, assuming generations take
    equal time (history entries are the last len(history) generations); None if never."""
    if not history:
        return None
    h = np.asarray([np.inf if v is None else v for v in history], dtype=float)
    hit = np.flatnonzero(h <= target)
    if not hit.size:
        return None
    offset = generations - len(h)
    return wall * (int(hit[0]) + 1 + offset) / generations


# ----------------------------------------------------------------------------- frictionid
def run_ours(model, generations: int, seeds) -> dict:
    from frictionid_core.optim import Problem, minimize

    lo, hi = model.bounds()
    problem = Problem(list(model.names), lo, hi, model.batch_cost, residuals=model.residuals)
    out = {}
    for algo in ALGOS:
        minimize(problem, algo, seed=999, pop=POP, generations=3)  # warm-up
        runs = []
        for s in seeds:
            c0, t0 = time.process_time(), time.perf_counter()
            res = minimize(problem, algo, seed=s, pop=POP, generations=generations)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            runs.append({"seed": s, "fun": float(res.fun), "wall_s": wall, "cpu_s": cpu, "nfev": int(res.nfev),
                         "x": [float(v) for v in res.x], "history_fmin": [float(v) for v in res.history_fmin]})
        out[algo] = runs
    return out


def run_scipy(model, generations: int, seeds) -> dict:
    import scipy
    from scipy.optimize import differential_evolution

    lo, hi = model.bounds()

    rows = [0]

    def func(x):  # vectorized: x is (k, S)
        rows[0] += x.shape[1]
        return model.batch_cost(x.T)

    def once(seed, gens):
        rng = np.random.default_rng(seed)
        init = lo + rng.random((POP, model.k)) * (hi - lo)
        hist = []
        rows[0] = 0

        def cb(intermediate_result):
            hist.append(float(intermediate_result.fun))

        c0, t0 = time.process_time(), time.perf_counter()
        res = differential_evolution(func, list(zip(lo, hi)), maxiter=gens - 1, init=init, rng=rng,
                                     callback=cb, **SCIPY_DE)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        return {"seed": seed, "fun": float(res.fun), "wall_s": wall, "cpu_s": cpu, "nfev": rows[0],
                "x": [float(v) for v in res.x], "history_fmin": hist}

    once(999, 3)
    runs = [once(s, generations) for s in seeds]
    return {"version": scipy.__version__, "runs": {"de": runs}}


# ----------------------------------------------------------------------------- pymoo
def pymoo_worker(job_path: str, out_path: str) -> None:
    """Runs inside bench/.venv-peers."""
    import pymoo
    from pymoo.algorithms.soo.nonconvex.de import DE
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.algorithms.soo.nonconvex.pso import PSO
    from pymoo.core.callback import Callback
    from pymoo.core.problem import Problem as PymooProblem
    from pymoo.optimize import minimize as pminimize

    from frictionid_core.identification import build_model
    from frictionid_core.io import load

    try:
        from pymoo.config import Config
        Config.warnings["not_compiled"] = False
    except Exception:
        pass
    job = json.load(open(job_path))
    series = load(job["bag"])
    out = {"version": pymoo.__version__, "numpy": np.__version__, "models": {}}
    make = {"ga": lambda: GA(pop_size=POP, **PYMOO_SETTINGS["ga"]),
            "de": lambda: DE(pop_size=POP, **PYMOO_SETTINGS["de"]),
            "pso": lambda: PSO(pop_size=POP, **PYMOO_SETTINGS["pso"])}

    class Hist(Callback):
        def __init__(self):
            super().__init__()
            self.h = []

        def notify(self, algorithm):
            self.h.append(float(algorithm.opt.get("F").min()))

    for label in job["models"]:
        fr, asym = MODELS[label]
        model = build_model(series, "emps", fr, asym)
        chk = job["check"][label]
        got = model.batch_cost(np.array(chk["x"]))
        ref = np.array(chk["cost"])
        lo, hi = model.bounds()

        class Prob(PymooProblem):
            def __init__(self, model, lo, hi):
                super().__init__(n_var=model.k, n_obj=1, xl=lo, xu=hi)
                self.model = model

            def _evaluate(self, X, out, *args, **kwargs):
                out["F"] = self.model.batch_cost(X)[:, None]

        prob = Prob(model, lo, hi)
        res_m = {"check_max_rel_diff": float(np.max(np.abs(got - ref) / np.abs(ref))),
                 "check_identical": bool(np.array_equal(got, ref)), "runs": {}}
        for algo in job["algos"]:
            pminimize(prob, make[algo](), ("n_gen", 3), seed=999, verbose=False)  # warm-up
            runs = []
            for s in job["seeds"]:
                cb = Hist()
                c0, t0 = time.process_time(), time.perf_counter()
                res = pminimize(prob, make[algo](), ("n_gen", job["generations"]), seed=s, verbose=False, callback=cb)
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                runs.append({"seed": s, "fun": float(np.min(res.F)), "wall_s": wall, "cpu_s": cpu,
                             "nfev": int(res.algorithm.evaluator.n_eval),
                             "x": [float(v) for v in np.atleast_2d(res.X)[0]], "history_fmin": cb.h})
            res_m["runs"][algo] = runs
            log(f"  pymoo {label} {algo}: median {median(r['wall_s'] for r in runs):.3f} s")
        out["models"][label] = res_m
    json.dump(out, open(out_path, "w"))


class PeerUnavailable(Exception):
    """A peer could not be installed, imported, checked or run."""


class PymooPeer:
    """pymoo GA/DE/PSO in bench/.venv-peers, one worker process per round of seeds."""

    name = "pymoo"

    def __init__(self, labels, models, generations, install, tmp):
        self.labels, self.models, self.generations, self.install, self.tmp = labels, models, generations, install, tmp
        self.info = {"settings": PYMOO_SETTINGS}

    def setup(self) -> None:
        py, reason = ensure_venv("peers", BENCH / "requirements-peers.txt", install=self.install,
                                 post=_add_core_to_path)
        if py is None:
            raise PeerUnavailable(reason)
        self.py = py
        self.checks = {}
        for lb in self.labels:
            pts = check_points(self.models[lb])
            self.checks[lb] = {"x": pts.tolist(), "cost": self.models[lb].batch_cost(pts).tolist()}

    def run(self, seeds) -> dict:
        job = {"bag": str(BAG), "models": self.labels, "algos": list(PYMOO_ALGOS), "seeds": list(seeds),
               "generations": self.generations, "check": self.checks}
        jp, op = self.tmp / "pymoo_job.json", self.tmp / "pymoo_out.json"
        jp.write_text(json.dumps(job))
        ok, reason = run_worker([str(self.py), str(Path(__file__).resolve()), "--pymoo-worker", str(jp), str(op)],
                                f"pymoo seeds {list(seeds)}")
        if not ok:
            raise PeerUnavailable(reason)
        out = json.loads(op.read_text())
        bad = {m: v["check_max_rel_diff"] for m, v in out["models"].items() if v["check_max_rel_diff"] > 1e-12}
        if bad:
            raise PeerUnavailable(f"cost in the peers venv differs from model.batch_cost: {bad}")
        self.info.update(version=out["version"], numpy=out["numpy"])
        self.info["models"] = {m: {k: v[k] for k in ("check_max_rel_diff", "check_identical")}
                               for m, v in out["models"].items()}
        return {m: v["runs"] for m, v in out["models"].items()}


# ----------------------------------------------------------------------------- mealpy
def export_cost(model, path: Path) -> None:
    """The arrays _mealpy_worker.py needs to recompute model.batch_cost without frictionid_core."""
    lo, hi = model.bounds()
    try:
        terms, dips, fixed, nd = model._terms, model._dips, model._fixed, model._nd
    except AttributeError as exc:
        raise RuntimeError(f"IdentificationModel internals changed ({exc}); update export_cost") from None
    arrays = {"friction": np.array(model.friction.name), "y": model.obs.y, "fixed": fixed,
              "linear_index": np.asarray(model.linear_index), "k": np.array(model.k), "nd": np.array(nd),
              "lower": lo, "upper": hi, "n_dips": np.array(len(dips))}
    for i, d in enumerate(dips):
        arrays[f"dip{i}_joint"] = np.array(d.joint)
        arrays[f"dip{i}_nl"] = np.asarray(d.nl_index, dtype=int)
        arrays[f"dip{i}_mask"] = d.mask
        arrays[f"dip{i}_speed"] = d.speed
    dip_terms = [(col, t.dip_branch, t.dip_sign) for col, t in enumerate(terms) if t.dip_branch is not None]
    arrays["dip_terms"] = np.array(dip_terms, dtype=float).reshape(-1, 3)
    np.savez(path, **arrays)


def check_points(model, n: int = 24, seed: int = 7) -> np.ndarray:
    lo, hi = model.bounds()
    rng = np.random.default_rng(seed)
    return np.vstack([lo + rng.random((n, model.k)) * (hi - lo), lo, hi, (lo + hi) / 2])


class MealpyPeer:
    """mealpy in bench/.venv-mealpy on the exported cost (checked against model.batch_cost first)."""

    name = "mealpy"

    def __init__(self, labels, models, generations, install, tmp, *, algos=ALGOS, pop=POP, cost_timing_calls=1000):
        self.labels, self.models, self.generations, self.install, self.tmp = labels, models, generations, install, tmp
        self.algos, self.pop, self.cost_timing_calls = tuple(algos), pop, cost_timing_calls
        self.info = {"settings": {a: MEALPY_SETTINGS[a] for a in self.algos}, "models": {}}
        self.worker = str(BENCH / "_mealpy_worker.py")

    def setup(self) -> None:
        py, reason = ensure_venv("mealpy", BENCH / "requirements-mealpy.txt", install=self.install)
        if py is None:
            raise PeerUnavailable(reason)
        self.py = py
        for label in self.labels:
            model = self.models[label]
            data = self.tmp / f"mealpy_{label}.npz"
            try:
                export_cost(model, data)
            except Exception as exc:
                raise PeerUnavailable(str(exc)) from None
            pts = check_points(model)
            np.save(self.tmp / "pts.npy", pts)
            ok, reason = run_worker([str(py), self.worker, "check", str(data), str(self.tmp / "pts.npy"),
                                     str(self.tmp / "chk.npy")], f"mealpy check {label}")
            if not ok:
                raise PeerUnavailable(reason)
            ref = model.batch_cost(pts)
            got = np.load(self.tmp / "chk.npy")
            rel = float(np.max(np.abs(got - ref[None, :]) / np.abs(ref)[None, :]))
            identical = bool(np.array_equal(got[0], ref) and np.array_equal(got[1], ref))
            log(f"  mealpy cost check {label}: {len(pts)} points, identical={identical}, max rel diff {rel:.2e}")
            if rel > 1e-12:
                raise PeerUnavailable(f"exported cost differs from model.batch_cost on {label} "
                                      f"(max rel diff {rel:.3e})")
            self.info["models"][label] = {"check_identical": identical, "check_max_rel_diff": rel,
                                          "check_points": len(pts), "cost_s_per_call_each_round": []}

    def run(self, seeds) -> dict:
        out = {}
        for label in self.labels:
            job = {"algos": list(self.algos), "seeds": list(seeds), "pop": self.pop, "generations": self.generations,
                   "settings": MEALPY_SETTINGS, "run_timeout_s": RUN_TIMEOUT,
                   "cost_timing_calls": self.cost_timing_calls}
            jp, op = self.tmp / "mealpy_job.json", self.tmp / f"mealpy_{label}.json"
            jp.write_text(json.dumps(job))
            ok, reason = run_worker([str(self.py), self.worker, "run", str(self.tmp / f"mealpy_{label}.npz"),
                                     str(jp), str(op)], f"mealpy {label} seeds {list(seeds)}")
            if not ok:
                raise PeerUnavailable(reason)
            res = json.loads(op.read_text())
            self.info["version"], self.info["numpy"] = res["mealpy"], res["numpy"]
            mi = self.info["models"][label]
            mi["cost_s_per_call_each_round"].append(res["cost_s_per_call"])
            mi["cost_s_per_call"] = median(mi["cost_s_per_call_each_round"])
            for algo, err in res.get("errors", {}).items():
                self.info.setdefault("errors", {})[f"{label}/{algo}"] = err
            out[label] = res["runs"]
        return out


# ----------------------------------------------------------------------------- varpro, bo, dt
def run_varpro(series, fr, asym, model, generations, seeds, warm_up: bool = True) -> dict:
    from frictionid_core.identification import SolverOptions, solve_model

    def once(seed):
        # Same footing as the peers: the prebuilt model's cost; the clock covers the whole
        # variable-projection solve (closed-form start sample + lm on vs/delta).
        t0 = time.perf_counter()
        x, opt = solve_model(model, SolverOptions("lm", seed, varpro=True))
        wall = time.perf_counter() - t0
        return {"seed": seed, "fun": float(model.batch_cost(x[None])[0]), "wall_s": wall,
                "optimizer_wall_s": opt.wall_s, "nfev": opt.nfev, "x": x.tolist()}

    try:
        if warm_up:
            once(999)  # warm-up (JIT, caches)
    except TypeError as exc:
        return {"available": False, "reason": f"SolverOptions(varpro=True) not supported: {exc}"}
    except Exception as exc:
        if "varpro" in str(exc):
            return {"available": False, "reason": f"SolverOptions(varpro=True) not supported yet: {exc}"}
        raise
    runs = [once(s) for s in seeds]
    return {"available": True, "runs": runs, "median_fun": median(r["fun"] for r in runs),
            "median_wall_s": median(r["wall_s"] for r in runs),
            "median_optimizer_wall_s": median(r["optimizer_wall_s"] for r in runs)}


def run_bo_dt(model, seeds) -> dict:
    from frictionid_core.optim import Problem, minimize

    lo, hi = model.bounds()
    problem = Problem(list(model.names), lo, hi, model.batch_cost, residuals=model.residuals)
    out = {}
    for method, limit in (("bo", BO_MAX_S), ("dt", DT_MAX_S)):
        minimize(problem, method, seed=999, calls=12)  # warm-up (imports)
        runs = []
        for s in seeds:
            t0 = time.perf_counter()
            res = minimize(problem, method, seed=s, calls=100)
            runs.append({"seed": s, "fun": float(res.fun), "wall_s": time.perf_counter() - t0, "nfev": int(res.nfev)})
        wall = median(r["wall_s"] for r in runs)
        out[method] = {"runs": runs, "median_wall_s": wall, "median_fun": median(r["fun"] for r in runs),
                       "target_s": limit, "pass": wall <= limit}
        log(f"  {method}: median {wall:.2f} s for 100 calls")
    return out


# ----------------------------------------------------------------------------- report
def fmt(v, spec=".4g", width=10):
    return f"{'-':>{width}}" if v is None else f"{v:>{width}{spec}}"


def summarise(runs: list[dict]) -> dict:
    return {"median_fun": median(r["fun"] for r in runs), "median_wall_s": median(r["wall_s"] for r in runs),
            "median_cpu_s": median(r.get("cpu_s") for r in runs),
            "min_wall_s": min(r["wall_s"] for r in runs),
            "nfev": median(r["nfev"] for r in runs), "seeds": len(runs)}


def report(res: dict, quick: bool) -> list[str]:
    lines = []
    p = lines.append
    gens = res["meta"]["generations"]
    meta = res["meta"]
    loads = [meta["loadavg_start"][0], *meta.get("loadavg_rounds", []), meta["loadavg_end"][0]]
    p(f"git {meta['git']}, {meta['cpus']} CPUs; 1-min load average during the run: "
      f"{min(loads):.1f} .. {max(loads):.1f}"
      + ("  (machine busy: absolute times inflated)" if max(loads) > 1.5 else ""))
    for label, m in res["models"].items():
        S = m["summary"]
        p("")
        p(f"== {label} ({m['k']} parameters): population {POP} x {gens} generations, "
          f"{res['meta']['n_seeds']} seed(s): median final cost | median wall s ==")
        p(f"{'algo':5}" + "".join(f"{impl:>24}" for impl in IMPLS))
        for algo in ALGOS:
            row = f"{algo:5}"
            for impl in IMPLS:
                s = S.get(impl, {}).get(algo)
                row += f"{'-':>24}" if s is None else f"{s['median_fun']:>13.6g} |{s['median_wall_s']:>8.3f}"
            p(row)
        p("")
        p("   our time / peer time             our cost / peer cost")
        peers = IMPLS[1:]
        p(f"{'algo':5}" + "".join(f"{x:>9}" for x in peers) + "   " + "".join(f"{x:>12}" for x in peers))
        for algo in ALGOS:
            ours = S["frictionid"][algo]
            tr, cr = "", ""
            for impl in peers:
                s = S.get(impl, {}).get(algo)
                tr += fmt(None if s is None else ours["median_wall_s"] / s["median_wall_s"], ".3f", 9)
                cr += fmt(None if s is None else ours["median_fun"] / s["median_fun"], ".6f", 12)
            p(f"{algo:5}{tr}   {cr}")
        # time to quality
        p("")
        p(f"time to quality: C* = {m['C_star']:.8g} (best final cost of any run: {m['C_star_by']}); "
          f"target C*·(1+{QUALITY_TOL:g})")
        p(f"{'impl/algo':18}{'reached':>9}{'median t_reach s':>18}{'median cost/C*-1':>18}")
        for impl in IMPLS:
            for algo in ALGOS:
                q = m["quality"].get(impl, {}).get(algo)
                if q is None:
                    continue
                p(f"{impl + '/' + algo:18}{q['reached']:>5}/{q['seeds']:<3}{fmt(q['median_t_reach_s'], '.3f', 18)}"
                  f"{fmt(q['median_rel_gap'], '.2e', 18)}")
        v = m.get("varpro", {})
        if v.get("available"):
            p(f"{'frictionid/varpro':18}{v['reached']:>5}/{len(v['runs']):<3}{fmt(v['median_wall_s'], '.3f', 18)}"
              f"{fmt(v['median_rel_gap'], '.2e', 18)}   (whole identify() call; its DE alone "
              f"{fmt(v.get('median_optimizer_wall_s'), '.3f', 0)} s)")
        else:
            p(f"frictionid/varpro: unavailable — {v.get('reason', 'not run')}")
    # targets
    p("")
    p(f"== targets: each population method >= {MEALPY_SPEEDUP:g}x faster than the same mealpy algorithm, "
      f"median cost <= mealpy's·(1+{COST_TOL:g}) ==")
    p(f"{'model':12}{'algo':5}{'ours s':>8}{'mealpy s':>10}{'speed-up':>10}{'':>6}{'(cpu)':>8}"
      f"{'cost ratio':>12}{'':>6}{'p(U)':>8}")
    for t in res["targets"]["mealpy"]:
        p(f"{t['model']:12}{t['algo']:5}{t['our_wall_s']:>8.3f}{t['mealpy_wall_s']:>10.3f}"
          f"{fmt(t['speedup'], '.1f', 9)}x{('PASS' if t['speed_pass'] else 'FAIL'):>6}"
          f"{fmt(t['speedup_cpu'], '.1f', 7)}x"
          f"{fmt(t['cost_ratio'], '.5f', 12)}{('PASS' if t['cost_pass'] else 'FAIL'):>6}"
          f"{fmt(t.get('cost_p_mannwhitney'), '.2f', 8)}")
    if not res["targets"]["mealpy"]:
        p("  (mealpy unavailable: no comparison)")
    else:
        p("  p(U): two-sided Mann-Whitney U p-value of the final costs, ours vs mealpy's (small: they differ)")
    p("")
    p(f"== target: varpro (start sample + lm) >= {VARPRO_SPEEDUP:g}x faster than mealpy DE "
      f"and within {QUALITY_TOL:.1%} of C* ==")
    for t in res["targets"]["varpro"]:
        p(f"{t['model']:12}" + (f"unavailable: {t['reason']}" if "reason" in t else
          f"varpro {t['varpro_wall_s']:.3f} s vs mealpy DE {fmt(t['mealpy_de_wall_s'], '.3f', 0)} s: "
          f"{fmt(t['speedup'], '.1f', 0)}x {'PASS' if t['speed_pass'] else 'FAIL'}; cost/C*-1 = "
          f"{t['rel_gap']:.2e} {'PASS' if t['quality_pass'] else 'FAIL'}"))
    if res.get("bo_dt"):
        p("")
        p("== bo / dt: 100 calls on tustin-asym ==")
        for meth, b in res["bo_dt"].items():
            p(f"{meth:4} median of {len(b['runs'])} seeds {b['median_wall_s']:.2f} s (target <= {b['target_s']:g} s: "
              f"{'PASS' if b['pass'] else 'FAIL'}), median cost {b['median_fun']:.6g}")
    elif not quick:
        p("bo/dt: not run")
    p("")
    for name, peer in res["peers"].items():
        if peer.get("available"):
            extra = f", numpy {peer['numpy']}" if "numpy" in peer else ""
            for lb, pm in peer.get("models", {}).items():
                if "check_max_rel_diff" in pm:
                    extra += (f"; {lb} cost check vs model.batch_cost: max rel diff {pm['check_max_rel_diff']:.1e}"
                              f"{' (bit-identical)' if pm.get('check_identical') else ''}")
                if "cost_s_per_call" in pm:
                    extra += f", cost alone {pm['cost_s_per_call'] * 1e6:.0f} us/call"
            p(f"peer {name}: {peer.get('version', '?')}{extra}")
            for what, err in peer.get("errors", {}).items():
                p(f"  {name} {what}: left out — {err}")
        else:
            p(f"peer {name}: UNAVAILABLE — {peer.get('reason')}")
    return lines


def analyse(res: dict) -> None:
    """Summaries, C*, time to quality, targets (in place)."""
    from scipy.stats import mannwhitneyu

    gens = res["meta"]["generations"]
    tmeal, tvar = [], []
    for label, m in res["models"].items():
        m["summary"] = {impl: {a: summarise(r) for a, r in algos.items()} for impl, algos in m["runs"].items()}
        finals = [(r["fun"], f"{impl}/{a} seed {r['seed']}") for impl, algos in m["runs"].items()
                  for a, rs in algos.items() for r in rs]
        v = m.get("varpro", {})
        if v.get("available"):
            finals += [(r["fun"], f"frictionid/varpro seed {r['seed']}") for r in v["runs"]]
        c_star, by = min(finals)
        m["C_star"], m["C_star_by"] = c_star, by
        target = c_star * (1 + QUALITY_TOL)
        m["quality"] = {}
        for impl, algos in m["runs"].items():
            for a, rs in algos.items():
                t = [time_to_reach(r.get("history_fmin"), r["wall_s"], gens, target) for r in rs]
                m["quality"].setdefault(impl, {})[a] = {
                    "reached": sum(x is not None for x in t), "seeds": len(rs),
                    "median_t_reach_s": median(t) if all(x is not None for x in t) else None,
                    "median_rel_gap": median(r["fun"] / c_star - 1 for r in rs)}
        if v.get("available"):
            v["median_rel_gap"] = median(r["fun"] / c_star - 1 for r in v["runs"])
            v["reached"] = sum(r["fun"] <= target for r in v["runs"])
        meal = m["summary"].get("mealpy", {})
        ours = m["summary"]["frictionid"]
        for a in ALGOS:
            if a in meal:
                sp = meal[a]["median_wall_s"] / ours[a]["median_wall_s"]
                cr = ours[a]["median_fun"] / meal[a]["median_fun"]
                # do the two samples of final costs differ at all? (two-sided Mann-Whitney U)
                p_u = float(mannwhitneyu([r["fun"] for r in m["runs"]["frictionid"][a]],
                                         [r["fun"] for r in m["runs"]["mealpy"][a]]).pvalue)
                spc = (meal[a]["median_cpu_s"] / ours[a]["median_cpu_s"]
                       if meal[a]["median_cpu_s"] and ours[a]["median_cpu_s"] else None)
                tmeal.append({"model": label, "algo": a, "speedup": sp, "speed_pass": sp >= MEALPY_SPEEDUP,
                              "speedup_cpu": spc, "our_wall_s": ours[a]["median_wall_s"],
                              "mealpy_wall_s": meal[a]["median_wall_s"],
                              "cost_ratio": cr, "cost_pass": cr <= 1 + COST_TOL, "cost_p_mannwhitney": p_u})
        if not v.get("available"):
            tvar.append({"model": label, "reason": v.get("reason", "not run")})
        else:
            md = meal.get("de", {}).get("median_wall_s")
            sp = None if md is None else md / v["median_wall_s"]
            tvar.append({"model": label, "varpro_wall_s": v["median_wall_s"], "mealpy_de_wall_s": md,
                         "speedup": sp, "speed_pass": sp is not None and sp >= VARPRO_SPEEDUP,
                         "rel_gap": v["median_rel_gap"], "quality_pass": v["median_rel_gap"] <= QUALITY_TOL})
    res["targets"] = {"mealpy": tmeal, "varpro": tvar}


# ----------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: tustin-asym, 1 seed, 20 generations")
    ap.add_argument("--no-install", action="store_true", help="do not create missing peer venvs")
    ap.add_argument("--no-peers", action="store_true", help="frictionid (and scipy) only")
    ap.add_argument("--seeds", type=int, default=len(SEEDS), help=f"seeds 0..N-1 per method (default {len(SEEDS)})")
    ap.add_argument("--out", type=Path, help="JSON output (default bench/results/optimizers[_quick].json)")
    ap.add_argument("--pymoo-worker", nargs=2, metavar=("JOB", "OUT"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.pymoo_worker:
        pymoo_worker(*a.pymoo_worker)
        return 0

    import scipy

    import frictionid_core
    from frictionid_core.identification import build_model
    from frictionid_core.io import load

    labels = ["tustin-asym"] if a.quick else list(MODELS)
    if a.seeds < 1:
        ap.error(f"--seeds must be positive, got {a.seeds}")
    seeds = [0] if a.quick else list(range(a.seeds))
    gens = 20 if a.quick else GENERATIONS
    name = "optimizers_quick" if a.quick else "optimizers" if a.seeds == len(SEEDS) else f"optimizers_{a.seeds}seeds"
    out_path = a.out or RESULTS / f"{name}.json"
    series = load(str(BAG))
    models = {lb: build_model(series, "emps", *MODELS[lb]) for lb in labels}
    bc = type(models[labels[0]]).batch_cost
    res = {"meta": {"date": time.strftime("%Y-%m-%dT%H:%M:%S"), "quick": a.quick, "pop": POP, "generations": gens,
                    "seeds": seeds, "n_seeds": len(seeds), "bag": str(BAG.relative_to(ROOT)),
                    "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
                    "cpus": os.cpu_count(), "machine": platform.machine(),
                    "frictionid_core": getattr(frictionid_core, "__version__", "?"),
                    "batch_cost": f"{bc.__module__}.{bc.__qualname__}",
                    "git": _git_head(), "loadavg_start": os.getloadavg()},
           "models": {}, "peers": {}}
    for lb in labels:
        m = models[lb]
        m.batch_cost(check_points(m))  # warm-up (JIT)
        res["models"][lb] = {"k": m.k, "names": list(m.names), "runs": {}}

    with tempfile.TemporaryDirectory(prefix="bench-optim-") as td:
        tmp = Path(td)
        peers = []
        if not a.no_peers:
            for cls in (PymooPeer, MealpyPeer):
                peer = cls(labels, models, gens, not a.no_install, tmp)
                try:
                    peer.setup()
                    peers.append(peer)
                except PeerUnavailable as exc:
                    res["peers"][peer.name] = {"available": False, "reason": str(exc)}
                except Exception as exc:
                    traceback.print_exc()
                    res["peers"][peer.name] = {"available": False, "reason": f"{type(exc).__name__}: {exc}"}
        # Round robin over seeds: every implementation runs seed s before any runs seed s+1, so a
        # load change on the shared machine hits all of them alike.
        collected = {lb: {} for lb in labels}
        res["meta"]["loadavg_rounds"] = []
        for rnd, seed in enumerate(seeds):
            res["meta"]["loadavg_rounds"].append(os.getloadavg()[0])
            for lb in labels:
                log(f"[seed {seed}] {lb}: frictionid, scipy, varpro")
                for algo, runs in run_ours(models[lb], gens, [seed]).items():
                    collected[lb].setdefault("frictionid", {}).setdefault(algo, []).extend(runs)
                if res["peers"].get("scipy", {}).get("available", True):
                    try:
                        sc = run_scipy(models[lb], gens, [seed])
                        collected[lb].setdefault("scipy", {}).setdefault("de", []).extend(sc["runs"]["de"])
                        res["peers"]["scipy"] = {"available": True, "version": sc["version"], "numpy": np.__version__,
                                                 "settings": dict(SCIPY_DE)}
                    except Exception as exc:
                        res["peers"]["scipy"] = {"available": False, "reason": f"{type(exc).__name__}: {exc}"}
                        for c in collected.values():
                            c.pop("scipy", None)
                fr, asym = MODELS[lb]
                v = run_varpro(series, fr, asym, models[lb], gens, [seed], warm_up=rnd == 0)
                old = res["models"][lb].get("varpro")
                if old is None or not v.get("available"):
                    res["models"][lb]["varpro"] = v
                else:
                    old["runs"] += v["runs"]
            for peer in list(peers):
                try:
                    got = peer.run([seed])
                except PeerUnavailable as exc:
                    res["peers"][peer.name] = {"available": False, "reason": str(exc)}
                    peers.remove(peer)
                    for lb in labels:
                        collected[lb].pop(peer.name, None)
                    continue
                for lb in labels:
                    for algo, runs in got[lb].items():
                        collected[lb].setdefault(peer.name, {}).setdefault(algo, []).extend(runs)
        for peer in peers:
            res["peers"][peer.name] = {"available": True, **peer.info}
        for lb in labels:
            res["models"][lb]["runs"] = collected[lb]
            v = res["models"][lb].get("varpro", {})
            if v.get("available"):
                v["median_fun"] = median(r["fun"] for r in v["runs"])
                v["median_wall_s"] = median(r["wall_s"] for r in v["runs"])
                v["median_optimizer_wall_s"] = median(r["optimizer_wall_s"] for r in v["runs"])
            for impl, algos in collected[lb].items():
                for algo, runs in algos.items():
                    log(f"  {lb} {impl} {algo}: median {median(r['wall_s'] for r in runs):.3f} s")
        if not a.quick:
            log("[bo/dt] tustin-asym, 100 calls")
            lb = "tustin-asym"
            try:
                res["bo_dt"] = run_bo_dt(models[lb], seeds[:3])
            except Exception as exc:
                res["bo_dt_error"] = f"{type(exc).__name__}: {exc}"
    res["meta"]["loadavg_end"] = os.getloadavg()
    analyse(res)
    lines = report(res, a.quick)
    print("\n".join(lines))
    res["report"] = lines
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(json.dumps(res, indent=1))
    out_path.with_suffix(".txt").write_text("\n".join(res["report"]) + "\n")
    print(f"\nwritten {out_path.relative_to(ROOT) if out_path.is_relative_to(ROOT) else out_path} (+ .txt)")
    return 0


def _git_head() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              timeout=10).stdout.strip()
    except Exception:
        return "?"


if __name__ == "__main__":
    sys.exit(main())
