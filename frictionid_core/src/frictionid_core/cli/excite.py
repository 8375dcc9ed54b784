"""``frictionid excite --system tx40 --out traj.npz [--joints J,…] [--hold J=RAD,…] [--harmonics 5] [--period 10]
[--duration 20] [--ramp S] [--evals 1500] [--seed 0] [--margin 0.05] [--max-acc A | J=A,…] [--params R.json]
[--collision [--clearance 0.01] [--floor Z]] [--dwell SECONDS [--dwell-vs 0.05]]``: optimise a Fourier excitation
trajectory within every limit of the robot and write it (.npz or .csv)."""

from __future__ import annotations

import argparse
import time
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
    p.add_argument("--duration", type=float, default=20.0,
                   help="trajectory length, s, ramps included (default 20)")
    p.add_argument("--ramp", type=float,
                   help="the motion rises from and returns to rest at its start pose over this many seconds at "
                        "each end (default min(2, duration/4))")
    p.add_argument("--evals", type=int, default=1500, help="criterion evaluations (default 1500)")
    p.add_argument("--starts", type=int, default=20, help="random starting shapes (default 20)")
    p.add_argument("--margin", type=float, default=0.05,
                   help="safety margin, fraction: every position |q − centre|/half-range, velocity, acceleration "
                        "and effort / its limit stays ≤ 1 − margin (default 0.05)")
    p.add_argument("--max-acc", metavar="A|JOINT=A,…",
                   help="acceleration limits, rad/s² (m/s²): one value for every joint or JOINT=A,… (default: the "
                        "model's: the TX40's table, 10 for a URDF)")
    p.add_argument("--params", type=Path, metavar="R.json",
                   help="an identification result of this robot: its friction enters the effort (default: the "
                        "TX40's published friction, a URDF's <dynamics>, else 5 %% + 5 %% of the effort limit)")
    p.add_argument("--collision", action="store_true",
                   help="keep every pair of non-adjacent links --clearance apart (the URDF's collision geometry)")
    p.add_argument("--clearance", type=float, metavar="M",
                   help="with --collision: the distance every checked pair keeps, m (default 0.01)")
    p.add_argument("--floor", type=float, metavar="Z",
                   help="keep every moving link --clearance above the plane z = Z of the base frame, m (implies "
                        "--collision)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--rate", type=float, default=1000.0,
                   help="sample rate of a .csv output and of the final verification (at least 1000), Hz (default "
                        "1000)")
    p.add_argument("--dwell", type=float, default=0.0,
                   help="append this many seconds of constant-velocity plateaus (±0.2, 0.6, 1.25, 2.5 × "
                        "--dwell-vs) after the Fourier part, for the Stribeck shapes (default 0: none)")
    p.add_argument("--dwell-vs", type=float, default=0.05, help="nominal Stribeck speed vs, rad/s (default 0.05)")
    add_json_argument(p, "a report")


def parse_acceleration(text: str | None) -> dict[str, float] | float | None:
    """``--max-acc``: one value (every joint) or JOINT=A,… → float or {joint: A}."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return parse_joint_values(text, "--max-acc", "RAD/S²")


def run(args) -> int:
    import dataclasses

    import numpy as np

    from frictionid_core.excitation import (
        DEFAULT_CLEARANCE,
        add_dwell,
        design_excitation,
        load_collision_model,
        result_friction,
        robot_limits,
        robot_of,
        verify,
        violation_text,
    )
    from frictionid_core.systems import get_system

    start = time.perf_counter()
    refuse_overwriting({"--out": args.out, "--json": args.json},
                       {"--system": system_file(args.system), "--params": args.params})
    if not args.dwell >= 0:
        raise InputError(f"--dwell must be ≥ 0 s, got {args.dwell:g}")
    collide = args.collision or args.floor is not None
    if args.clearance is not None and not collide:
        raise InputError("--clearance goes with --collision (or --floor)")
    if not (np.isfinite(args.rate) and args.rate > 0):
        raise InputError(f"--rate must be > 0 Hz, got {args.rate:g}")
    system = get_system(args.system)
    robot, default_moving = robot_of(system, args.system)
    moving = split_list(args.joints) or default_moving
    friction = None
    if args.params is not None:
        from frictionid_core.identification import read_result

        friction = result_friction(read_result(args.params).to_dict(), robot, str(args.params))
    limits = robot_limits(robot, args.margin, parse_acceleration(args.max_acc), friction)
    collision = None
    if collide:
        urdf = system_file(args.system)
        if urdf is None:
            raise InputError(f"--collision needs a URDF with collision geometry (--system urdf:PATH); {args.system} "
                             "has none")
        clearance = DEFAULT_CLEARANCE if args.clearance is None else args.clearance
        collision = load_collision_model(robot, urdf, clearance, args.floor)
    verify_rate = max(1000.0, args.rate)
    design = design_excitation(system, robot, limits=limits, moving=moving,
                               hold=parse_joint_values(args.hold, "--hold", "RAD"), harmonics=args.harmonics,
                               period=args.period, duration=args.duration, ramp=args.ramp, evals=args.evals,
                               starts=args.starts, seed=args.seed, collision=collision, verify_rate=verify_rate)
    traj = design.trajectory
    if args.dwell > 0:
        bounded = dataclasses.replace(robot, acceleration_limit=limits.acceleration)
        traj = add_dwell(bounded, traj, args.dwell, args.dwell_vs, args.margin)
        design.report = verify(robot, limits, traj, verify_rate, collision)
        if not design.report["ok"]:
            raise InputError(f"--dwell {args.dwell:g}: the plateaus leave the limits: "
                             + violation_text(design.report, args.margin))
    traj.save(args.out, args.rate)
    seconds = time.perf_counter() - start
    print(f"excitation for {args.system} ({robot.name}): cond {design.cond_initial:.4g} → {design.cond:.4g} "
          f"after {design.evaluations} evaluations; written to {args.out} ({seconds:.1f} s)")
    for note in design.notes:
        print(note)
    if args.dwell > 0:
        print(f"then {args.dwell:g} s of plateaus at ± {', '.join(f'{v:.4g}' for v in traj.speeds)} rad/s "
              f"({', '.join(f'{h:.3g}' for h in traj.plateau_s)} s each sign, entry ramp {traj.entry_s:g} s); "
              f"{traj.duration:g} s in all")
    _print_table(robot, limits, traj, verify_rate)
    rep = design.report
    print("max ratio to the limits (≤ " + f"{1 - args.margin:.3g}): "
          + ", ".join(f"{k} {v:.3g} ({rep['worst'][k]['joint']})" for k, v in rep["max_ratio"].items()))
    if collision is not None:
        print(f"min clearance {rep['min_clearance_m'] * 1000:.2f} mm (≥ {collision.clearance * 1000:.3g} mm) between "
              f"{rep['closest']['pair'].replace('|', ' and ')} at t = {rep['closest']['t']:.3f} s; "
              f"{len(collision.pairs)} pairs checked")
    print("start pose (rad): " + ", ".join(f"{j} {v:.4g}" for j, v in zip(robot.joints, design.trajectory.start_pose)))
    print(f"effort: inverse dynamics + friction from {limits.friction.source}")
    report = dict(design.to_dict(), system=args.system, out=str(args.out), trajectory=traj.to_dict(),
                  wall_time_s=seconds)
    if collision is not None:
        report["collision"] = {"clearance_m": collision.clearance, "floor_z": collision.floor,
                               "pairs": collision.pairs, "mesh_pairs": collision.mesh_pairs,
                               "excluded": collision.excluded}
    save_json(args.json, report)
    return 0


def _print_table(robot, limits, traj, rate: float) -> None:
    import numpy as np

    _, q, qd, qdd = traj.sample(rate)
    tau = np.abs(robot.inverse_dynamics(q, qd, qdd) + limits.friction.torque(qd)).max(axis=0)
    print(f"{'joint':<20}{'q min':>9}{'q max':>9}{'|q̇| max':>9}{'lim':>7}{'|q̈| max':>9}{'lim':>7}{'|τ| max':>9}"
          f"{'lim':>8}")
    for k, j in enumerate(robot.joints):
        print(f"{j:<20}{q[:, k].min():>9.4g}{q[:, k].max():>9.4g}{np.abs(qd[:, k]).max():>9.4g}"
              f"{limits.velocity[k]:>7.3g}{np.abs(qdd[:, k]).max():>9.4g}{limits.acceleration[k]:>7.3g}"
              f"{tau[k]:>9.4g}{limits.effort[k]:>8.4g}")
