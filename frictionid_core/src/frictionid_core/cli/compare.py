"""``frictionid compare FIT.json [FIT.json …] [--truth T.json [--bag NAME]] [--validation SRC …] [--json OUT]``:
two or more fits side by side (parameters, σ, differences, metrics, settings); with ``--truth`` each fit
against the ground truth of synthetic data; with ``--validation`` each fit's cross-test error (and, with
a truth, the noise floor)."""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from frictionid_core.cli._common import add_json_argument, fmt, refuse_overwriting, save_json, split_list, system_file
from frictionid_core.errors import FrictionIdError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("results", nargs="+", type=Path, metavar="FIT.json",
                   help="JSON written by 'frictionid identify' (two or more, or one with --truth), or two or more "
                        "payload files of 'frictionid payload'")
    p.add_argument("--truth", type=Path, help="truth JSON ('frictionid synth --truth' or bags/tx40_truth.json)")
    p.add_argument("--bag", help="recording of a multi-bag truth file (default: the result's source)")
    p.add_argument("--validation", type=Path, nargs="+", metavar="SRC",
                   help="validation recording(s): each fit's cross-test error (vs the noise floor with --truth)")
    p.add_argument("--joints", help="joints to load from the validation recording (default: each fit's)")
    p.add_argument("--layout", type=Path, help="YAML layout of validation CSVs not in frictionid's own format")
    add_json_argument(p, "the comparison")


def run(args) -> int:
    from frictionid_core.compare import compare_fits, fit_labels
    from frictionid_core.files import read_json
    from frictionid_core.identification import read_result

    payloads = _payload_files(args.results)
    if payloads:
        refuse_overwriting({"--json": args.json}, {"FIT.json": args.results})
        out = _print_payloads(payloads, args.results)
        save_json(args.json, out)
        return 0
    results = [read_result(path).to_dict() for path in args.results]
    refuse_overwriting({"--json": args.json}, {"FIT.json": args.results, "--truth": args.truth,
                                               "--validation": args.validation, "--layout": args.layout,
                                               "--system": [system_file(r["system"]) for r in results]})
    truth_all = read_json(args.truth, "a ground truth") if args.truth is not None else None
    if len(results) == 1:
        if truth_all is None:
            raise FrictionIdError("compare needs two or more fits, or one fit and --truth T.json")
        out = _truth_block(args.results[0], results[0], args, truth_all)
        if args.validation:
            entries = [_noise_floor_line(src, results[0], args, truth_all) for src in args.validation]
            out["validation"] = entries[0] if len(entries) == 1 else entries
        save_json(args.json, out)
        return 0
    labels = fit_labels(len(results))
    out = compare_fits(results, [str(p) for p in args.results])
    _print_fits(out)
    if truth_all is not None:
        out["truth"] = {}
        for lab, path, result in zip(labels, args.results, results):
            print()
            out["truth"][lab] = _truth_block(path, result, args, truth_all)
    if args.validation:
        out["validation"] = [_validation(src, labels, results, args, truth_all) for src in args.validation]
    save_json(args.json, out)
    return 0


# -------------------------------------------------------------------- payloads side by side
def _payload_files(paths: list[Path]) -> list:
    """The payloads of ``paths`` when they are payload files ('frictionid payload --json': a
    ``payload`` block and no ``params``), else []; FrictionIdError for a mix of both."""
    from frictionid_core.files import read_json
    from frictionid_core.identification import PayloadResult

    data = [read_json(p, "an identification result or a payload file") for p in paths]
    kinds = [isinstance(d, dict) and "payload" in d and "params" not in d for d in data]
    if not any(kinds):
        return []
    if not all(kinds):
        others = ", ".join(str(p) for p, k in zip(paths, kinds) if not k)
        raise FrictionIdError(f"{others}: not a payload file; compare takes identification results or payload files, "
                              "not both")
    return [PayloadResult.from_dict(d, where=str(p)).payload for d, p in zip(data, paths)]


def _print_payloads(payloads: list, paths: list[Path]) -> dict:
    """Print payloads side by side (value, σ per payload; difference and z against A); return the block."""
    from frictionid_core.compare import compare_payloads

    out = compare_payloads(payloads, [str(p) for p in paths])
    labels = [p["label"] for p in out["payloads"]]
    for p in out["payloads"]:
        print(f"{p['label']}: {p['file']} · payload on {p['link']} · {'feasible' if p['feasible'] else 'NOT feasible'}"
              f" · resolved {len(p['resolved'])} of 10")
    print(f"{'quantity':<14}" + "".join(f"{lab:>13}{'σ ' + lab:>11}" for lab in labels)
          + "".join(f"{lab + ' − ' + labels[0]:>14}{'z ' + lab:>9}" for lab in labels[1:]))
    for name, row in out["quantities"].items():
        print(f"{name:<14}" + "".join(f"{fmt(row['values'][lab]):>13}{fmt(row['sigma'][lab], 3):>11}" for lab in labels)
              + "".join(f"{fmt(row['difference'][lab], 4):>14} {fmt(row['z'][lab], 3):>8}" for lab in labels[1:]))
    print("units: kg, m (centre of mass in the link's frame), kg·m² (inertia about the centre of mass); σ — where "
          "held; z: difference in units of the combined σ")
    return out


# ----------------------------------------------------------------------- fits side by side
def _print_fits(out: dict) -> None:
    labels = [f["label"] for f in out["fits"]]
    others = labels[1:]
    for f in out["fits"]:
        source = ", ".join(f["source"]) if isinstance(f["source"], list) else f["source"]
        asym = " (asymmetric)" if f["asymmetric"] else ""
        print(f"{f['label']}: {f['file']} · {f['system']} · {f['friction']}{asym} · solver {f['solver']}"
              f" · source {source}")
    if out["settings"]:
        print("settings that differ:")
        for key, values in out["settings"].items():
            print(f"  {key:<28} " + " | ".join(f"{lab} {_short(v)}" for lab, v in values.items()))
    head = f"{'parameter':<22}" + "".join(f"{lab:>13}{'σ ' + lab:>11}" for lab in labels)
    head += "".join(f"{lab + ' − ' + labels[0]:>13}{'z ' + lab:>8}" for lab in others)
    print(head)
    for name, row in out["parameters"].items():
        line = f"{name:<22}" + "".join(f"{fmt(row['values'][lab]):>13}{fmt(row['sigma'][lab]):>11}" for lab in labels)
        line += "".join(f"{fmt(row['difference'][lab]):>13}{fmt(row['z'][lab], 3):>8}" for lab in others)
        print(line)
    print(f"z: difference in units of the combined σ √(σ_{labels[0]}² + σ²)")
    for name, having in out["only_in"].items():
        print(f"{name}: only in {', '.join(having)}")
    if out["metrics"]:
        print(f"{'metric':<22}" + "".join(f"{lab:>13}" for lab in labels))
        for m, values in out["metrics"].items():
            print(f"{m:<22}" + "".join(f"{fmt(values[lab]):>13}" for lab in labels))
    if out["per_joint"]:
        print(f"{'joint':<16}{'metric':<12}" + "".join(f"{lab:>13}" for lab in labels))
        for joint, metrics in out["per_joint"].items():
            for m, values in metrics.items():
                print(f"{joint:<16}{m:<12}" + "".join(f"{fmt(values[lab]):>13}" for lab in labels))
    for f in out["fits"]:
        for w in f["warnings"]:
            print(f"warning {f['label']}: {w}")


def _short(value, width: int = 40) -> str:
    text = str(value) if isinstance(value, (bool, list, dict)) else fmt(value)
    return text if len(text) <= width else text[: width - 1] + "…"


# ------------------------------------------------------------------------------- truth
def _truth_block(path: Path, result: dict, args, truth_all: dict) -> dict:
    """Print one fit against the truth; return {parameters, summary}."""
    from frictionid_core.compare import RESOLVE_TOLERANCE_PCT, Z95, compare, select_truth

    out = compare(result, select_truth(truth_all, args.bag or result.get("source")))
    print(f"{path} vs truth ({args.truth}{'' if not args.bag else ' · ' + args.bag})")
    print(f"{'parameter':<22} {'estimate':>12} {'truth':>12} {'error %':>9} {'σ %':>9} {'err/σ':>7} "
          f"{'robust σ':>10}  determined  1.96σ covers (σ, calibrated)")
    covers = {True: "yes", False: "NO", None: "—"}
    for name, r in out["parameters"].items():
        print(f"{name:<22} {fmt(r['estimate']):>12} {fmt(r['truth']):>12} {fmt(r['relerr_pct'], 3):>9} "
              f"{fmt(r['sigma_pct'], 3):>9} {fmt(r['z'], 3):>7} {fmt(r['sigma_robust'], 3):>10}  "
              f"{'yes' if r['determined'] else 'no':<10}  {covers[r['covered']]}, {covers[r['covered_robust']]}")
    s = out["summary"]
    print(f"{s['determined']} of {s['parameters']} parameters determined (σ < 1 % of |truth|): max |error| "
          f"{fmt(s['max_abs_relerr_pct_determined'])} %; max |z| over all {fmt(s['max_abs_z'])}")
    tol = f"{RESOLVE_TOLERANCE_PCT:g} %"
    print(f"{s['resolvable_5pct']} of {s['parameters']} resolvable to {tol} ({Z95:g} σ < {tol} of |truth|): "
          f"max |error| {fmt(s['max_abs_relerr_pct_resolvable_5pct'])} %; the other "
          f"{s['parameters'] - s['resolvable_5pct']} cannot be placed within {tol} with 95 % confidence "
          f"on this recording")
    (hit, n), cal = s["coverage"], s["coverage_calibrated"]
    share = f" ({100 * cal['share']:.0f} %)" if cal["identified"] else ""
    print(f"coverage (identified parameters whose |error| ≤ {Z95:g} σ; about 95 % when σ is honest): calibrated σ "
          f"(std_robust) {cal['covered']} of {cal['identified']}{share}; white-noise σ (std) {hit} of {n}")
    return out


# -------------------------------------------------------------------------- validation
def _load(src: Path, result: dict, args):
    joints = split_list(args.joints) or result.get("joints")
    return _load_once(src, tuple(joints) if joints else None, args.layout)


@functools.lru_cache(maxsize=4)
def _load_once(src: Path, joints: tuple[str, ...] | None, layout: Path | None):
    """A validation recording, read once for every fit that loads the same joints."""
    from frictionid_core.io import load

    return load(src, joints=list(joints) if joints else None, layout=layout)


def _noise_floor_line(src: Path, result: dict, args, truth_all: dict, label: str = "") -> dict:
    """Print (and return) a fit's cross-test error on ``src`` against the truth's noise floor."""
    from frictionid_core.compare import noise_floor, select_truth
    from frictionid_core.model import check_finite

    v = dict(noise_floor(_load(src, result, args), result, select_truth(truth_all, str(src))), source=str(src))
    check_finite(v, f"{label}the cross-test on {src}", ("relerr_pct", "floor_relerr_pct"))
    print(f"{label}validation {src}: OSA relative error {v['relerr_pct']:.5g} % vs noise floor "
          f"{v['floor_relerr_pct']:.5g} % (true parameters): ratio {v['ratio']:.4f}")
    return v


def _validation(src: Path, labels: list[str], results: list[dict], args, truth_all: dict | None) -> dict:
    """Every fit cross-tested on ``src``: {source, fits: {label: metrics (+ noise floor with a truth)}}."""
    from frictionid_core.identification import validate
    from frictionid_core.model import check_finite

    if truth_all is not None:
        return {"source": str(src), "fits": {lab: _noise_floor_line(src, r, args, truth_all, f"{lab}: ")
                                             for lab, r in zip(labels, results)}}
    fits = {lab: check_finite(validate(_load(src, r, args), r), f"the cross-test of fit {lab} on {src}")
            for lab, r in zip(labels, results)}
    print(f"validation {src}: relerr_pct " + ", ".join(f"{lab} {fmt(m['relerr_pct'])}" for lab, m in fits.items()))
    for joint in dict.fromkeys(j for m in fits.values() for j in (m.get("per_joint") or {})):
        print(f"  {joint}: relerr_pct " + ", ".join(
            f"{lab} {fmt((m.get('per_joint') or {}).get(joint, {}).get('relerr_pct'))}" for lab, m in fits.items()))
    return {"source": str(src), "fits": fits}
