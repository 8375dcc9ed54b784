"""``frictionid compare RESULT.json --truth T.json [--bag NAME] [--validation BAG [--joints J,…]] [--json OUT]``:
identified parameters vs the ground truth of synthetic data, and the noise floor."""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.cli._common import add_json_argument, fmt, save_json, split_list


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("result", type=Path, help="JSON written by 'frictionid identify'")
    p.add_argument("--truth", type=Path, required=True,
                   help="truth JSON ('frictionid synth --truth' or bags/tx40_truth.json)")
    p.add_argument("--bag", help="recording of a multi-bag truth file (default: the result's source)")
    p.add_argument("--validation", type=Path, help="validation recording: also report the OSA error vs its noise floor")
    p.add_argument("--joints", help="joints to load from the validation recording (default: the result's)")
    add_json_argument(p, "the comparison")


def run(args) -> int:
    from frictionid_core.jsonfile import read_json
    from frictionid_core.robots.compare import RESOLVE_TOLERANCE_PCT, Z95, compare, noise_floor, select_truth

    result = read_json(args.result, "an identification result")
    truth_all = read_json(args.truth, "a ground truth")
    out = compare(result, select_truth(truth_all, args.bag or result.get("source")))
    print(f"{args.result} vs truth ({args.truth}{'' if not args.bag else ' · ' + args.bag})")
    print(f"{'parameter':<22} {'estimate':>12} {'truth':>12} {'error %':>9} {'σ %':>9} {'err/σ':>7}  determined")
    for name, r in out["parameters"].items():
        print(f"{name:<22} {fmt(r['estimate']):>12} {fmt(r['truth']):>12} {fmt(r['relerr_pct'], 3):>9} "
              f"{fmt(r['sigma_pct'], 3):>9} {fmt(r['z'], 3):>7}  {'yes' if r['determined'] else 'no'}")
    s = out["summary"]
    print(f"{s['determined']} of {s['parameters']} parameters determined (σ < 1 % of |truth|): max |error| "
          f"{fmt(s['max_abs_relerr_pct_determined'])} %; max |z| over all {fmt(s['max_abs_z'])}")
    tol = f"{RESOLVE_TOLERANCE_PCT:g} %"
    print(f"{s['resolvable_5pct']} of {s['parameters']} resolvable to {tol} ({Z95:g} σ < {tol} of |truth|): "
          f"max |error| {fmt(s['max_abs_relerr_pct_resolvable_5pct'])} %; the other "
          f"{s['parameters'] - s['resolvable_5pct']} cannot be placed within {tol} with 95 % confidence "
          f"on this recording")
    if args.validation is not None:
        from frictionid_core.io import load

        series = load(args.validation, joints=split_list(args.joints) or result.get("joints"))
        vtruth = select_truth(truth_all, str(args.validation))
        out["validation"] = dict(noise_floor(series, result, vtruth), source=str(args.validation))
        v = out["validation"]
        print(f"validation {args.validation}: OSA relative error {v['relerr_pct']:.5g} % vs noise floor "
              f"{v['floor_relerr_pct']:.5g} % (true parameters): ratio {v['ratio']:.4f}")
    save_json(args.json, out)
    return 0
