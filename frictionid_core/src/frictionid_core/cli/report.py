"""``frictionid report emps --out DIR [--study DIR]``: the EMPS report (HTML, PNG figures, report.json)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("system", choices=["emps"])
    p.add_argument("--estimation", type=Path, default=Path("bags/emps_estimation"))
    p.add_argument("--validation", type=Path, default=Path("bags/emps_validation"))
    p.add_argument("--study", type=Path, help="a 'frictionid study' output directory to include")
    p.add_argument("--out", type=Path, required=True)


def run(args) -> int:
    from frictionid_core.report import build_report

    rep = build_report(args.estimation, args.validation, args.out, args.study)
    best = rep["output_error"][rep["best_output_error"]]["sim"]
    print(f"report: {args.out / 'report.html'} ({rep['wall_s']:.0f} s)")
    print(f"best pipeline (output error {rep['best_output_error']}): validation position relerr "
          f"{best['val_true']:.6g} % (true clock), {best['val_benchmark']:.6g} % (benchmark clock)")
    for e in rep["ensembles"]:
        print(f"ensemble on {e['label']}: BGBM improves validation by {e['improvement_val_pct']['bgbm']:.1f} %, "
              f"EGBB by {e['improvement_val_pct']['egbb']:.1f} %")
    return 0
