"""``frictionid validate SOURCE [SOURCE ...] --params OUT.json [--start S] [--end S] [--cutoff HZ|JOINT=HZ,…]
[--decimate N] [--trim S[:S]] [--min-speed V] [--json V.json] [--residuals R.csv]``: cross-test identified
parameters.

System, joint map, joints, friction, drive and pre-processing come from the parameter file;
``--system``/``--joint-map``/``--joints`` override them. The pre-processing settings the
identification chose from its data are chosen again from these data (its fixed ones are kept);
the pre-processing flags, the same as ``identify``'s, fix them. The line ``preprocessing: …`` and the
JSON's ``preprocessing`` block say which were re-chosen, kept and set.
"""

from __future__ import annotations

import argparse
import csv
import io
from pathlib import Path

from frictionid_core.cli._common import (
    add_drive_argument,
    add_source_arguments,
    drive_option,
    load_sources,
    preprocessing_line,
    print_metrics,
    refuse_overwriting,
    save_json,
    source_inputs,
    split_list,
    system_file,
    window_of,
)
from frictionid_core.cli.identify import add_preprocessing_arguments, preprocessing_fields


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_source_arguments(p)
    p.add_argument("--params", type=Path, required=True, help="JSON written by 'frictionid identify'")
    p.add_argument("--payload", type=Path, metavar="P.json",
                   help="a payload ('frictionid payload --json') on the robot: its torque (and re-fitted friction "
                        "levels) added to the parameters' (default: the payload the parameters file carries, if any)")
    add_drive_argument(p, "default: the result's")
    p.add_argument("--system", help="inverse dynamic model (default: the parameter file's)")
    p.add_argument("--joint-map", help="bag joint → model joint names (default: the parameter file's): a=b,c=d")
    add_preprocessing_arguments(p)
    p.add_argument("--residuals", type=Path, metavar="R.csv",
                   help="write the compared instants as CSV: source, t (s on the source's clock) and per joint "
                        "the effort the metrics compare, the prediction and whether they count the row (1/0)")


def residuals_csv(residuals: dict, sources: list[str]) -> str:
    """The text of ``--residuals``: a header ``source,t,<joint>.effort,<joint>.predicted,<joint>.used,…``
    and one line per analysis instant of :func:`~frictionid_core.identification.validation_residuals`
    (numbers to 10 significant digits, efforts in the joint's units: N·m or N)."""
    import numpy as np

    joints = residuals["joints"]
    header = ["source", "t"] + [f"{j}.{k}" for j in joints for k in ("effort", "predicted", "used")]
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(header)
    per_joint = [np.column_stack([residuals["effort"][j], residuals["predicted"][j], residuals["used"][j]])
                 for j in range(len(joints))]
    table = np.column_stack([residuals["t"], *per_joint])
    for k, name in enumerate(sources):
        quoted = io.StringIO()
        csv.writer(quoted, lineterminator="").writerow([name])
        fmt = quoted.getvalue().replace("%", "%%") + ",%.10g" + ",%.10g,%.10g,%d" * len(joints)
        np.savetxt(buffer, table[residuals["source"] == k], fmt=fmt)
    return buffer.getvalue()


def run(args) -> int:
    from dataclasses import replace

    from frictionid_core.identification import (
        PreprocessingOverrides,
        check_metrics,
        model_from_result,
        payload_of,
        read_result,
        validation_metrics,
        validation_record,
        window_record,
    )
    from frictionid_core.systems import parse_joint_map

    result = read_result(args.params)
    refuse_overwriting({"--json": args.json, "--residuals": args.residuals},
                       {**source_inputs(args), "--params": args.params,
                        "--system": system_file(args.system or result.system), "--payload": args.payload})
    drive = drive_option(args)
    if drive is not None:
        result = replace(result, drive=drive.to_dict())
    loaded, payload = payload_of(result, args.params, args.payload)
    overrides = PreprocessingOverrides(**preprocessing_fields(args))
    sources = load_sources(args)
    joint_map = None if args.joint_map is None else parse_joint_map(args.joint_map)
    names = [s.source for s in sources]
    model, x = model_from_result(sources, loaded, system=args.system, joint_map=joint_map,
                                 joints=split_list(args.joints), preprocessing=overrides, window=window_of(args),
                                 payload=payload)
    metrics = validation_metrics(model, x, names)
    check_metrics(metrics, f"the cross-test of {args.params} on {', '.join(names)}")
    record = validation_record(model)
    out = {"source": names[0] if len(names) == 1 else names, "params_file": str(args.params),
           "system": args.system or result.system, "friction": result.friction,
           "asymmetric": result.asymmetric, "drive": result.drive,
           "layout": None if args.layout is None else str(args.layout), "window": window_record(window_of(args)),
           "preprocessing": record, "metrics": metrics}
    if payload is not None:
        out["payload"] = payload.to_dict()
    loaded = "" if payload is None else f" with a {payload.mass:.4g} kg payload on {payload.link}"
    print(f"cross-test of {args.params}{loaded} on {', '.join(names)}")
    print(preprocessing_line(record))
    print_metrics(metrics)
    save_json(args.json, out)
    if args.residuals is not None:
        from frictionid_core.files import write_text
        from frictionid_core.identification import validation_residuals

        write_text(args.residuals, residuals_csv(validation_residuals(model, x), names))
    return 0
