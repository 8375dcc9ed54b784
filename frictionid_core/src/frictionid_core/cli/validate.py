"""``frictionid validate SOURCE [SOURCE ...] --params OUT.json [--start S] [--end S] [--json V.json]``:
cross-test identified parameters.

System, joint map, joints, friction, drive and pre-processing come from the parameter file;
``--system``/``--joint-map``/``--joints`` override them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.cli._common import (add_drive_argument, add_source_arguments, drive_option, load_sources,
                                         print_metrics, save_json, split_list, window_of)


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_source_arguments(p)
    p.add_argument("--params", type=Path, required=True, help="JSON written by 'frictionid identify'")
    add_drive_argument(p, "default: the result's")
    p.add_argument("--system", help="inverse dynamic model (default: the parameter file's)")
    p.add_argument("--joint-map", help="bag joint → model joint names (default: the parameter file's): a=b,c=d")


def run(args) -> int:
    from frictionid_core.identification import validate, window_record
    from frictionid_core.identification.plausibility import check_metrics
    from frictionid_core.jsonfile import read_json
    from frictionid_core.systems import parse_joint_map

    params = read_json(args.params, "parameters")
    drive = drive_option(args)
    if drive is not None:
        params = {**params, "drive": drive.to_dict()}
    sources = load_sources(args)
    joint_map = None if args.joint_map is None else parse_joint_map(args.joint_map)
    metrics = validate(sources, params, system=args.system, joint_map=joint_map, joints=split_list(args.joints),
                       window=window_of(args))
    names = [s.source for s in sources]
    check_metrics(metrics, f"cross-test of {args.params} on {', '.join(names)}: its")
    out = {"source": names[0] if len(names) == 1 else names, "params_file": str(args.params),
           "system": args.system or params.get("system"), "friction": params.get("friction"),
           "asymmetric": params.get("asymmetric"), "drive": params.get("drive"),
           "layout": None if args.layout is None else str(args.layout), "window": window_record(window_of(args)),
           "metrics": metrics}
    print(f"cross-test of {args.params} on {', '.join(names)}")
    print_metrics(metrics)
    save_json(args.json, out)
    return 0
