"""Statistical study of optimisers × friction models on the EMPS (thesis §6.3, docs/reference.md#statistical-study).

Each run identifies the IDM parameters with one population algorithm at the thesis budget
(50 × 100) on the estimation data, then reports the OSA torque relative error and the
closed-loop simulated position relative error on the estimation and validation data (true
and benchmark clocks). Runs are appended to ``DIR/runs.jsonl`` as they finish (a rerun skips
finished runs); :func:`analyse` turns them into the rank table, Friedman tests, pairwise
p-values and convergence curves.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from frictionid_core.errors import FrictionIdError
from frictionid_core.jsonfile import write_json

if TYPE_CHECKING:  # numpy and the optimisers are imported by the functions that use them
    import numpy as np

ALGORITHMS = ("de", "pso", "ga", "aco", "bbo")
RUNS_FILE = "runs.jsonl"

# progress(finished, total, elapsed_s): called after each finished run.
Progress = Callable[[int, int, float], None]


@dataclass(frozen=True)
class RunSpec:
    """One study run."""

    algorithm: str
    friction: str
    asymmetric: bool
    seed: int
    estimation: str
    validation: str
    pop: int = 50
    generations: int = 100

    @property
    def key(self) -> str:
        return f"{self.algorithm}|{self.friction}|{int(self.asymmetric)}|{self.seed}"


def plan(algorithms, frictions, seeds: int, estimation: str, validation: str, pop: int = 50,
         generations: int = 100) -> list[RunSpec]:
    """Every (algorithm, friction model, symmetric/asymmetric, seed) run."""
    return [RunSpec(a, f, asym, s, str(estimation), str(validation), pop, generations)
            for f in frictions for asym in (False, True) for a in algorithms for s in range(seeds)]


@lru_cache(maxsize=4)
def _series(path: str):
    from frictionid_core.io import load

    return load(path)


@lru_cache(maxsize=4)
def _emps(path: str):
    from frictionid_core.emps_simulation import load_emps

    return load_emps(path)


@lru_cache(maxsize=64)
def _simulator(path: str, friction: str, asymmetric: bool, clock: str):
    from frictionid_core.emps_simulation import EmpsSimulator

    return EmpsSimulator(_emps(path), friction, asymmetric, clock=clock)


def run_one(spec: RunSpec) -> dict:
    """Identify with ``spec`` and evaluate; returns one JSON-ready record."""
    from frictionid_core.identification import IdentifyRequest, SolverOptions, identify, validate

    t0 = time.perf_counter()
    solver = SolverOptions(spec.algorithm, spec.seed, pop=spec.pop, generations=spec.generations, warm_start=False)
    res = identify(_series(spec.estimation), IdentifyRequest(friction=spec.friction, asymmetric=spec.asymmetric,
                                                             solver=solver))
    record = asdict(spec) | {"key": spec.key, "params": res.params, "cost": res.metrics["cost"],
                             "osa_est_pct": res.metrics["relerr_pct"],
                             "osa_val_pct": validate(_series(spec.validation), res)["relerr_pct"],
                             "identify_s": res.wall_s,
                             "history_fmin": res.optimizer["history_fmin"],
                             "history_dist_mean": res.optimizer["history_dist_mean"]}
    for clock in ("true", "benchmark"):
        for tag, path in (("est", spec.estimation), ("val", spec.validation)):
            sim = _simulator(path, spec.friction, spec.asymmetric, clock)
            record[f"sim_{tag}_{clock}_pct"] = float(sim.position_relerr(sim.as_array(res.params))[0])
    record["wall_s"] = time.perf_counter() - t0
    return record


def _init_worker() -> None:
    os.environ.setdefault("FRICTIONID_THREADS", "1")  # one process per CPU: no kernel threads (parallel.py)


def finished_keys(out_dir: Path) -> set[str]:
    """Keys of the runs already in ``out_dir/runs.jsonl`` (a torn last line is ignored)."""
    path = Path(out_dir) / RUNS_FILE
    keys = set()
    if path.exists():
        for line in path.read_text().splitlines():
            try:
                keys.add(json.loads(line)["key"])
            except (json.JSONDecodeError, KeyError):
                continue
    return keys


def run_study(specs: list[RunSpec], out_dir: Path, *, workers: int | None = None, scheduler: str | None = None,
              progress: Progress | None = None) -> int:
    """Run the ``specs`` not finished yet in ``out_dir``; returns how many ran now.

    Local processes by default (all cores), or a Dask cluster at ``scheduler`` (tcp://host:port).
    Each finished run is appended and flushed at once: an interruption loses only the runs in flight.
    ``progress(finished, total, elapsed_s)`` is called after each run.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    done = finished_keys(out_dir)
    todo = [s for s in specs if s.key not in done]
    total, t0 = len(todo), time.perf_counter()
    if not todo:
        return 0
    path = out_dir / RUNS_FILE
    with open(path, "a", encoding="utf-8") as sink:
        if path.stat().st_size and not path.read_bytes().endswith(b"\n"):
            sink.write("\n")  # close a line torn by an interruption

        def write(record: dict, n: int) -> None:
            sink.write(json.dumps(record) + "\n")
            sink.flush()
            os.fsync(sink.fileno())
            if progress is not None:
                progress(n, total, time.perf_counter() - t0)

        if scheduler:
            _run_dask(todo, scheduler, write)
        else:
            _run_local(todo, workers or os.cpu_count() or 1, write)
    return total


def _run_local(todo: list[RunSpec], workers: int, write) -> None:
    if workers == 1:
        for n, spec in enumerate(todo, 1):
            write(run_one(spec), n)
        return
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker) as pool:
        pending = set()
        queue = iter(todo)
        n = 0
        for spec in queue:  # keep the pool busy but only ~2 runs per worker in flight
            pending.add(pool.submit(run_one, spec))
            if len(pending) >= 2 * workers:
                break
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                n += 1
                write(fut.result(), n)
                nxt = next(queue, None)
                if nxt is not None:
                    pending.add(pool.submit(run_one, nxt))


def _run_dask(todo: list[RunSpec], scheduler: str, write) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise FrictionIdError("--scheduler needs dask.distributed (pip install distributed)") from None
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise FrictionIdError(f"cannot reach the Dask scheduler at {scheduler} ({exc})") from None
    with client:
        futures = client.map(run_one, todo, pure=False)
        for n, fut in enumerate(as_completed(futures), 1):
            write(fut.result(), n)


# ------------------------------------------------------------------------------------ analysis
def load_runs(out_dir: Path) -> list[dict]:
    path = Path(out_dir) / RUNS_FILE
    if not path.exists():
        raise FrictionIdError(f"{path}: no runs yet (run 'frictionid study' first)")
    runs = []
    for line in path.read_text().splitlines():
        try:
            runs.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return runs


def _label(run: dict) -> str:
    return f"{run['friction']}{'-asym' if run['asymmetric'] else ''}"


def analyse(out_dir: Path, metric: str = "sim_val_true_pct") -> dict:
    """Rank table, Friedman tests (across algorithms and across models) and pairwise
    Wilcoxon p-values of ``metric`` over the runs in ``out_dir``; writes ``summary.json``."""
    import numpy as np
    from scipy import stats

    runs = load_runs(out_dir)
    algos = sorted({r["algorithm"] for r in runs})
    models = sorted({_label(r) for r in runs})
    seeds = sorted({r["seed"] for r in runs})
    value = {(r["algorithm"], _label(r), r["seed"]): r[metric] for r in runs}
    complete = [(m, s) for m in models for s in seeds if all((a, m, s) in value for a in algos)]
    table = {a: {} for a in algos}
    for a in algos:
        for m in models:
            vals = [value[(a, m, s)] for s in seeds if (a, m, s) in value]
            if vals:
                table[a][m] = {"median": float(np.median(vals)), "mean": float(np.mean(vals)),
                               "std": float(np.std(vals)), "best": float(np.min(vals)), "n": len(vals)}
    summary: dict = {"metric": metric, "algorithms": algos, "models": models, "n_runs": len(runs), "table": table}
    if len(algos) >= 2 and complete:
        block = np.array([[value[(a, m, s)] for a in algos] for m, s in complete])
        ranks = stats.rankdata(block, axis=1)
        summary["mean_rank"] = dict(zip(algos, map(float, ranks.mean(axis=0))))
        if len(algos) >= 3:
            f = stats.friedmanchisquare(*block.T)
            summary["friedman_algorithms"] = {"statistic": float(f.statistic), "pvalue": float(f.pvalue),
                                              "blocks": len(complete)}
        summary["pairwise_wilcoxon"] = {
            f"{a}~{b}": float(stats.wilcoxon(block[:, i], block[:, j]).pvalue)
            for i, a in enumerate(algos) for j, b in enumerate(algos) if i < j and np.any(block[:, i] != block[:, j])}
    blocks_m = [(a, s) for a in algos for s in seeds if all((a, m, s) in value for m in models)]
    if len(models) >= 3 and blocks_m:
        bm = np.array([[value[(a, m, s)] for m in models] for a, s in blocks_m])
        f = stats.friedmanchisquare(*bm.T)
        summary["friedman_models"] = {"statistic": float(f.statistic), "pvalue": float(f.pvalue), "blocks": len(blocks_m)}
        summary["model_mean_rank"] = dict(zip(models, map(float, stats.rankdata(bm, axis=1).mean(axis=0))))
    best = min(runs, key=lambda r: r[metric])
    summary["best_run"] = {k: best[k] for k in ("algorithm", "friction", "asymmetric", "seed", metric,
                                                "sim_val_benchmark_pct", "osa_est_pct")}
    write_json(Path(out_dir) / "summary.json", summary)
    return summary


def convergence(runs: list[dict]) -> dict[str, dict[str, np.ndarray]]:
    """Per algorithm: median over runs of f_min(G) normalised by each run's final cost, and mean dist_mean(G)."""
    import numpy as np

    out = {}
    for a in sorted({r["algorithm"] for r in runs}):
        mine = [r for r in runs if r["algorithm"] == a]
        n = min(len(r["history_fmin"]) for r in mine)
        f = np.array([np.asarray(r["history_fmin"][:n]) / r["history_fmin"][n - 1] for r in mine])
        d = np.array([np.asarray(r["history_dist_mean"][:n], dtype=float) for r in mine])
        out[a] = {"fmin_rel": np.median(f, axis=0), "dist_mean": np.nanmean(d, axis=0)}
    return out


def format_summary(summary: dict) -> str:
    """The rank table and the tests as text."""
    lines = [f"metric: {summary['metric']} (median over seeds, %)"]
    models = summary["models"]
    lines.append(f"{'algorithm':<10}" + "".join(f"{m:>16}" for m in models) + f"{'mean rank':>11}")
    for a in summary["algorithms"]:
        cells = "".join(f"{summary['table'][a].get(m, {}).get('median', float('nan')):>16.6g}" for m in models)
        lines.append(f"{a:<10}{cells}{summary.get('mean_rank', {}).get(a, float('nan')):>11.3g}")
    for key in ("friedman_algorithms", "friedman_models"):
        if key in summary:
            f = summary[key]
            lines.append(f"{key}: chi2 = {f['statistic']:.4g}, p = {f['pvalue']:.3g} ({f['blocks']} blocks)")
    if "pairwise_wilcoxon" in summary:
        lines.append("pairwise Wilcoxon p: " + ", ".join(f"{k} {v:.3g}" for k, v in summary["pairwise_wilcoxon"].items()))
    b = summary["best_run"]
    lines.append(f"best run: {b['algorithm']} {b['friction']}{'-asym' if b['asymmetric'] else ''} seed {b['seed']}: "
                 f"{summary['metric']} {b[summary['metric']]:.6g} %, benchmark clock {b['sim_val_benchmark_pct']:.6g} %")
    return "\n".join(lines)

