"""A large log through the command line: 5 kHz × 6 TX40 joints × 60 s (not a test).

    .venv/bin/python bench/large_log.py [--keep DIR] [--runs stribeck,coulomb]

Writes a synthetic TX40 recording with ``frictionid excite`` + ``frictionid synth`` (Stribeck
friction of docs/reference.md#tx40, the published position noise, 0.05 N·m torque noise): an
estimation log of 45 s of optimised Fourier motion plus 15 s of constant-velocity plateaus
(300 001 samples) and a 20 s validation log, both at 5 kHz. Then times ``frictionid identify``
(Coulomb LS; Stribeck hybrid) with the default preprocessing, each in a subprocess of its own:
wall time and peak RSS (``os.wait4`` ru_maxrss), and ``frictionid validate`` on the validation
log. Prints a table (with the preprocessing the tool chose) and writes
bench/results/large_log.{json,txt}. Targets: identify ≤ 20 s and ≤ 2 GB; Stribeck vs and δ
within 5 % of the truth on the joints whose dips the data determine.

``--keep DIR`` writes (or reuses) the logs in DIR instead of a temporary folder.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import publish

ROOT = Path(__file__).resolve().parents[1]
RATE = 5000
WALL_TARGET_S, RSS_TARGET_GB = 20.0, 2.0
SHAPE_TOLERANCE = 0.05  # vs, δ relative to truth
# name: (excitation seed, period s, Fourier duration s, dwell s, noise seed)
LOGS = {"estimation": (1, 10.0, 45.0, 15.0, 11), "validation": (2, 8.0, 20.0, 0.0, 21)}
RUNS = {"coulomb": ("coulomb", "ls"), "stribeck": ("stribeck", "hybrid")}


def run(*args: str) -> tuple[float, float, str, float]:
    """Run ``frictionid ARGS`` in a subprocess: (wall s, peak RSS GB, stdout, CPU s user + system);
    exits on failure."""
    cmd = [sys.executable, "-m", "frictionid_core.cli", *args]
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(cmd, stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0), err.seek(0)
        stdout, stderr = out.read(), err.read()
    if proc.returncode != 0:
        raise SystemExit(f"frictionid {' '.join(args)} failed ({proc.returncode}):\n{stderr}")
    return wall, usage.ru_maxrss / 1024**2, stdout, usage.ru_utime + usage.ru_stime  # ru_maxrss: KiB on Linux


def make_logs(folder: Path) -> dict:
    """The estimation and validation bags (and truth) in ``folder``; reused when present."""
    made = {}
    for name, (seed, period, duration, dwell, noise_seed) in LOGS.items():
        bag, truth, traj = folder / name, folder / f"{name}_truth.json", folder / f"{name}.npz"
        if bag.exists() and truth.exists():
            made[name] = {"reused": True}
            continue
        if bag.exists():
            shutil.rmtree(bag)
        t_ex, *_ = run("excite", "--system", "tx40", "--seed", str(seed), "--period", str(period),
                         "--duration", str(duration), "--dwell", str(dwell), "--evals", "300", "--out", str(traj))
        t_syn, *_ = run("synth", str(traj), "--system", "tx40", "--friction", "stribeck", "--seed", str(noise_seed),
                          "--rate", str(RATE), "--out", str(bag), "--truth", str(truth))
        made[name] = {"excite_s": t_ex, "synth_s": t_syn}
    return made


def shape_errors(params: dict, truth: dict) -> dict[str, dict[str, float]]:
    """{joint: {vs, delta: relative error}} of a Stribeck fit against the truth."""
    out = {}
    for joint, p in truth["friction"]["params"].items():
        out[joint] = {k: params[f"{joint}/{k}"] / p[k] - 1 for k in ("vs", "delta") if f"{joint}/{k}" in params}
    return out


def main() -> int:
    from frictionid_core.files import read_json

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--keep", type=Path, help="folder of the logs (kept; reused when present)")
    ap.add_argument("--runs", default=",".join(RUNS), help="comma-separated subset of " + ", ".join(RUNS))
    args = ap.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="large_log_"))
    folder.mkdir(parents=True, exist_ok=True)
    targets = {"wall_s": WALL_TARGET_S, "rss_gb": RSS_TARGET_GB, "shape_tolerance": SHAPE_TOLERANCE}
    out: dict = {"rate_hz": RATE, "logs": make_logs(folder), "targets": targets, "runs": {}}
    truth = read_json(folder / "estimation_truth.json")
    est, val = folder / "estimation", folder / "validation"
    for name in args.runs.split(","):
        friction, solver = RUNS[name]
        fit, check = folder / f"{name}.json", folder / f"{name}_val.json"
        wall, rss, _, cpu = run("identify", str(est), "--system", "tx40", "--friction", friction, "--solver", solver,
                           "--json", str(fit))
        run("validate", str(val), "--params", str(fit), "--json", str(check))
        r, v = read_json(fit), read_json(check)
        pre = r["preprocessing"]
        rec = {"command": f"frictionid identify estimation --system tx40 --friction {friction} --solver {solver}",
               "wall_s": wall, "cpu_s": cpu, "identify_wall_s": r["wall_s"], "peak_rss_gb": rss,
               "load_average": os.getloadavg(),
               "estimation_relerr_pct": r["metrics"]["relerr_pct"], "validation_relerr_pct": v["metrics"]["relerr_pct"],
               "preprocessing": pre, "warnings": r.get("warnings", []), "params": r["params"],
               "pass": wall <= WALL_TARGET_S and rss <= RSS_TARGET_GB}
        if friction == "stribeck":
            rec["shape_errors"] = shape_errors(r["params"], truth)
        out["runs"][name] = rec
        print(line(name, rec), flush=True)
    publish("large_log", summary(out, folder), out)
    if args.keep is None:
        shutil.rmtree(folder, ignore_errors=True)
    return 0 if all(r["pass"] for r in out["runs"].values()) else 1


def line(name: str, r: dict) -> str:
    pre = r["preprocessing"]
    rows = pre.get("fit_rows")
    return (f"{name:<9} wall {r['wall_s']:6.1f} s (identify {r['identify_wall_s']:5.1f} s, CPU {r['cpu_s']:5.1f} s, "
            f"load {r['load_average'][0]:.1f})  peak RSS {r['peak_rss_gb']:5.2f} GB  "
            f"estimation {r['estimation_relerr_pct']:6.3f} %  validation {r['validation_relerr_pct']:6.3f} %  "
            f"cut-off {pre['cutoff_hz']:.3g} Hz, decimate {pre['decimate']}"
            + (f", rows {rows}" if rows is not None else "") + f"  {'PASS' if r['pass'] else 'FAIL'}")


def summary(out: dict, folder: Path) -> str:
    lines = [f"large log: {RATE} Hz × 6 TX40 joints × 60 s (synthetic, Stribeck; logs in {folder}); "
             f"targets ≤ {WALL_TARGET_S:g} s, ≤ {RSS_TARGET_GB:g} GB per identify"]
    for name, r in out["runs"].items():
        lines.append(line(name, r))
        pre = r["preprocessing"]
        lines.append("  preprocessing: " + ", ".join(f"{k} {pre[k]}" for k in pre if k not in (
            "min_speed", "bandwidth_per_joint_hz", "position_noise", "velocity_noise", "top_speed",
            "qdd_noise_share", "reversal_acceleration")))
        for joint, e in r.get("shape_errors", {}).items():
            lines.append(f"  {joint}: " + ", ".join(f"{k} {100 * v:+.1f} %" for k, v in e.items()))
        lines.extend(f"  warning: {w}" for w in r["warnings"])
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
