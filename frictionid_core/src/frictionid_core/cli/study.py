"""``frictionid study emps --out DIR [--algorithms …] [--friction …] [--seeds N]``: optimisers × friction
models × seeds on the EMPS (resumable; local processes or a Dask cluster)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from frictionid_core.cli._common import output_folder, refuse_overwriting, split_list
from frictionid_core.errors import FrictionIdError


def add_arguments(p: argparse.ArgumentParser) -> None:
    from frictionid_core.emps import ALGORITHMS

    p.add_argument("system", choices=["emps"])
    p.add_argument("--algorithms", default=",".join(ALGORITHMS), help="comma-separated (default de,pso,ga,aco,bbo)")
    p.add_argument("--friction", default="all", help="comma-separated friction laws or 'all' (each sym + asym)")
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--pop", type=int, default=50)
    p.add_argument("--generations", type=int, default=100)
    p.add_argument("--estimation", default="bags/emps_estimation")
    p.add_argument("--validation", default="bags/emps_validation")
    p.add_argument("--out", type=Path, required=True, help="output directory (resumable)")
    p.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT (default: local processes)")


def _progress_bar(n: int, total: int, elapsed: float) -> None:
    """A one-line progress bar with the ETA on stderr, redrawn in place."""
    eta = elapsed / n * (total - n)
    width = 30
    bar = "#" * int(width * n / total)
    print(f"\r[{bar:<{width}}] {n}/{total} runs, {elapsed:5.0f} s elapsed, ETA {eta:4.0f} s", end="",
          file=sys.stderr, flush=True)


def run(args) -> int:
    from frictionid_core.emps import analyse, format_summary, plan, run_study
    from frictionid_core.friction import STATIC_FRICTIONS as FRICTIONS  # the EMPS simulator's laws
    from frictionid_core.optim import METHODS

    algos = split_list(args.algorithms)
    unknown = [a for a in algos if a not in METHODS]
    if unknown:
        raise FrictionIdError(f"unknown algorithm(s) {unknown}; available: {', '.join(METHODS)}")
    frictions = list(FRICTIONS) if args.friction == "all" else split_list(args.friction)
    bad = [f for f in frictions if f not in FRICTIONS]
    if bad:
        raise FrictionIdError(f"unknown friction model(s) {bad}; choose from {', '.join(FRICTIONS)} or 'all'")
    for path in (args.estimation, args.validation):
        if not Path(path).exists():
            raise FrictionIdError(f"{path}: no such file or directory")
    refuse_overwriting({**output_folder("--out", args.out, ("summary.json",)), "--out": args.out},
                       {"--estimation": Path(args.estimation), "--validation": Path(args.validation)})
    specs = plan(algos, frictions, args.seeds, args.estimation, args.validation, args.pop, args.generations)
    t0 = time.perf_counter()
    ran = run_study(specs, args.out, workers=args.workers, scheduler=args.scheduler, progress=_progress_bar)
    if ran:
        print(file=sys.stderr)  # end the progress bar's line
    print(f"{ran} runs done now, {len(specs) - ran} were already finished; {time.perf_counter() - t0:.1f} s")
    print(format_summary(analyse(args.out)))
    return 0
