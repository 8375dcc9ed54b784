"""``frictionid report RESULT.json SRC [SRC …] --out DIR [--validation SRC …]``: one result on any system
and source (HTML, PNG per source and joint, report.json);
``frictionid report emps --out DIR [--study DIR]``: the EMPS report (models, output error, ensembles)."""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.cli._common import output_folder, refuse_overwriting, system_file
from frictionid_core.errors import FrictionIdError

EMPS = "emps"
EMPS_ESTIMATION, EMPS_VALIDATION = Path("bags/emps_estimation"), Path("bags/emps_validation")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("target", metavar="RESULT.json|emps",
                   help="JSON written by 'frictionid identify', or 'emps' for the EMPS benchmark report")
    p.add_argument("sources", nargs="*", type=Path, metavar="SRC",
                   help="recording(s) to show the result on (its estimation data; not with 'emps')")
    p.add_argument("--validation", type=Path, nargs="+", metavar="SRC",
                   help=f"validation recording(s) (with 'emps': one, default {EMPS_VALIDATION})")
    p.add_argument("--layout", type=Path, help="YAML layout of CSV sources not in frictionid's own format")
    p.add_argument("--topic", help="JointState topic of bag sources (default /joint_states, else the only one)")
    p.add_argument("--estimation", type=Path, help=f"'emps' only: estimation recording (default {EMPS_ESTIMATION})")
    p.add_argument("--study", type=Path, help="'emps' only: a 'frictionid study' output directory to include")
    p.add_argument("--out", type=Path, required=True, help="output directory")


def run(args) -> int:
    return _run_emps(args) if args.target == EMPS else _run_result(args)


def _run_result(args) -> int:
    from frictionid_core.identification import read_result
    from frictionid_core.io import load
    from frictionid_core.reports import REPORT_FILES, build_fit_report

    if args.estimation is not None or args.study is not None:
        raise FrictionIdError("--estimation and --study belong to 'frictionid report emps'; give the sources of a "
                              "result as SRC and --validation SRC")
    sources = [("estimation", p) for p in args.sources] + [("validation", p) for p in args.validation or []]
    if not sources:
        raise FrictionIdError(f"no source to show {args.target} on: give SRC (its data) and/or --validation SRC")
    outputs = output_folder("--out", args.out, REPORT_FILES)
    result = read_result(args.target)
    refuse_overwriting(outputs, {"RESULT.json": Path(args.target), "SRC": args.sources, "--validation": args.validation,
                                 "--layout": args.layout, "--system": system_file(result.system)})
    loaded = [(role, load(path, topic=args.topic, joints=result.joints or None, layout=args.layout))
              for role, path in sources]
    rep = build_fit_report(result.to_dict(), loaded, args.out, str(args.target))
    print(f"report: {args.out / 'report.html'}")
    for s in rep["sources"]:
        per_joint = ", ".join(f"{j} {m.get('relerr_pct', float('nan')):.4g}" for j, m in s["per_joint"].items())
        print(f"{s['role']} {s['source']}: relerr {s['metrics'].get('relerr_pct', float('nan')):.4g} % "
              f"(per joint: {per_joint})")
    for w in rep["warnings"]:
        print(f"warning: {w}")
    return 0


def _run_emps(args) -> int:
    from frictionid_core.emps import build_report
    from frictionid_core.reports import REPORT_FILES

    if args.sources or (args.validation and len(args.validation) > 1) or args.layout or args.topic:
        raise FrictionIdError("'frictionid report emps' takes --estimation, one --validation, --study and --out only")
    estimation = args.estimation or EMPS_ESTIMATION
    validation = args.validation[0] if args.validation else EMPS_VALIDATION
    refuse_overwriting(output_folder("--out", args.out, REPORT_FILES),
                       {"--estimation": estimation, "--validation": validation, "--study": args.study})
    rep = build_report(estimation, validation, args.out, args.study)
    best = rep["output_error"][rep["best_output_error"]]["sim"]
    print(f"report: {args.out / 'report.html'} ({rep['wall_s']:.0f} s)")
    print(f"best pipeline (output error {rep['best_output_error']}): validation position relerr "
          f"{best['val_true']:.6g} % (true clock), {best['val_benchmark']:.6g} % (benchmark clock)")
    for e in rep["ensembles"]:
        print(f"ensemble on {e['label']}: BGBM improves validation by {e['improvement_val_pct']['bgbm']:.1f} %, "
              f"EGBB by {e['improvement_val_pct']['egbb']:.1f} %")
    return 0
