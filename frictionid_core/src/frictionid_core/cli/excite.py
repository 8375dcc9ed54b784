"""``frictionid excite --system tx40 --out traj.npz [--joints J,…] [--hold J=RAD,…] [--harmonics 5] [--period 10]
[--duration 20] [--evals 1500] [--seed 0] [--dwell SECONDS [--dwell-vs 0.05]]``: optimise a Fourier excitation
trajectory and write it (.npz or .csv)."""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.cli._common import (
    add_json_argument,
    parse_joint_values,
    refuse_overwriting,
    save_json,
    split_list,
    system_file,
)
from frictionid_core.errors import InputError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--system", required=True,
                   help="tx40 | tx40-j2 | urdf:PATH (the model whose columns are conditioned)")
    p.add_argument("--out", type=Path, required=True, help="trajectory file: .npz (coefficients) or .csv (samples)")
    p.add_argument("--joints", help="joints that move (default: all; tx40-j2: joint_2)")
    p.add_argument("--hold", help="positions of the joints that do not move, JOINT=RAD,… (default 0)")
    p.add_argument("--harmonics", type=int, default=5, help="Fourier harmonics L (default 5)")
    p.add_argument("--period", type=float, default=10.0, help="fundamental period 2π/ω_f, s (default 10)")
    p.add_argument("--duration", type=float, default=20.0, help="trajectory length, s (default 20)")
    p.add_argument("--evals", type=int, default=1500, help="criterion evaluations (default 1500)")
    p.add_argument("--starts", type=int, default=20, help="random starting shapes (default 20)")
    p.add_argument("--margin", type=float, default=0.05, help="safety margin on the limits, fraction (default 0.05)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--rate", type=float, default=1000.0, help="sample rate of a .csv output, Hz (default 1000)")
    p.add_argument("--dwell", type=float, default=0.0,
                   help="append this many seconds of constant-velocity plateaus (±0.2, 0.6, 1.25, 2.5 × "
                        "--dwell-vs) after the Fourier part, for the Stribeck shapes (default 0: none)")
    p.add_argument("--dwell-vs", type=float, default=0.05, help="nominal Stribeck speed vs, rad/s (default 0.05)")
    add_json_argument(p, "a report")


def run(args) -> int:
    import numpy as np

    from frictionid_core.excitation import add_dwell, optimise_excitation, robot_of
    from frictionid_core.systems import get_system

    refuse_overwriting({"--out": args.out, "--json": args.json}, {"--system": system_file(args.system)})
    system = get_system(args.system)
    robot, default_moving = robot_of(system, args.system)
    moving = split_list(args.joints) or default_moving
    res = optimise_excitation(system, robot, moving=moving, hold=parse_joint_values(args.hold, "--hold", "RAD"),
                              harmonics=args.harmonics, period=args.period, duration=args.duration,
                              evals=args.evals, starts=args.starts, seed=args.seed, margin=args.margin)
    traj = res.trajectory
    if not args.dwell >= 0:
        raise InputError(f"--dwell must be ≥ 0 s, got {args.dwell:g}")
    if args.dwell > 0:
        traj = add_dwell(robot, traj, args.dwell, args.dwell_vs, args.margin)
    traj.save(args.out, args.rate)
    t, q, qd, qdd = traj.sample(args.rate)
    print(f"excitation for {args.system} ({robot.name}): cond {res.cond_initial:.4g} → {res.cond:.4g} "
          f"after {res.evaluations} evaluations; written to {args.out}")
    if args.dwell > 0:
        print(f"then {args.dwell:g} s of plateaus at ± {', '.join(f'{v:.4g}' for v in traj.speeds)} rad/s "
              f"({', '.join(f'{h:.3g}' for h in traj.plateau_s)} s each sign, entry ramp {traj.entry_s:g} s); "
              f"{traj.duration:g} s in all")
    print(f"{'joint':<14}{'q min':>10}{'q max':>10}{'|q̇| max':>10}{'lim':>8}{'|q̈| max':>10}{'lim':>8}")
    for k, j in enumerate(robot.joints):
        print(f"{j:<14}{q[:, k].min():>10.4g}{q[:, k].max():>10.4g}{np.abs(qd[:, k]).max():>10.4g}"
              f"{robot.velocity_limit[k]:>8.3g}{np.abs(qdd[:, k]).max():>10.4g}{robot.acceleration_limit[k]:>8.3g}")
    save_json(args.json, dict(res.to_dict(), system=args.system, out=str(args.out), trajectory=traj.to_dict()))
    return 0
