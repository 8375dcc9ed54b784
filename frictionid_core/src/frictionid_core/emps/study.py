"""Statistical study of optimisers × friction models on the EMPS (thesis §6.3, docs/reference.md#statistical-study).

Each run identifies the IDM parameters with one population algorithm at the thesis budget
(50 × 100) on the estimation data, then reports the OSA torque relative error and the
closed-loop simulated position relative error on the estimation and validation data (true
and benchmark clocks). Runs are appended to ``DIR/runs.jsonl`` as they finish, each record with its
checksum (:mod:`frictionid_core.fleet.store`): a rerun skips finished runs, and sets aside and redoes a
damaged record (a changed or deleted field, a line that is not JSON, bad bytes), saying so. A run
that fails is recorded and retried once, never stopping the others. :func:`analyse` turns the
finished runs into the rank table, Friedman tests, pairwise p-values and convergence curves.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from frictionid_core.errors import FrictionIdError
from frictionid_core.files import write_json
from frictionid_core.fleet import RecordStore, latest_by_key

if TYPE_CHECKING:  # numpy and the optimisers are imported by the functions that use them
    import numpy as np

ALGORITHMS = ("de", "pso", "ga", "aco", "bbo")
RUNS_FILE = "runs.jsonl"

# progress(finished, total, elapsed_s): called after each finished run (or failed twice).
Progress = Callable[[int, int, float], None]
# Numbers every finished run holds (analyse and format_summary read them).
RUN_NUMBERS = ("cost", "osa_est_pct", "osa_val_pct", "sim_est_true_pct", "sim_val_true_pct", "sim_est_benchmark_pct",
               "sim_val_benchmark_pct")


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
    from frictionid_core.emps.simulation import load_emps

    return load_emps(path)


@lru_cache(maxsize=64)
def _simulator(path: str, friction: str, asymmetric: bool, clock: str):
    from frictionid_core.emps.simulation import EmpsSimulator

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


def valid_run(record: dict) -> str | None:
    """None when a ``runs.jsonl`` record has what the study reads, else what is wrong with it."""
    if record.get("status") == "failed":
        return None if isinstance(record.get("error"), str) else "a failed run without its error line"
    if record.get("status") != "ok":
        return f"unknown status {record.get('status')!r}"
    for name in ("algorithm", "friction", "key"):
        if not isinstance(record.get(name), str):
            return f"field '{name}' missing or not text"
    for name in (*RUN_NUMBERS, "seed"):
        if not isinstance(record.get(name), (int, float)) or isinstance(record.get(name), bool):
            return f"field '{name}' missing or not a number"
    for name in ("history_fmin", "history_dist_mean"):
        if not isinstance(record.get(name), list):
            return f"field '{name}' missing or not a list"
    return None


def _store(out_dir: Path) -> RecordStore:
    return RecordStore(Path(out_dir) / RUNS_FILE, validate=valid_run)


def _finished(record: dict | None) -> bool:
    """A run needs no new attempt: it finished, or failed twice."""
    return record is not None and (record["status"] == "ok" or record.get("attempt", 1) >= 2)


def finished_keys(out_dir: Path) -> set[str]:
    """Keys of the runs finished (or failed twice) in ``out_dir/runs.jsonl``; damaged lines are left out."""
    return {key for key, r in latest_by_key(_store(out_dir).read().records).items() if _finished(r)}


def run_study(specs: list[RunSpec], out_dir: Path, *, workers: int | None = None, scheduler: str | None = None,
              progress: Progress | None = None) -> int:
    """Run the ``specs`` not finished yet in ``out_dir``; returns how many ran now.

    Local processes by default (all cores), or a Dask cluster at ``scheduler`` (tcp://host:port).
    Each run's record is appended and flushed at once: an interruption loses only the runs in flight.
    Damaged records are set aside and their runs redone (a UserWarning says which); a failed run is
    recorded and retried once. ``progress(finished, total, elapsed_s)`` is called after each run.
    """
    from frictionid_core.fleet import open_backend

    out_dir = Path(out_dir)
    with _store(out_dir) as store:
        found = store.check()
        for message in found.set_aside:
            warnings.warn(message, UserWarning, stacklevel=2)
        latest = latest_by_key(found.records)
        todo = [s for s in specs if not _finished(latest.get(s.key))]
        total, t0 = len(todo), time.perf_counter()
        if not todo:
            return 0
        finished = 0

        def write(record: dict) -> None:
            nonlocal finished
            store.append(record)
            finished += _finished(record)
            if progress is not None and _finished(record):
                progress(finished, total, time.perf_counter() - t0)

        with open_backend(workers, scheduler) as backend:
            backend.run(run_one, [(spec.key, spec) for spec in todo], write)
    return total


# ------------------------------------------------------------------------------------ analysis
def load_runs(out_dir: Path) -> list[dict]:
    """The finished runs of ``out_dir/runs.jsonl`` (damaged records left out, with a UserWarning each)."""
    path = Path(out_dir) / RUNS_FILE
    if not path.exists():
        raise FrictionIdError(f"{path}: no runs yet (run 'frictionid study' first)")
    found = _store(out_dir).read()
    for message in found.set_aside:
        warnings.warn(message, UserWarning, stacklevel=2)
    return [r for r in latest_by_key(found.records).values() if r["status"] == "ok"]


def failed_runs(out_dir: Path) -> list[dict]:
    """{key, error, attempts} of the runs whose last attempt failed."""
    found = _store(out_dir).read()
    return [{"key": key, "error": r["error"], "attempts": r.get("attempt", 1)}
            for key, r in latest_by_key(found.records).items() if r["status"] == "failed"]


def _label(run: dict) -> str:
    return f"{run['friction']}{'-asym' if run['asymmetric'] else ''}"


def analyse(out_dir: Path, metric: str = "sim_val_true_pct") -> dict:
    """Rank table, Friedman tests (across algorithms and across models) and pairwise
    Wilcoxon p-values of ``metric`` over the runs in ``out_dir``; writes ``summary.json``."""
    import numpy as np
    from scipy import stats

    runs = load_runs(out_dir)
    if not runs:
        raise FrictionIdError(f"{Path(out_dir) / RUNS_FILE}: no finished run to analyse")
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
        summary["friedman_models"] = {"statistic": float(f.statistic), "pvalue": float(f.pvalue),
                                      "blocks": len(blocks_m)}
        summary["model_mean_rank"] = dict(zip(models, map(float, stats.rankdata(bm, axis=1).mean(axis=0))))
    best = min(runs, key=lambda r: r[metric])
    summary["best_run"] = {k: best[k] for k in ("algorithm", "friction", "asymmetric", "seed", metric,
                                                "sim_val_benchmark_pct", "osa_est_pct")}
    failed = failed_runs(out_dir)
    if failed:
        summary["failed_runs"] = failed
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
        lines.append("pairwise Wilcoxon p: "
                     + ", ".join(f"{k} {v:.3g}" for k, v in summary["pairwise_wilcoxon"].items()))
    for f in summary.get("failed_runs", []):
        lines.append(f"failed run {f['key']} ({f['attempts']} attempts): {f['error']}")
    b = summary["best_run"]
    lines.append(f"best run: {b['algorithm']} {b['friction']}{'-asym' if b['asymmetric'] else ''} seed {b['seed']}: "
                 f"{summary['metric']} {b[summary['metric']]:.6g} %, "
                 f"benchmark clock {b['sim_val_benchmark_pct']:.6g} %")
    return "\n".join(lines)

