"""``frictionid export RESULT.json [--payload P.json] [--urdf OUT.urdf] [--mujoco OUT.xml] [--yaml OUT.yaml]
[--force]``: a robot result's identified parameters (and a payload on one of its links) as a URDF, a
MuJoCo model and a parameters file."""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.errors import FrictionIdError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("result", type=Path, help="result of 'frictionid identify --system tx40|urdf:PATH' "
                                             "(best with --consistent)")
    p.add_argument("--urdf", type=Path, metavar="OUT.urdf", help="the robot's URDF with the identified inertials "
                                                                 "and <dynamics damping=Fv friction=Fc>")
    p.add_argument("--mujoco", type=Path, metavar="OUT.xml", help="MuJoCo MJCF: inertials, joint damping = Fv, "
                                                                  "frictionloss = Fc, armature = rotor inertia")
    p.add_argument("--yaml", type=Path, metavar="OUT.yaml", help="parameters file for the node and 'validate'")
    p.add_argument("--payload", type=Path, metavar="P.json",
                   help="a payload ('frictionid payload --json') to fix to its link: a fixed link 'payload' in the "
                        "URDF and MuJoCo model, a 'payload' block (and its re-fitted friction levels) in the YAML")
    p.add_argument("--force", action="store_true",
                   help="export even when the result is not physically consistent or its links are implausible "
                        "against the robot model")


def run(args) -> int:
    from frictionid_core.cli._common import refuse_overwriting, system_file
    from frictionid_core.export import export_data, mujoco_text, urdf_text, yaml_text
    from frictionid_core.files import write_text
    from frictionid_core.identification import payload_of, read_result
    from frictionid_core.systems import result_system

    if not (args.urdf or args.mujoco or args.yaml):
        raise FrictionIdError("nothing to export: give --urdf, --mujoco and/or --yaml")
    result = read_result(args.result)
    refuse_overwriting({"--urdf": args.urdf, "--mujoco": args.mujoco, "--yaml": args.yaml},
                       {"RESULT": args.result, "--system": system_file(result.system), "--payload": args.payload})
    result, payload = payload_of(result, args.result, args.payload)
    data = export_data(result, result_system(result), args.force, payload)
    if data.note:
        print(data.note)
    if not data.feasible:
        print("frictionid: warning: exporting an inconsistent or implausible result (--force): "
              + "; ".join(data.problems))
    for joint, m in data.match.items():
        if m["loss_pct"] > 0.0 or m.get("lost"):
            f = data.friction[joint]
            print(f"{joint}: {m['law']} friction exported as damping {f['Fv']:.6g}, frictionloss {f['Fc']:.6g} "
                  f"(least squares over |v| {m['speeds'][0]:.3g}…{m['speeds'][1]:.3g}, {m['speeds_from']}): loses "
                  f"{m['loss_pct']:.3g} % (RMS) of the law" + (f"; lost: {m['lost']}" if m.get("lost") else ""))
    urdf = urdf_text(data) if (args.urdf or args.mujoco) else None
    texts = []  # every text before any file is written
    if args.urdf:
        texts.append((args.urdf, urdf))
    if args.mujoco:
        texts.append((args.mujoco, mujoco_text(data, urdf)))
    if args.yaml:
        texts.append((args.yaml, yaml_text(data)))
    for path, text in texts:
        print(f"wrote {write_text(path, text)}")
    return 0
