"""``frictionid consistency RESULT.json [--prior model|generic] [--json OUT]``: physical consistency of a
robot identification result (exit code 3: no consistent parameters found)."""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.cli._common import add_json_argument, refuse_overwriting, save_json, system_file

EXIT_NOT_FEASIBLE = 3


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("result", type=Path, help="JSON written by 'frictionid identify --system tx40|urdf:PATH'")
    p.add_argument("--prior", choices=("model", "generic"), default="model",
                   help="standard parameters to stay close to: the model's own (default) or generic bodies")
    add_json_argument(p, "the report")


def run(args) -> int:
    from frictionid_core.consistency import report_for_result
    from frictionid_core.identification import read_result
    from frictionid_core.systems import result_system

    result = read_result(args.result)
    refuse_overwriting({"--json": args.json}, {"RESULT": args.result, "--system": system_file(result.system)})
    result = result.to_dict()
    rep = report_for_result(result, result_system(result), args.prior)
    print(f"physical consistency of {args.result} ({rep['system']}): "
          f"{'FEASIBLE' if rep['feasible'] else 'NOT FOUND FEASIBLE'} — {rep['method']}")
    print(f"{'body':<14}{'mass':>10}{'λmin(J)':>12}{'triangle':>10}{'ok':>5}")
    for j, b in rep["bodies"].items():
        print(f"{j:<14}{b['mass']:>10.4g}{b['pseudo_inertia_min_eig']:>12.3g}"
              f"{str(b.get('triangle_inequalities', '—')):>10}{'yes' if b['consistent'] else 'NO':>5}")
    print("rotor Ia:", ", ".join(f"{j} {r['Ia']:.4g}" for j, r in rep["rotors"].items()))
    print(f"max |A·π − β̂| = {rep['base_residual_max']:.3g}")
    save_json(args.json, rep)
    return 0 if rep["feasible"] else EXIT_NOT_FEASIBLE
