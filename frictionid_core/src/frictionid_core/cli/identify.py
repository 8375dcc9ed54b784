"""``frictionid identify SOURCE [SOURCE ...] [--system S] [--friction F] [--solver X] [--start S] [--end S]
[--fix NAME=VALUE]... [--bounds NAME=LO:HI]... [--layout FILE] [--consistent [--prior urdf --prior-weight W]]
[--json OUT]``."""

from __future__ import annotations

import argparse

from frictionid_core.cli._common import (add_drive_argument, add_source_arguments, drive_option, load_sources,
                                         parse_bounds, parse_fixed, print_table, save_json, warn, window_of)
from frictionid_core.errors import FrictionIdError


def add_arguments(p: argparse.ArgumentParser) -> None:
    from frictionid_core.friction import FRICTIONS
    from frictionid_core.optim import SOLVERS
    from frictionid_core.options import CLOCKS, VELOCITY_SOURCES

    add_source_arguments(p)
    p.add_argument("--system", default="emps",
                   help="inverse dynamic model: emps | joint | friction-only | tx40-j2 | tx40 | urdf:PATH "
                        "(default emps)")
    p.add_argument("--joint-map", help="bag joint → model joint names when they differ: a=b,c=d")
    add_drive_argument(p)
    p.add_argument("--friction", default="coulomb", choices=FRICTIONS, help="friction model (default coulomb)")
    p.add_argument("--asymmetric", action="store_true", help="separate parameters for v > 0 and v < 0")
    p.add_argument("--solver", default="ls", choices=SOLVERS, help="optimiser (default ls: linear least squares)")
    p.add_argument("--seed", type=int, default=0, help="random seed of stochastic solvers (default 0)")
    p.add_argument("--budget", type=int, help="generations (population solvers) or calls (bo, dt)")
    p.add_argument("--pop", type=int, help="population size of population solvers")
    p.add_argument("--bounds", action="append", default=[], metavar="NAME=LO:HI",
                   help="bounds of a parameter or family (e.g. vs=1e-4:1, Fs=0:100), held by every solver; "
                        "repeatable")
    p.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                   help="hold a parameter or family at a value (e.g. offset=0, joint_1/vs=0.01); repeatable")
    p.add_argument("--cutoff", type=float, metavar="HZ",
                   help="Butterworth cut-off on position, Hz (default: 10 × the motion's bandwidth, ≤ 0.2 × the "
                        "sample rate; emps: 100)")
    p.add_argument("--decimate", type=int, metavar="N",
                   help="decimation factor (default: down to ≥ 10 × the cut-off; emps: 10)")
    p.add_argument("--trim", metavar="SECONDS[:SECONDS]",
                   help="seconds dropped at both ends, or START:END (default: 5 / cut-off each; emps: 0.049:0)")
    p.add_argument("--min-speed", type=float, metavar="SPEED",
                   help="rows with |q̇| below this (rad/s or m/s) are left out (default: 10 σ of the velocity "
                        "noise per joint; emps: 0, every row kept)")
    p.add_argument("--velocity", choices=VELOCITY_SOURCES,
                   help="q̇ from the filtered 'position' (default) or the 'recorded' velocity of the log")
    p.add_argument("--output-error", action="store_true",
                   help="EMPS: minimise the closed-loop simulated position error, starting from the IDM result")
    p.add_argument("--clock", choices=CLOCKS, default="true",
                   help="simulation clock of --output-error (default true)")
    p.add_argument("--varpro", action=argparse.BooleanOptionalAction, default=None,
                   help="variable projection: search only vs/delta/v0, solve the linear parameters in closed form "
                        "(default: on for tx40 and urdf:PATH, off otherwise)")
    p.add_argument("--consistent", action="store_true",
                   help="tx40, urdf:PATH: physically consistent standard parameters (pseudo-inertia ⪰ 0 per link, "
                        "rotor inertia, Fv, Fc ≥ 0; cvxpy + Clarabel); the result adds standard_parameters and "
                        "consistency")
    p.add_argument("--prior", choices=("urdf",),
                   help="with --consistent: pull each link toward the robot's own URDF inertials (log-det divergence)")
    p.add_argument("--prior-weight", type=float, default=1.0, metavar="W",
                   help="weight of the --prior divergence against the data term ‖e‖²/2σ̂² (default 1)")
    p.add_argument("--stribeck-order", action="store_true",
                   help="with --consistent and an Fs parameter: also impose Fs ≥ Fc (off by default: see the docs)")
    p.add_argument("--warm-start", action=argparse.BooleanOptionalAction, default=True,
                   help="global solvers evaluate the closed-form start (never worse than the nested linear model) "
                        "first; --no-warm-start: purely random initial population, the thesis protocol (default on)")


def _preprocessing(args):
    """The system's pre-processing with the --cutoff/--decimate/--trim/--min-speed/--velocity
    overrides, or None."""
    from dataclasses import replace

    from frictionid_core.systems import get_system

    changes = {k: v for k, v in (("cutoff_hz", args.cutoff), ("decimate", args.decimate),
                                 ("min_speed", args.min_speed), ("velocity", args.velocity)) if v is not None}
    if args.trim is not None:
        start, sep, end = args.trim.partition(":")
        try:
            changes["trim_start_s"] = float(start)
            changes["trim_end_s"] = float(end) if sep else float(start)
        except ValueError:
            raise FrictionIdError(f"--trim '{args.trim}': expected SECONDS or START:END in seconds") from None
    if not changes:
        return None
    return replace(get_system(args.system).preprocessing, **changes)


def run(args) -> int:
    from frictionid_core.options import budget_options

    opts = budget_options(args.solver, args.budget, args.pop)
    if args.output_error:
        from frictionid_core.output_error import identify_output_error

        if args.system != "emps":
            raise FrictionIdError(f"--output-error needs the EMPS closed-loop model; got system '{args.system}'")
        unsupported = [flag for flag, used in (("several sources", len(args.source) > 1), ("--fix", args.fix),
                                               ("--drive", args.drive is not None),
                                               ("--start/--end", window_of(args)), ("--layout", args.layout)) if used]
        if unsupported:
            raise FrictionIdError(f"--output-error takes one EMPS source without {', '.join(unsupported)}")
        result = identify_output_error(args.source[0], friction=args.friction, asymmetric=args.asymmetric,
                                       solver=args.solver if args.solver != "ls" else "lm", seed=args.seed,
                                       clock=args.clock, bounds=parse_bounds(args.bounds), **opts).to_dict()
    else:
        from frictionid_core.identification import identify
        from frictionid_core.systems import parse_joint_map

        result = identify(load_sources(args), system=args.system, joint_map=parse_joint_map(args.joint_map),
                          friction=args.friction,
                          asymmetric=args.asymmetric, solver=args.solver, seed=args.seed, varpro=args.varpro,
                          warm_start=args.warm_start, bounds=parse_bounds(args.bounds),
                          preprocessing=_preprocessing(args), fixed=parse_fixed(args.fix), window=window_of(args),
                          drive=drive_option(args), consistent=args.consistent, prior=args.prior,
                          prior_weight=args.prior_weight, stribeck_order=args.stribeck_order, **opts).to_dict()
        result["layout"] = None if args.layout is None else str(args.layout)
    print_table(result)
    if "consistency" in result:
        c = result["consistency"]
        print(f"consistent parameters: {'FEASIBLE' if c['feasible'] else 'NOT FEASIBLE'} ({c['solver']}, "
              f"{c['sdp_wall_s']:.2f} s, prior {c['prior']} weight {c['prior_weight']:g}); cost "
              f"+{c['cost_increase_pct']:.3g} % over the unconstrained fit (relerr "
              f"{c['unconstrained']['relerr_pct']:.4g} %)")
    warn(result.get("warnings", []))
    save_json(args.json, result)
    return 0
