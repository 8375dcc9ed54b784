"""Friction feed-forward torque from a results file, as the ROS node computes it (no ROS needed).

    python examples/feedforward_torque.py RESULT.json [OUT_DIR] [--eps 0.01] [--velocities=-0.1,0,0.1]

RESULT.json is written by ``frictionid identify --json`` (or the node's results file). For
each joint, τ_ff = the identified friction at velocity v (no rigid-body terms, no offset),
with sign(v) smoothed to tanh(v/eps) against chatter at zero speed: the node's default
eps is 0.01 (rad/s or m/s, parameter ``smoothing_eps``). Prints one row per velocity; with
OUT_DIR, also writes OUT_DIR/feedforward.csv.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import frictionid_core as fid


def joint_parameters(result: dict) -> dict[str, np.ndarray]:
    """{joint: friction parameter vector in the model's order} of an identification result.
    With several joints, parameter names are prefixed ``<joint>/``."""
    model = fid.FrictionModel(result["friction"], bool(result["asymmetric"]))
    joints = result["joints"]
    prefixes = {j: (f"{j}/" if len(joints) > 1 else "") for j in joints}
    return {j: np.array([result["params"][p + n] for n in model.names]) for j, p in prefixes.items()}


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("result", type=Path, help="JSON written by 'frictionid identify --json'")
    parser.add_argument("out_dir", type=Path, nargs="?", help="folder for feedforward.csv")
    parser.add_argument("--eps", type=float, default=0.01, help="sign smoothing tanh(v/eps) (default 0.01; 0: sign)")
    parser.add_argument("--velocities", default="-0.2,-0.05,-0.01,0,0.01,0.05,0.2",
                        help="comma-separated joint velocities, rad/s or m/s")
    args = parser.parse_args(argv)

    result = json.loads(args.result.read_text())
    model = fid.FrictionModel(result["friction"], bool(result["asymmetric"]))
    velocities = np.array([float(v) for v in args.velocities.split(",")])
    # One torque column per joint: model.torque evaluates all velocities in one call.
    torques = {j: model.torque(theta, velocities, eps=args.eps) for j, theta in joint_parameters(result).items()}

    print(f"{model.label} friction feed-forward, eps {args.eps:g}")
    print(f"{'velocity':>10}" + "".join(f"{j:>14}" for j in torques))
    for i, v in enumerate(velocities):
        print(f"{v:>10.4g}" + "".join(f"{t[i]:>14.6g}" for t in torques.values()))
    if args.out_dir:
        args.out_dir.mkdir(parents=True, exist_ok=True)
        path = args.out_dir / "feedforward.csv"
        np.savetxt(path, np.column_stack([velocities, *torques.values()]), delimiter=",",
                   header=",".join(["velocity", *torques]), comments="", fmt="%.10g")
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
