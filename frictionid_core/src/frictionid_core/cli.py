"""The ``frictionid`` command line.

    frictionid identify SOURCE --system emps --friction coulomb [--asymmetric] --solver ls --json OUT
    frictionid validate SOURCE --params OUT.json [--json V.json]
    frictionid simulate emps --params OUT.json --data FILE [--clock true|benchmark] [--json S.json]

Errors in the input are reported as one line on stderr with exit code 2.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import warnings
from pathlib import Path

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import FRICTIONS
from frictionid_core.optim import SOLVERS
from frictionid_core.options import budget_options

EXIT_INPUT = 2
EXIT_INTERNAL = 1


def _add_source_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("source", help="MAT (EMPS), CSV, rosbag2 directory / .mcap / .db3, or ROS 1 .bag")
    p.add_argument("--topic", help="JointState topic of a bag (default /joint_states, else the only one)")
    p.add_argument("--joints", help="comma-separated joint names to use, in order (default: all)")
    p.add_argument("--effort-topic", help="separate effort topic (JointState or Float64MultiArray)")
    p.add_argument("--strict-time", action="store_true",
                   help="fail on duplicated or out-of-order time stamps instead of repairing them")
    p.add_argument("--json", type=Path, help="write the result as JSON to this file")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="frictionid", description="Joint friction identification for robot manipulators.")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("identify", help="identify friction (and rigid-body) parameters from data")
    _add_source_args(p)
    p.add_argument("--system", default="emps",
                   help="inverse dynamic model: emps | friction-only | tx40-j2 | tx40 | urdf:PATH (default emps)")
    p.add_argument("--joint-map", help="bag joint → model joint names when they differ: a=b,c=d")
    p.add_argument("--friction", default="coulomb", choices=FRICTIONS, help="friction model (default coulomb)")
    p.add_argument("--asymmetric", action="store_true", help="separate parameters for v > 0 and v < 0")
    p.add_argument("--solver", default="ls", choices=SOLVERS, help="optimiser (default ls: linear least squares)")
    p.add_argument("--seed", type=int, default=0, help="random seed of stochastic solvers (default 0)")
    p.add_argument("--budget", type=int, help="generations (population solvers) or calls (bo, dt)")
    p.add_argument("--pop", type=int, help="population size of population solvers")
    p.add_argument("--bounds", action="append", default=[], metavar="NAME=LO:HI",
                   help="search bounds of a parameter or family (e.g. vs=1e-4:1); repeatable")
    p.add_argument("--cutoff", type=float, help="Butterworth cut-off on position, Hz (default: the system's)")
    p.add_argument("--decimate", type=int, help="decimation factor (default: the system's)")
    p.add_argument("--trim", type=int, help="samples dropped at the start (default: the system's)")
    p.add_argument("--output-error", action="store_true",
                   help="EMPS: minimise the closed-loop simulated position error, starting from the IDM result")
    p.add_argument("--clock", choices=("true", "benchmark"), default="true",
                   help="simulation clock of --output-error (default true)")
    p.add_argument("--varpro", action=argparse.BooleanOptionalAction, default=None,
                   help="variable projection: search only vs/delta/v0, solve the linear parameters in closed form "
                        "(default: on for tx40 and urdf:PATH, off otherwise)")
    p.add_argument("--warm-start", action=argparse.BooleanOptionalAction, default=True,
                   help="global solvers evaluate the closed-form start (never worse than the nested linear model) "
                        "first; --no-warm-start: purely random initial population, the thesis protocol (default on)")

    p = sub.add_parser("validate", help="cross-test identified parameters on other data")
    _add_source_args(p)
    p.add_argument("--params", type=Path, required=True, help="JSON written by 'frictionid identify'")

    from frictionid_core import report, robots, simulation, study

    COMMANDS["simulate"] = simulation.register(sub)
    COMMANDS["study"] = study.register(sub)
    COMMANDS["report"] = report.register(sub)
    COMMANDS.update(robots.register_all(sub))
    _add_plugin_commands(sub)
    return parser


PLUGIN_GROUP = "frictionid.commands"


def _add_plugin_commands(sub) -> None:
    """Sub-commands other packages register under the entry-point group ``frictionid.commands``
    (e.g. ``replay`` from frictionid_ros). Each entry point is a function
    ``register(subparsers) -> handler`` where ``handler(args) -> exit code``."""
    from importlib.metadata import entry_points

    for ep in entry_points(group=PLUGIN_GROUP):
        try:
            COMMANDS[ep.name] = ep.load()(sub)
        except Exception as exc:  # a broken plugin must not break the core commands
            print(f"frictionid: warning: command '{ep.name}' unavailable ({exc})", file=sys.stderr)


def _load(args):
    from frictionid_core.io import load

    joints = [j.strip() for j in args.joints.split(",") if j.strip()] if args.joints else None
    return load(args.source, topic=args.topic, joints=joints, effort_topic=args.effort_topic,
                strict_time=args.strict_time)


def _fmt(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    return f"{x:.6g}" if isinstance(x, (int, float)) else str(x)


def print_table(result: dict, out=None) -> None:
    """A readable table of parameters (± σ) and metrics (to ``out``, default stdout)."""
    out = sys.stdout if out is None else out
    head = f"{result['system']} · {result['friction']}{' (asymmetric)' if result['asymmetric'] else ''} · solver {result['solver']}"
    print(head, file=out)
    print(f"source: {result['source']}", file=out)
    print(f"{'parameter':<16}{'value':>14}{'σ':>12}", file=out)
    for name, value in result["params"].items():
        print(f"{name:<16}{_fmt(value):>14}{_fmt(result['std'].get(name)):>12}", file=out)
    print("metrics:", ", ".join(f"{k} {_fmt(v)}" for k, v in result["metrics"].items()), file=out)


def _write_json(path: Path | None, data: dict) -> None:
    if path is None:
        return
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, allow_nan=True) + "\n")
    tmp.replace(path)


def _parse_bounds(items: list[str]) -> dict[str, tuple[float, float]]:
    out = {}
    for item in items:
        name, _, rng = item.partition("=")
        lo, _, hi = rng.partition(":")
        try:
            out[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise FrictionIdError(f"--bounds '{item}': expected NAME=LO:HI, e.g. vs=1e-4:1") from None
    return out


def _preprocessing(args):
    from dataclasses import replace

    from frictionid_core.systems import get_system

    changes = {k: v for k, v in (("cutoff_hz", args.cutoff), ("decimate", args.decimate),
                                 ("trim_start", args.trim)) if v is not None}
    if not changes:
        return None
    if changes.get("decimate", 1) < 1 or changes.get("trim_start", 0) < 0:
        raise FrictionIdError("--decimate must be ≥ 1 and --trim ≥ 0")
    return replace(get_system(args.system).preprocessing, **changes)


def cmd_identify(args) -> int:
    from frictionid_core.identify import identify
    from frictionid_core.systems import parse_joint_map

    opts = budget_options(args.solver, args.budget, args.pop)
    if args.output_error:
        from frictionid_core.output_error import identify_output_error

        if args.system != "emps":
            raise FrictionIdError(f"--output-error needs the EMPS closed-loop model; got system '{args.system}'")
        result = identify_output_error(args.source, friction=args.friction, asymmetric=args.asymmetric,
                                       solver=args.solver if args.solver != "ls" else "lm", seed=args.seed,
                                       clock=args.clock, bounds=_parse_bounds(args.bounds), **opts).to_dict()
        print_table(result)
        _write_json(args.json, result)
        return 0
    series = _load(args)
    result = identify(series, system=args.system, joint_map=parse_joint_map(args.joint_map), friction=args.friction,
                      asymmetric=args.asymmetric,
                      solver=args.solver, seed=args.seed, varpro=args.varpro, warm_start=args.warm_start,
                      bounds=_parse_bounds(args.bounds),
                      preprocessing=_preprocessing(args), **opts).to_dict()
    print_table(result)
    _write_json(args.json, result)
    return 0


def cmd_validate(args) -> int:
    from frictionid_core.identify import validate

    try:
        params = json.loads(args.params.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise FrictionIdError(f"{args.params}: cannot read parameters ({exc})") from None
    series = _load(args)
    metrics = validate(series, params)
    out = {"source": series.source, "params_file": str(args.params), "system": params.get("system"),
           "friction": params.get("friction"), "asymmetric": params.get("asymmetric"), "metrics": metrics}
    print(f"cross-test of {args.params} on {series.source}")
    print("metrics:", ", ".join(f"{k} {_fmt(v)}" for k, v in metrics.items()))
    _write_json(args.json, out)
    return 0


COMMANDS = {"identify": cmd_identify, "validate": cmd_validate}


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command not in COMMANDS:
        print(f"frictionid: error: command '{args.command}' is not available", file=sys.stderr)
        return EXIT_INPUT
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        try:
            code = COMMANDS[args.command](args)
        except FrictionIdError as exc:
            code = EXIT_INPUT
            print(f"frictionid: error: {' '.join(str(exc).split())}", file=sys.stderr)
        except BrokenPipeError:  # output piped into head & co.
            sys.stderr.close()
            code = 0
        except Exception as exc:  # a bug, not bad input: one line unless debugging
            if os.environ.get("FRICTIONID_DEBUG"):
                raise
            code = EXIT_INTERNAL
            print(f"frictionid: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} "
                  "(set FRICTIONID_DEBUG=1 for the traceback)", file=sys.stderr)
        for w in caught:
            if issubclass(w.category, UserWarning):
                print(f"frictionid: warning: {w.message}", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
