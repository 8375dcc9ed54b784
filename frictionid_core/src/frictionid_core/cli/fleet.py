"""``frictionid fleet FLEET.yaml --out DIR [--workers N | --scheduler tcp://HOST:PORT] [--refit]``: identify
every log of a fleet of robots (new ones only), track each parameter with its σ and raise an alarm when
one drifts; writes fits.csv, alarms.json, failed.json and index.html in DIR (docs/fleet.md)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("fleet", type=Path, help="fleet file (YAML: defaults, robots with their logs, baseline_logs, "
                                            "alarm)")
    p.add_argument("--out", type=Path, required=True, help="output directory (resumable: fitted logs are skipped)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="local worker processes (default: the usable CPUs)")
    where.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT (its workers: one thread each)")
    p.add_argument("--refit", action="store_true", help="fit every log again, also those already fitted or failed")
    p.add_argument("--worker-memory", type=float, metavar="MB",
                   help="local workers: address-space cap per worker, MB (default: 80 %% of the available memory, "
                        "shared out); a log needing more fails with MemoryError")


class _ProgressLine:
    """One line on stderr, redrawn in place: logs done, failed attempts, rate and ETA."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()
        self.failures = 0

    def __call__(self, done: int, total: int, record: dict) -> None:
        self.failures += record.get("status") != "ok"
        elapsed = time.perf_counter() - self.t0
        rate = done / elapsed * 60.0 if elapsed > 0 else 0.0
        eta = f"ETA {elapsed / done * (total - done):5.0f} s" if done else "ETA —"
        print(f"\r{done}/{total} logs, {self.failures} failed attempts, {rate:5.1f} logs/min, {eta} ", end="",
              file=sys.stderr, flush=True)


def run(args) -> int:
    from frictionid_core.cli._common import output_folder, refuse_overwriting, warn
    from frictionid_core.fleet import OUTPUT_FILES, per_log_cost, read_fleet, run_fleet

    config = read_fleet(args.fleet)
    logs = [Path(source) for robot in config.robots for _, source in robot.logs]
    refuse_overwriting(output_folder("--out", args.out, OUTPUT_FILES), {"FLEET": args.fleet, "logs": logs})
    progress = _ProgressLine()
    result = run_fleet(config, args.out, workers=args.workers, scheduler=args.scheduler, refit=args.refit,
                       memory_mb=args.worker_memory, progress=progress)
    if result.fitted_now or progress.failures:
        print(file=sys.stderr)  # end the progress line
    warn(result.set_aside)
    out = result.out_dir
    print(f"fleet: {result.logs} logs of {len(config.robots)} robots: {result.fitted_now} fitted now, "
          f"{result.skipped} already done, {len(result.failed)} failed ({out / 'failed.json'})")
    for failure in result.failed:
        print(f"  failed: {failure['robot']} {failure['log']}: {failure['error']}")
    print(f"{len(result.alarms)} alarms ({out / 'alarms.json'})")
    for a in result.alarms:
        print(f"  ALARM {a['robot']} {a['joint']} {a['parameter']} {a['direction']} from {a['first_log']} "
              f"({a['start_time']}): {a['value']:.6g} vs baseline {a['baseline']:.6g}, z = {a['z']:.3g}")
    cost = per_log_cost([r for r in result.records if r.get("wall_s") is not None])
    per_log = (f"; per log {cost['wall_s']:.3g} s wall, {cost['cpu_s']:.3g} s CPU (median), worker peak "
               f"{cost['rss_mb']:.0f} MB" if cost else "")
    print(f"fits: {out / 'fits.csv'}; dashboard: {out / 'index.html'}; {result.wall_s:.1f} s{per_log}")
    return 0
