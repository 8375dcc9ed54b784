"""EMPS closed-loop simulation: acceptance figures and timings.

    python bench/simulation.py [--mat DIR] [--pop 50] [--repeat 5]

Prints the four relative errors of the reference parameters (docs/reference.md#emps-idim-ls, symmetric and
asymmetric Coulomb) on both runs and both clocks, then the wall time of a position-only
simulation of the whole record for P = 1 and P = --pop parameter sets (best of --repeat,
after a warm-up call that also compiles the kernel). Data: the bags in bags/, or the MAT
files in DIR (DATA_EMPS.mat, DATA_EMPS_PULSES.mat).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from frictionid_core.emps import METRIC_KEYS, EmpsSimulator, load_emps

ROOT = Path(__file__).resolve().parents[1]
REF = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "offset": -3.1648}
REF_ASYM = {"M": 95.1540, "Fv_pos": 166.7061, "Fc_pos": 20.1440, "Fv_neg": 240.4236, "Fc_neg": 20.6277}
PUBLISHED = {  # thesis Table 6.12 (benchmark clock, position) and the benchmark script (estimation)
    ("estimation", "benchmark", False): "pos 0.013752, vel 0.229, acc 8.60, force 5.85",
    ("validation", "benchmark", False): "pos 0.0080248",
    ("estimation", "benchmark", True): "pos 0.013769",
    ("validation", "benchmark", True): "pos 0.0079575",
    ("estimation", "true", False): "pos ≈ 0.0017 (docs/reference.md#emps-simulation)",
    ("validation", "true", False): "pos ≈ 0.0027 (docs/reference.md#emps-simulation)",
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mat", type=Path, help="directory of the EMPS MAT files (default: the bags)")
    ap.add_argument("--pop", type=int, default=50)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--substeps", type=int, default=10)
    args = ap.parse_args()
    if args.mat:
        sources = {"estimation": args.mat / "DATA_EMPS.mat", "validation": args.mat / "DATA_EMPS_PULSES.mat"}
    else:
        sources = {"estimation": ROOT / "bags" / "emps_estimation", "validation": ROOT / "bags" / "emps_validation"}
    runs = {name: load_emps(src) for name, src in sources.items()}

    print(f"relative errors, % (substeps {args.substeps}); data: {'MAT' if args.mat else 'bags'}")
    print(f"{'run':<11}{'clock':<10}{'model':<7}" + "".join(f"{k.removesuffix('_relerr_pct'):>14}" for k in METRIC_KEYS)
          + "   published")
    for clock in ("benchmark", "true"):
        for name, data in runs.items():
            for asym, params in ((False, REF), (True, REF_ASYM)):
                sim = EmpsSimulator(data, "coulomb", asym, clock=clock, substeps=args.substeps)
                m = sim.simulate(params).metrics
                print(f"{name:<11}{clock:<10}{'asym' if asym else 'sym':<7}"
                      + "".join(f"{m[k]:>14.7g}" for k in METRIC_KEYS)
                      + f"   {PUBLISHED.get((name, clock, asym), '')}")

    print(f"\nwall time of a position-only simulation of {runs['estimation'].t.size} samples "
          f"(best of {args.repeat})")
    rng = np.random.default_rng(0)
    for friction, asym in (("coulomb", False), ("coulomb", True), ("tustin", False), ("stribeck", True)):
        for clock in ("true", "benchmark"):
            sim = EmpsSimulator(runs["validation"], friction, asym, clock=clock, substeps=args.substeps)
            base = {"M": 95.0, "Fv": 200.0, "Fc": 20.0, "Fs": 25.0, "vs": 0.005, "delta": 1.5, "offset": -3.0}
            x = np.array([base[n.removesuffix("_pos").removesuffix("_neg")] for n in sim.names])
            line = f"{friction + ('-asym' if asym else ''):<15}{clock:<10}"
            for P in (1, args.pop):
                pop = x * (1.0 + 0.05 * rng.uniform(-1, 1, (P, x.size)))
                sim.position_cost(pop)  # warm-up (compiles on first use)
                best = np.inf
                for _ in range(args.repeat):
                    t0 = time.perf_counter()
                    sim.position_cost(pop)
                    best = min(best, time.perf_counter() - t0)
                line += f"  P={P:<3} {best * 1e3:8.1f} ms"
            print(line)


if __name__ == "__main__":
    main()
