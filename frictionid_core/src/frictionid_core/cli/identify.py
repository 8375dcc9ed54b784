"""``frictionid identify SOURCE [SOURCE ...] [--request FILE] [--system S] [--friction F] [--solver X]
[--start S] [--end S] [--fix NAME=VALUE]... [--bounds NAME=LO:HI]... [--layout FILE]
[--hold JOINT=VALUE]... [--hold-missing] [--gravity] [--prior urdf]
[--consistent [--prior-weight W] | --known-rigid-body] [--save-request FILE] [--json OUT]``.

The flags and ``--request FILE`` build one :class:`~frictionid_core.identification.IdentifyRequest`
(:func:`request_of`): the file's values, with every flag given on the command line over the file's
value of its field. The request flags therefore default to None here; their defaults are the request's.
"""

from __future__ import annotations

import argparse

from frictionid_core.cli._common import (
    add_drive_argument,
    add_hold_arguments,
    add_source_arguments,
    drive_file,
    hold_option,
    load_sources,
    parse_bounds,
    parse_fixed,
    parse_joint_values,
    print_table,
    refuse_overwriting,
    save_json,
    source_inputs,
    split_list,
    system_file,
    warn,
)
from frictionid_core.errors import FrictionIdError

HELD_LISTED = 6  # held joints named on the "held still:" line

# Request field (dotted: nested) → the flag that sets it, for messages.
FLAGS = {"system": "--system", "joints": "--joints", "joint_map": "--joint-map", "drive": "--drive",
         "friction": "--friction", "asymmetric": "--asymmetric", "solver.method": "--solver", "solver.seed": "--seed",
         "solver.generations": "--budget", "solver.calls": "--budget", "solver.pop": "--pop",
         "solver.varpro": "--varpro", "solver.warm_start": "--warm-start", "preprocessing.cutoff_hz": "--cutoff",
         "preprocessing.decimate": "--decimate", "preprocessing.trim_start_s": "--trim",
         "preprocessing.trim_end_s": "--trim", "preprocessing.min_speed": "--min-speed",
         "preprocessing.velocity": "--velocity", "window": "--start/--end", "window.start_s": "--start",
         "window.end_s": "--end", "consistent": "--consistent", "prior": "--prior", "prior_weight": "--prior-weight",
         "stribeck_order": "--stribeck-order", "hold": "--hold", "hold_missing": "--hold-missing",
         "gravity": "--gravity", "known_rigid_body": "--known-rigid-body", "effort_sign": "--effort-sign",
         "elements": "--elements", "load_dependent": "--load-dependent"}


def add_arguments(p: argparse.ArgumentParser) -> None:
    from frictionid_core.emps import CLOCKS
    from frictionid_core.friction import FRICTIONS
    from frictionid_core.optim import SOLVERS
    from frictionid_core.preprocess import VELOCITY_SOURCES

    add_source_arguments(p)
    p.add_argument("--request", metavar="FILE",
                   help="identification request (YAML, as written by --save-request, or a result JSON's 'request'): "
                        "its values, each flag given on the command line overriding the file's value")
    p.add_argument("--save-request", metavar="FILE",
                   help="write this run's request as YAML (rerun it with --request FILE)")
    p.add_argument("--system", help="inverse dynamic model: emps | joint | friction-only | tx40-j2 | tx40 | urdf:PATH "
                                    "(default emps)")
    p.add_argument("--joint-map", help="bag joint → model joint names when they differ: a=b,c=d")
    add_drive_argument(p)
    p.add_argument("--friction", choices=(*FRICTIONS, "auto"),
                   help="friction model (default coulomb; auto: the law that predicts best, by cross-validation)")
    p.add_argument("--asymmetric", action="store_true", default=None, help="separate parameters for v > 0 and v < 0")
    p.add_argument("--elements", type=int, metavar="N",
                   help="--friction gms: number of Maxwell-slip elements (default 4; 1: Dahl's law with Fs = Fc)")
    p.add_argument("--solver", choices=SOLVERS, help="optimiser (default ls: linear least squares)")
    p.add_argument("--seed", type=int, help="random seed of stochastic solvers (default 0)")
    p.add_argument("--budget", type=int, help="generations (population solvers) or calls (bo, dt)")
    p.add_argument("--pop", type=int, help="population size of population solvers")
    p.add_argument("--bounds", action="append", metavar="NAME=LO:HI",
                   help="bounds of a parameter or family (e.g. vs=1e-4:1, Fs=0:100), held by every solver; "
                        "repeatable")
    p.add_argument("--fix", action="append", metavar="NAME=VALUE",
                   help="hold a parameter or family at a value (e.g. offset=0, joint_1/vs=0.01); repeatable")
    add_preprocessing_arguments(p)
    p.add_argument("--velocity", choices=VELOCITY_SOURCES,
                   help="q̇ from the filtered 'position' (default) or the 'recorded' velocity of the log")
    p.add_argument("--output-error", action="store_true",
                   help="EMPS: minimise the closed-loop simulated position error, starting from the IDM result")
    p.add_argument("--clock", choices=CLOCKS, default="true",
                   help="simulation clock of --output-error (default true)")
    p.add_argument("--varpro", action=argparse.BooleanOptionalAction,
                   help="variable projection: search only vs/delta/v0, solve the linear parameters in closed form "
                        "(default: on for tx40 and urdf:PATH, off otherwise)")
    p.add_argument("--consistent", action="store_true", default=None,
                   help="tx40, urdf:PATH: physically consistent standard parameters (pseudo-inertia ⪰ 0 per link, "
                        "rotor inertia, Fv, Fc ≥ 0; cvxpy + Clarabel); the result adds standard_parameters and "
                        "consistency")
    p.add_argument("--prior", choices=("urdf",),
                   help="tx40, urdf:PATH: hold the directions the data do not resolve at the robot model's own values "
                        "(default: dropped); with --consistent also pull each link toward the model's inertials "
                        "(log-det divergence)")
    add_hold_arguments(p)
    p.add_argument("--gravity", action="store_true", default=None,
                   help="--system joint: add g_sin·sin q + g_cos·cos q per joint (a joint loaded by gravity)")
    p.add_argument("--prior-weight", type=float, metavar="W",
                   help="weight of the --prior divergence against the data term ‖e‖²/2σ̂² (default 1)")
    p.add_argument("--stribeck-order", action="store_true", default=None,
                   help="with --consistent and an Fs parameter: also impose Fs ≥ Fc (off by default: see the docs)")
    p.add_argument("--known-rigid-body", action="store_true", default=None,
                   help="tx40, urdf:PATH: hold the model's rigid body (its links) and identify each joint's rotor "
                        "inertia (armature, ≥ 0: its base parameters and <joint>.Ia), friction and offsets")
    p.add_argument("--load-dependent", action="store_true", default=None,
                   help="tx40, urdf:PATH: Coulomb friction rising with the transmitted torque: Fc + Fc_load·|τ_rigid| "
                        "per joint (τ_rigid its rigid-body torque), <joint>/Fc_load identified with the rest")
    p.add_argument("--effort-sign", choices=("auto", "as-logged"),
                   help="joints whose friction ends ≤ 0 are fitted again with their efforts negated; auto (default): "
                        "the negated fit when it is clearly better (a driver's sign opposite to the model's joint "
                        "axis; its drive in the result holds the signs), as-logged: the log's signs and a warning")
    p.add_argument("--warm-start", action=argparse.BooleanOptionalAction,
                   help="global solvers evaluate the closed-form start (never worse than the nested linear model) "
                        "first; --no-warm-start: purely random initial population, the thesis protocol (default on)")


def add_preprocessing_arguments(p: argparse.ArgumentParser) -> None:
    """The pre-processing overrides of ``identify`` and ``validate`` (see :func:`preprocessing_fields`)."""
    p.add_argument("--cutoff", metavar="HZ|JOINT=HZ,…",
                   help="Butterworth cut-off on position, Hz: one for every joint, or per joint (the joints not "
                        "named: from the data) (default per joint: the one that minimises the acceleration's "
                        "mean-square error, ≤ 0.2 × the sample rate; emps: 100)")
    p.add_argument("--decimate", type=int, metavar="N",
                   help="decimation factor (default: down to ≥ 10 × the highest cut-off; emps: 10)")
    p.add_argument("--trim", metavar="SECONDS[:SECONDS]",
                   help="seconds dropped at both ends, or START:END (default: 5 / the lowest cut-off each; "
                        "emps: 0.049:0)")
    p.add_argument("--min-speed", type=float, metavar="SPEED",
                   help="rows with |q̇| below this (rad/s or m/s) are left out (default: 10 σ of the velocity "
                        "noise per joint, and its stick phases; emps: 0, every row kept)")


def preprocessing_fields(args) -> dict:
    """The ``preprocessing`` request fields of the flags of :func:`add_preprocessing_arguments` given."""
    pre = {"cutoff_hz": parse_cutoff(args.cutoff), "decimate": args.decimate, "min_speed": args.min_speed}
    if args.trim is not None:
        start, sep, end = args.trim.partition(":")
        try:
            pre["trim_start_s"], pre["trim_end_s"] = float(start), float(end) if sep else float(start)
        except ValueError:
            raise FrictionIdError(f"--trim '{args.trim}': expected SECONDS or START:END in seconds") from None
    return {k: v for k, v in pre.items() if v is not None}


def parse_cutoff(text: str | None) -> float | dict[str, float] | None:
    """``--cutoff``: ``HZ`` → HZ; ``JOINT=HZ,…`` → {joint: HZ}; None stays None."""
    if text is None:
        return None
    if "=" in text:
        return parse_joint_values(text, "--cutoff", "HZ")
    try:
        return float(text)
    except ValueError:
        raise FrictionIdError(f"--cutoff '{text}': expected HZ or JOINT=HZ[,JOINT=HZ…]") from None


def given_fields(args) -> dict:
    """The request fields the command line sets (nested as in ``IdentifyRequest.to_dict``), only
    those of the flags given."""
    from frictionid_core.systems import parse_joint_map

    top = {"system": args.system, "joints": split_list(args.joints), "drive": args.drive, "friction": args.friction,
           "asymmetric": args.asymmetric, "consistent": args.consistent, "prior": args.prior,
           "prior_weight": args.prior_weight, "stribeck_order": args.stribeck_order,
           "hold": hold_option(args),
           "hold_missing": args.hold_missing, "gravity": args.gravity, "known_rigid_body": args.known_rigid_body,
           "effort_sign": args.effort_sign, "elements": args.elements, "load_dependent": args.load_dependent,
           "joint_map": None if args.joint_map is None else parse_joint_map(args.joint_map),
           "fixed": None if args.fix is None else parse_fixed(args.fix),
           "bounds": None if args.bounds is None else parse_bounds(args.bounds)}
    solver = {"method": args.solver, "seed": args.seed, "pop": args.pop, "varpro": args.varpro,
              "warm_start": args.warm_start}
    pre = {**preprocessing_fields(args), "velocity": args.velocity}
    window = {"start_s": args.start, "end_s": args.end}
    out = {k: v for k, v in top.items() if v is not None}
    for key, part in (("solver", solver), ("preprocessing", pre), ("window", window)):
        part = {k: v for k, v in part.items() if v is not None}
        if part:
            out[key] = part
    return out


def request_of(args):
    """The IdentifyRequest of the command line: ``--request``'s file (if any) with the flags given over it."""
    from frictionid_core.identification import IdentifyRequest, budget_field, read_request

    values = read_request(args.request).to_dict() if args.request else {}
    for key, value in given_fields(args).items():
        if isinstance(value, dict) and isinstance(values.get(key), dict) and key != "joint_map":
            values[key] = {**values[key], **value}  # nested parts and fixed/bounds: field by field
        else:
            values[key] = value
    if args.budget is not None:
        method = (values.get("solver") or {}).get("method", "ls")
        values.setdefault("solver", {})[budget_field(method)] = args.budget
    return IdentifyRequest.from_dict(values, where="", names=FLAGS)


def run(args) -> int:
    from frictionid_core.model import FINITE_METRICS, check_finite

    request = request_of(args)
    drive = request.drive if isinstance(request.drive, str) else None  # --drive or the request file's
    refuse_overwriting({"--json": args.json, "--save-request": args.save_request},
                       {**source_inputs(args), "--drive": drive_file(drive), "--system": system_file(request.system),
                        "--request": args.request})
    if args.save_request:
        from frictionid_core.identification import write_request

        write_request(args.save_request, request)
    if args.output_error:
        from frictionid_core.emps import identify_output_error

        unsupported = [flag for flag, used in (("several sources", len(args.source) > 1),
                                               ("--layout", args.layout)) if used]
        if unsupported:
            raise FrictionIdError(f"--output-error takes one EMPS source without {', '.join(unsupported)}")
        result = identify_output_error(args.source[0], request, clock=args.clock)
    else:
        from dataclasses import replace

        from frictionid_core.identification import identify

        # the sources are read whole: the request's joints are the fit's rows (a robot system also
        # uses the log's other joints; each of several sources may hold its own joints)
        robot = request.system == "tx40" or request.system.startswith("urdf:")
        selected = request.joints is not None and not robot and len(args.source) == 1
        args.joints = ",".join(request.joints) if selected else None
        layout = None if args.layout is None else str(args.layout)
        result = replace(identify(load_sources(args), request), layout=layout)
    finite = ("position_relerr_pct",) if args.output_error else FINITE_METRICS  # output error: the simulation's
    check_finite(result.metrics, "the identification", finite)
    print_table(result.to_dict())
    if result.held_joints:
        held = [f"{j} = {v:g}" for j, v in result.held_joints.items()]
        more = f", … ({len(held)} joints: the result's held_joints)" if len(held) > HELD_LISTED else ""
        print("held still: " + ", ".join(held[:HELD_LISTED]) + more)
    if result.consistency is not None:
        c = result.consistency
        print(f"consistent parameters: {'FEASIBLE' if c['feasible'] else 'NOT FEASIBLE'} ({c['solver']}, "
              f"{c['sdp_wall_s']:.2f} s, prior {c['prior']} weight {c['prior_weight']:g}); cost "
              f"+{c['cost_increase_pct']:.3g} % over the unconstrained fit (relerr "
              f"{c['unconstrained']['relerr_pct']:.4g} %)")
    warn(result.warnings)
    save_json(args.json, result.to_dict())
    return 0
