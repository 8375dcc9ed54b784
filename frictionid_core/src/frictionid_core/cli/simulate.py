"""``frictionid simulate emps --params r.json --data FILE [--clock true|benchmark] [--tec S] [--substeps N]
[--json S.json]``: closed-loop simulation of identified EMPS parameters."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from frictionid_core.cli._common import add_json_argument, refuse_overwriting, save_json


def add_arguments(p: argparse.ArgumentParser) -> None:
    from frictionid_core.emps import CLOCKS

    p.add_argument("system", choices=["emps"], help="system to simulate")
    p.add_argument("--params", type=Path, required=True, help="JSON written by 'frictionid identify'")
    p.add_argument("--data", type=Path, required=True, help="EMPS run: MAT file or bag with /joint_reference")
    p.add_argument("--clock", choices=CLOCKS, default="true",
                   help="true: recorded stamps (default); benchmark: the benchmark's constant tec = t(10)−t(9)")
    p.add_argument("--tec", type=float,
                   help="benchmark-clock period, s (default t(10)−t(9) of the stamps; a bag's stamps are rounded "
                        "to 1 ns: 9.99983961121758e-4 reproduces the MAT file of the estimation run)")
    p.add_argument("--substeps", type=int, default=10, help="RK4 steps per controller period (default 10)")
    add_json_argument(p)


def run(args) -> int:
    from frictionid_core.emps import METRIC_KEYS, load_emps, simulate_identification
    from frictionid_core.identification import read_result
    from frictionid_core.model import check_finite

    refuse_overwriting({"--json": args.json}, {"--params": args.params, "--data": args.data})
    result = read_result(args.params)
    data = load_emps(args.data)
    sim = simulate_identification(data, result.to_dict(), clock=args.clock, substeps=args.substeps, tec=args.tec)
    check_finite(sim.metrics, f"the simulation of {args.params} on {data.source}", METRIC_KEYS)
    out = {"system": "emps", "friction": result.friction, "asymmetric": result.asymmetric,
           "params": dict(zip(sim.names, map(float, sim.params))), "params_file": str(args.params),
           "source": data.source, "clock": sim.clock, "settings": sim.settings, "samples": int(sim.t.size),
           "metrics": dict(sim.metrics, clock=sim.clock)}
    print_simulation(out)
    save_json(args.json, out)
    return 0


def print_simulation(out: dict, stream=None) -> None:
    """A small table of the simulation metrics, stating the clock."""
    from frictionid_core.emps import METRIC_KEYS

    stream = stream or sys.stdout
    m = out["metrics"]
    if out["clock"] == "benchmark":
        clock = f"benchmark (constant tec = {out['settings']['tec'] * 1e3:.9f} ms)"
    else:
        clock = "true (recorded stamps)"
    model = f"{out['friction']}{' (asymmetric)' if out['asymmetric'] else ''}"
    print(f"EMPS closed-loop simulation · {model} · clock {clock}", file=stream)
    print(f"data: {out['source']}", file=stream)
    print(f"{'relative error':<16}{'%':>14}", file=stream)
    for key in METRIC_KEYS:
        print(f"{key.removesuffix('_relerr_pct'):<16}{m[key]:>14.6g}", file=stream)
