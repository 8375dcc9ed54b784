"""``frictionid synth TRAJ --system tx40 --out BAG [--friction stribeck] [--asymmetric] [--friction-params F.json]
[--offsets J=V,…] [--position-noise RAD[,…]] [--torque-noise 0.05] [--rate 1000] [--seed 0] [--truth T.json]
[--names A,B,…] [--drive FILE|NAME]``: trajectory → synthetic JointState bag (+ ground-truth JSON)."""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from frictionid_core.cli._common import (
    add_drive_argument,
    drive_file,
    drive_option,
    parse_joint_values,
    refuse_overwriting,
    save_json,
    split_list,
    system_file,
)
from frictionid_core.errors import FrictionIdError, InputError


def add_arguments(p: argparse.ArgumentParser) -> None:
    from frictionid_core.friction import FRICTIONS

    p.add_argument("trajectory", type=Path,
                   help="trajectory from 'frictionid excite' (.npz) or CSV (t, q:<joint>, …)")
    p.add_argument("--system", required=True, help="robot: tx40 | tx40-j2 (the TX40) | urdf:PATH")
    p.add_argument("--out", type=Path, required=True, help="bag directory to create (MCAP)")
    p.add_argument("--friction", default="stribeck", choices=FRICTIONS, help="friction law (default stribeck)")
    p.add_argument("--asymmetric", action="store_true", help="asymmetric friction (v > 0 and v < 0 parameters)")
    p.add_argument("--friction-params", type=Path,
                   help="JSON {joint: {Fv: …, Fc: …}} or a truth file (default for the TX40: docs/reference.md#tx40)")
    p.add_argument("--offsets", help="constant torque offsets JOINT=N·m,… (default 0)")
    p.add_argument("--position-noise",
                   help="1σ position noise, rad: one value or one per joint (default: the published TX40 noise for "
                        "the TX40, else 1e-6)")
    p.add_argument("--torque-noise", type=float,
                   help="1σ torque noise, N·m (default 0.05)")
    p.add_argument("--rate", type=float, default=1000.0, help="sample rate, Hz (default 1000)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--names",
                   help="joint names written in the bag, comma-separated in model order (default: model names)")
    p.add_argument("--truth", type=Path, help="write the ground truth as JSON here")
    add_drive_argument(p, "the bag then holds what the drive logs (e.g. motor angles, efforts in its units); with "
                          "friction_on: motor, friction acts per motor and --friction-params names motor_<k>")


def _per_joint(text: str | None, n: int, option: str) -> list[float] | None:
    """One number, or ``n`` comma-separated ones (``--position-noise``)."""
    if text is None:
        return None
    try:
        values = [float(x) for x in split_list(text)]
    except ValueError:
        raise FrictionIdError(f"{option} '{text}': expected a number or {n} comma-separated numbers") from None
    if len(values) not in (1, n):
        raise FrictionIdError(f"{option}: expected 1 or {n} values, got {len(values)}")
    return values


def run(args) -> int:
    from frictionid_core.excitation import load_trajectory, robot_of
    from frictionid_core.io import write_joint_state_bag
    from frictionid_core.synthetic import read_friction_params, synthesize
    from frictionid_core.systems import get_system

    refuse_overwriting({"--out": args.out, "--truth": args.truth},
                       {"TRAJ": args.trajectory, "--friction-params": args.friction_params,
                        "--drive": drive_file(args.drive), "--system": system_file(args.system)})
    robot, _ = robot_of(get_system(args.system), args.system)
    traj = load_trajectory(args.trajectory)
    params = None
    if args.friction_params is not None:
        params, law, asym = read_friction_params(args.friction_params)
        if law is not None and (law != args.friction or bool(asym) != args.asymmetric):
            raise FrictionIdError(f"{args.friction_params} holds {law}{' (asymmetric)' if asym else ''} parameters; "
                                  f"pass --friction {law}{' --asymmetric' if asym else ''}")
    offsets = parse_joint_values(args.offsets, "--offsets")
    bad = [j for j in offsets if j not in robot.joints]
    if bad:
        raise InputError(f"--offsets: joint(s) {bad} not in {robot.name} {robot.joints}")
    names = None
    if args.names:
        given = split_list(args.names)
        if len(given) != robot.nv:
            raise FrictionIdError(f"--names: {robot.nv} names needed (model order {robot.joints}), got {len(given)}")
        names = dict(zip(robot.joints, given))
    series, truth = synthesize(robot, traj, friction=args.friction, asymmetric=args.asymmetric, friction_params=params,
                               offsets=offsets,
                               position_noise=_per_joint(args.position_noise, robot.nv, "--position-noise"),
                               rate=args.rate, seed=args.seed, names=names, source=str(args.out),
                               drive=drive_option(args),
                               **({} if args.torque_noise is None else {"torque_noise": args.torque_noise}))
    truth["trajectory_file"] = str(args.trajectory)
    existed = args.out.exists()  # the writer refuses an existing bag
    try:
        write_joint_state_bag(args.out, series)
    except BaseException:  # Ctrl-C included: no half-written bag left behind
        if not existed:
            shutil.rmtree(args.out, ignore_errors=True)
        raise
    save_json(args.truth, truth)
    print(f"{args.out}: {len(series)} samples × {len(series.joints)} joints of {robot.name} at {args.rate:g} Hz, "
          f"{args.friction}{' (asymmetric)' if args.asymmetric else ''} friction"
          + (f" on the {truth['drive']['friction_on']}s, {truth['drive']['side']}-side log of drive "
             f"'{truth['drive']['name']}'" if "drive" in truth else "")
          + (f"; truth in {args.truth}" if args.truth else ""))
    return 0
