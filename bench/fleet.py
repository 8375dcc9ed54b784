"""Fleet throughput (not a test): logs per minute on 1 and 2 local workers and on a local Dask cluster of
2 workers, time per log against a serial fit, memory per worker, and the cost of 100 robots × 365 days.

    .venv/bin/python bench/fleet.py [--robots 4] [--logs 8] [--duration 30] [--rate 1000]

Writes a synthetic fleet (3-joint ``joint`` system, Coulomb friction, LS; ``tools/synth_fleet.py``) in a
temporary folder, fits a few of its logs serially in this process (after a warm-up), then runs
``frictionid fleet`` (in-process ``run_fleet``) with ``--workers 1``, ``--workers 2`` and on a Dask
scheduler with 2 workers started as ``dask worker --nthreads 1`` under their nannies (the nanny's
``MALLOC_TRIM_THRESHOLD_`` left as Dask sets it: the fleet's worker set-up undoes it). Each run starts
with fresh worker processes, so its wall time includes their start and warm-up. Checks that the three
runs wrote the same fits.csv. Writes bench/results/fleet.{json,txt}.
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import publish

from frictionid_core.fleet import read_fleet, run_fleet, synthesize_fleet
from frictionid_core.fleet.jobs import LogJob, fit_log, warm_up

DAYS, ROBOTS_AT_SCALE = 365, 100


def serial_times(config, count: int) -> list[float]:
    """Wall seconds of ``count`` logs fitted one after another in this process (after a warm-up)."""
    robot = config.robots[0]
    warm_up((robot.request,))
    times = []
    for name, source in robot.logs[:count]:
        t0 = time.perf_counter()
        fit_log(LogJob(robot.name, name, source, robot.request, robot.load, robot.covariates))
        times.append(time.perf_counter() - t0)
    return times


def dask_cluster() -> tuple[str, list[subprocess.Popen]]:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    dask = str(Path(sys.executable).parent / "dask")
    address = f"tcp://127.0.0.1:{port}"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              **quiet)]
    procs += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--no-dashboard"], **quiet)
              for _ in range(2)]
    return address, procs


def measure(config, out: Path, **backend) -> dict:
    result = run_fleet(config, out, **backend)
    ok = [r for r in result.records if r.get("wall_s") is not None]
    return {"logs": result.fitted_now, "wall_s": result.wall_s,
            "logs_per_min": 60.0 * result.fitted_now / result.wall_s,
            "per_log_wall_s": statistics.median(r["wall_s"] for r in ok),
            "per_log_cpu_s": statistics.median(r["cpu_s"] for r in ok),
            "worker_peak_rss_mb": max(r["rss_mb"] for r in ok), "fits_csv": (out / "fits.csv").read_text()}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", type=int, default=4)
    p.add_argument("--logs", type=int, default=8)
    p.add_argument("--duration", type=float, default=30.0, help="seconds per log")
    p.add_argument("--rate", type=float, default=1000.0, help="sample rate, Hz")
    args = p.parse_args()
    with tempfile.TemporaryDirectory(prefix="fleet-bench-") as tmp:
        folder = Path(tmp)
        fleet = synthesize_fleet(folder / "data", robots=args.robots, logs=args.logs, duration_s=args.duration,
                                 rate_hz=args.rate, seed=1)
        config = read_fleet(fleet)
        serial = statistics.median(serial_times(config, min(6, args.logs)))
        runs = {"local_1": measure(config, folder / "w1", workers=1),
                "local_2": measure(config, folder / "w2", workers=2)}
        address, procs = dask_cluster()
        try:
            runs["dask_2"] = measure(config, folder / "dask", scheduler=address)
        finally:
            for proc in procs:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    same = len({r.pop("fits_csv") for r in runs.values()}) == 1
    n = args.robots * args.logs
    speedup = runs["local_2"]["logs_per_min"] / runs["local_1"]["logs_per_min"]
    dask_ratio = runs["dask_2"]["per_log_wall_s"] / serial
    at_scale = ROBOTS_AT_SCALE * DAYS
    cpu_h = at_scale * runs["local_2"]["per_log_cpu_s"] / 3600.0
    wall_h = at_scale / runs["local_2"]["logs_per_min"] / 60.0
    lines = [f"fleet bench: {args.robots} robots × {args.logs} logs ({n}), 3 joints, {args.duration:g} s at "
             f"{args.rate:g} Hz each, joint system, Coulomb, LS; {os.cpu_count()} CPUs (shared, load "
             f"{os.getloadavg()[0]:.1f} at the end)",
             f"serial fit in one process: {serial:.3f} s per log (median)",
             f"{'backend':<10} {'logs/min':>9} {'wall s':>7} {'s/log':>7} {'CPU s/log':>9} {'peak MB':>8}"]
    for name, r in runs.items():
        lines.append(f"{name:<10} {r['logs_per_min']:9.1f} {r['wall_s']:7.1f} {r['per_log_wall_s']:7.3f} "
                     f"{r['per_log_cpu_s']:9.3f} {r['worker_peak_rss_mb']:8.0f}")
    lines += [f"2 local workers / 1: {speedup:.2f}× the throughput (target ≥ 1.6)",
              f"Dask worker time per log / serial: {dask_ratio:.2f} (target ≤ 1.2)",
              f"same fits.csv on all three backends: {same}",
              f"{ROBOTS_AT_SCALE} robots × {DAYS} days = {at_scale} logs: {cpu_h:.1f} CPU-hours, {wall_h:.1f} h on 2 "
              f"local workers ({wall_h / DAYS * 60:.1f} min a day)"]
    publish("fleet", "\n".join(lines), {"args": vars(args), "serial_per_log_s": serial, "runs": runs,
                                        "speedup_2_over_1": speedup, "dask_over_serial": dask_ratio,
                                        "same_fits_csv": same, "cpu_hours_100x365": cpu_h,
                                        "wall_hours_100x365_2_workers": wall_h})
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
