"""``frictionid payload SOURCE [SOURCE ...] --base BASE.json [--link LINK] [--refit-friction] [--json P.json]``:
the mass, centre of mass and inertia of a rigid body fixed to a link, from a log recorded with it and
the unloaded result BASE.json (rigid body, friction and drive held).

The source options (``--layout``, ``--drive``, ``--start/--end``, ``--joints``, ``--topic``, …), the
holds and the pre-processing flags are ``identify``'s; the pre-processing is the base result's,
re-chosen from these data as ``validate`` does.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.cli._common import (
    add_drive_argument,
    add_hold_arguments,
    add_source_arguments,
    drive_option,
    fmt,
    hold_option,
    load_sources,
    preprocessing_line,
    print_metrics,
    refuse_overwriting,
    save_json,
    source_inputs,
    split_list,
    system_file,
    warn,
    window_of,
)
from frictionid_core.cli.identify import add_preprocessing_arguments, preprocessing_fields


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_source_arguments(p)
    p.add_argument("--base", type=Path, required=True, metavar="BASE.json",
                   help="result of 'frictionid identify --system tx40|urdf:PATH' on the robot without the payload")
    p.add_argument("--link", help="the link the payload is fixed to (default: the last link of the chain, e.g. tool0)")
    p.add_argument("--refit-friction", action="store_true",
                   help="also fit the friction levels (Fv, Fc, Fs) again: friction rises with the load in geared "
                        "joints")
    add_drive_argument(p, "default: the base result's")
    add_hold_arguments(p)
    add_preprocessing_arguments(p)


def run(args) -> int:
    from dataclasses import replace

    from frictionid_core.identification import PayloadRequest, PreprocessingOverrides, identify_payload, read_result

    base = read_result(args.base)
    refuse_overwriting({"--json": args.json}, {**source_inputs(args), "--base": args.base,
                                               "--system": system_file(base.system)})
    drive = drive_option(args)
    if drive is not None:
        base = replace(base, drive=drive.to_dict())
    request = PayloadRequest(link=args.link, refit_friction=args.refit_friction, joints=split_list(args.joints),
                             hold=hold_option(args), hold_missing=args.hold_missing,
                             preprocessing=PreprocessingOverrides(**preprocessing_fields(args)), window=window_of(args))
    result = identify_payload(load_sources(args), base, request, base_file=str(args.base))
    print_payload(result.to_dict())
    warn(result.warnings)
    save_json(args.json, result.to_dict())
    return 0


def print_payload(out: dict) -> None:
    """The payload's table (value, σ, resolved or held), re-fitted friction, and the loaded log's metrics."""
    p = out["payload"]
    source = ", ".join(out["source"]) if isinstance(out["source"], list) else out["source"]
    print(f"payload on {p['link']} · {out['system']} · base {out['base']} · source {source}")
    if out.get("preprocessing"):
        print(preprocessing_line(out["preprocessing"]))
    print(f"{'quantity':<14}{'value':>14}{'σ':>12}  ")
    for name, value, sigma in _rows(p):
        state = "resolved" if name in p["resolved"] else "held (point mass)"
        print(f"{name:<14}{fmt(value):>14}{fmt(sigma, 3):>12}  {state}")
    print(f"units: kg, m (centre of mass in {p['link']}'s frame), kg·m² (inertia about the centre of mass); "
          f"physically consistent: {'yes' if p['feasible'] else 'NO'}")
    if out.get("friction_refit"):
        f = out["friction_refit"]
        print(f"{'friction level':<22}{'base':>12}{'re-fitted':>12}{'σ':>10}")
        for name, value in f["params"].items():
            print(f"{name:<22}{fmt(f['base'][name]):>12}{fmt(value):>12}{fmt(f['std'][name], 3):>10}")
    print(f"on the loaded log: relerr {fmt(out['metrics_base'].get('relerr_pct'), 4)} % with the base alone, "
          f"{fmt(out['metrics'].get('relerr_pct'), 4)} % with the payload")
    print_metrics(out["metrics"])


def _rows(p: dict) -> list[tuple[str, float, float | None]]:
    """(quantity, value, σ) in the order of the payload's ``resolved`` names."""
    from frictionid_core.robots import INERTIA_ENTRIES

    sigma = p.get("sigma") or {}
    out = [("mass", p["mass"], sigma.get("mass"))]
    out += [(f"com.{a}", p["com"][k], (sigma.get("com") or [None] * 3)[k]) for k, a in enumerate("xyz")]
    for key, (a, b) in INERTIA_ENTRIES.items():
        out.append((f"inertia.{key}", p["inertia"][a][b], ((sigma.get("inertia") or [[None] * 3] * 3)[a][b])))
    return out
