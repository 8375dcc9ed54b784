"""Thesis Tables 6.17–6.20 regenerated on the bundled TX40 joint-2 bags.

    .venv/bin/python bench/tx40_joint2.py [--runs 10] [--bo-runs N] [--algorithms de,ga,pso,bo,dt]
                                          [--protocols thesis,varpro] [--json OUT.json]

Data: bags/tx40_j2_excitation (estimation) and bags/tx40_j2_validation, synthesised by
tools/make_tx40_bags.py (only joint 2 moves, docs/reference.md#tx40 noise; ground truth in
bags/tx40_truth.json). Model: system ``tx40-j2`` (τ = ZZ·q̈ − g·MX·cos θ + g·MY·sin θ +
Stribeck friction + offset), symmetric Stribeck, seeds 0…runs−1.

Protocols:
  thesis  every parameter searched (9) with the thesis budgets: DE/GA/PSO 50 × 100
          generations, BO/DT 100 calls, random start (``warm_start=False``) — the protocol
          of Tables 6.17–6.19;
  varpro  only vs and δ searched, the 7 linear parameters solved in closed form per
          candidate (``SolverOptions(varpro=True)``), same budgets, the closed-form start
          evaluated first (identify's default).

Reported per algorithm: parameters mean ± std over the runs (Tables 6.17/6.18), wall time per
run (Table 6.19), OSA relative error on the estimation data (Table 6.20, as the thesis) and on
the validation bag, next to the truth and the noise floor (relative error of the true
parameters). Finally the DE 50 × 100 timing on joint 2 (thesis: 171 s per run).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from frictionid_core.identification import IdentifyRequest, SolverOptions, identify, validate
from frictionid_core.io import load
from frictionid_core.synthetic import expected_parameters

ROOT = Path(__file__).resolve().parents[1]
THESIS = {  # Tables 6.17/6.18 (mean), 6.19 (s), 6.20 (%)
    "de": {"ZZ": 1.5431, "MX": 2.8351, "MY": 0.011162, "Fv": 6.1622, "Fc": 5.6851, "Fs": 9.2543, "offset": -0.069789,
           "vs": 0.043739, "delta": 1.2634, "wall_s": 171.16, "relerr_pct": 7.2133},
    "ga": {"ZZ": 1.4625, "MX": 2.8305, "MY": 0.0087263, "Fv": 5.8579, "Fc": 5.8252, "Fs": 8.4545, "offset": -0.059046,
           "vs": 0.046754, "delta": 1.7986, "wall_s": 174.91, "relerr_pct": 7.4285},
    "pso": {"ZZ": 1.7759, "MX": 2.7157, "MY": 0.043832, "Fv": 7.6546, "Fc": 6.1318, "Fs": 8.0299, "offset": 0.1021,
            "vs": 0.057701, "delta": 1.4888, "wall_s": 179.58, "relerr_pct": 9.3014},
    "bo": {"ZZ": 1.741209, "MX": 2.716822, "MY": 0.085575, "Fv": 7.992918, "Fc": 6.090332, "Fs": 8.627831,
           "offset": 0.137157, "vs": 0.055201, "delta": 1.757256, "wall_s": 61.44, "relerr_pct": 11.482},
    "dt": {"ZZ": 1.638843, "MX": 2.852588, "MY": 0.038281, "Fv": 5.995656, "Fc": 5.911671, "Fs": 8.718668,
           "offset": 0.237290, "vs": 0.051831, "delta": 1.598269, "wall_s": 26.61, "relerr_pct": 7.9176},
}
PARAMS = ("ZZ", "MX", "MY", "Fv", "Fc", "Fs", "offset", "vs", "delta")


def _mean_std(values) -> tuple[float, float]:
    return float(np.mean(values)), float(np.std(values))


def run(algorithms, protocols, runs, bags: Path, slow_runs: int | None = None) -> dict:
    est = load(bags / "tx40_j2_excitation", joints=["joint_2"])
    val = load(bags / "tx40_j2_validation", joints=["joint_2"])
    truths = json.loads((bags / "tx40_truth.json").read_text())["bags"]
    truth = expected_parameters(truths["tx40_j2_excitation"], "tx40-j2")
    out = {"truth": truth, "protocols": {}}
    floor_done = False
    for protocol in protocols:
        table = {}
        for alg in algorithms:
            rows = []
            for seed in range(slow_runs if alg == "bo" and slow_runs is not None else runs):
                solver = SolverOptions(alg, seed, varpro=protocol == "varpro", warm_start=protocol == "varpro")
                r = identify(est, IdentifyRequest(system="tx40-j2", friction="stribeck", solver=solver)).to_dict()
                rows.append({"params": r["params"], "wall_s": r["wall_s"], "relerr_est": r["metrics"]["relerr_pct"],
                             "relerr_val": validate(val, r)["relerr_pct"]})
                if not floor_done:
                    tr = dict(r, params={k: truth[k] for k in r["params"]})
                    out["floor_relerr_est"] = validate(est, tr)["relerr_pct"]
                    out["floor_relerr_val"] = validate(val, tr)["relerr_pct"]
                    floor_done = True
                print(f"{protocol:>6} {alg:>4} seed {seed}: {r['wall_s']:.2f} s, "
                      f"OSA est {rows[-1]['relerr_est']:.4f} %, val {rows[-1]['relerr_val']:.4f} %",
                      file=sys.stderr, flush=True)
            table[alg] = {
                "params": {p: _mean_std([x["params"][p] for x in rows]) for p in PARAMS},
                "wall_s": _mean_std([x["wall_s"] for x in rows]),
                "relerr_est": _mean_std([x["relerr_est"] for x in rows]),
                "relerr_val": _mean_std([x["relerr_val"] for x in rows]),
                "runs": rows,
            }
        out["protocols"][protocol] = table
    # DE 50 × 100 on joint 2: the thesis protocol, timed end to end (data already loaded).
    times = []
    for seed in range(3):
        t0 = time.perf_counter()
        solver = SolverOptions("de", seed, pop=50, generations=100, warm_start=False)
        identify(est, IdentifyRequest(system="tx40-j2", friction="stribeck", solver=solver))
        times.append(time.perf_counter() - t0)
    out["de_50x100_wall_s"] = {"runs": times, "median": float(np.median(times)), "thesis": 171.16}
    return out


def print_tables(out: dict) -> None:
    truth = out["truth"]
    for protocol, table in out["protocols"].items():
        algs = list(table)
        counts = ", ".join(f"{a.upper()} {len(table[a]['runs'])}" for a in algs)
        print(f"\n### Protocol '{protocol}' — parameters, mean ± std over the runs ({counts}) (Tables 6.17/6.18)\n")
        print("| parameter | truth | " + " | ".join(a.upper() for a in algs) + " |")
        print("|---|---|" + "---|" * len(algs))
        for p in PARAMS:
            cells = [f"{table[a]['params'][p][0]:.5g} ± {table[a]['params'][p][1]:.2g}" for a in algs]
            print(f"| {p} | {truth[p]:.5g} | " + " | ".join(cells) + " |")
        print("\n| algorithm | wall time per run, s (Table 6.19) | thesis s | OSA relerr estimation, % (Table 6.20) | "
              "thesis % | OSA relerr validation, % |")
        print("|---|---|---|---|---|---|")
        for a in algs:
            t = table[a]
            print(f"| {a.upper()} | {t['wall_s'][0]:.3g} ± {t['wall_s'][1]:.2g} | {THESIS[a]['wall_s']} | "
                  f"{t['relerr_est'][0]:.4g} ± {t['relerr_est'][1]:.2g} | {THESIS[a]['relerr_pct']} | "
                  f"{t['relerr_val'][0]:.4g} ± {t['relerr_val'][1]:.2g} |")
    print(f"\nNoise floor (true parameters): estimation {out['floor_relerr_est']:.4g} %, "
          f"validation {out['floor_relerr_val']:.4g} %")
    d = out["de_50x100_wall_s"]
    print(f"DE 50 × 100 on joint 2 (thesis protocol, all 9 parameters): median {d['median']:.2f} s per run "
          f"(runs {', '.join(f'{x:.2f}' for x in d['runs'])}); thesis {d['thesis']} s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--bo-runs", type=int, help="runs of BO (minutes per run; default: --runs)")
    ap.add_argument("--algorithms", default="de,ga,pso,bo,dt")
    ap.add_argument("--protocols", default="thesis,varpro")
    ap.add_argument("--bags", type=Path, default=ROOT / "bags")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    out = run(args.algorithms.split(","), args.protocols.split(","), args.runs, args.bags, args.bo_runs)
    print_tables(out)
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
