"""The ``frictionid`` command line.

    frictionid identify SOURCE --system emps --friction coulomb [--asymmetric] --solver ls --json OUT
    frictionid validate SOURCE --params OUT.json [--json V.json]
    frictionid simulate emps --params OUT.json --data FILE [--clock true|benchmark] [--json S.json]
    frictionid CMD --help                       (every command: see COMMANDS)

One module per command in this package, each defining ``add_arguments(parser)`` and
``run(args) -> exit code``; :data:`COMMANDS` names them with their one-line help, so the
top-level parser imports no command module and only the chosen command's parser is built
(``--help`` stays fast). Other packages add commands through the entry-point group
``frictionid.commands``: each entry point is ``register(subparsers) -> handler``, loaded only
when its command runs. Errors in the input are reported as one line on stderr with exit code 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Iterable

from frictionid_core import lazy
from frictionid_core.cli._common import interrupted, run_handler

__all__ = ["COMMANDS", "PLUGIN_GROUP", "build_parser", "main", "run_handler"]

# name → (module in this package, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "identify": ("identify", "identify friction (and rigid-body) parameters from data"),
    "validate": ("validate", "cross-test identified parameters on other data"),
    "payload": ("payload", "identify a payload (mass, centre of mass, inertia) on a link from a loaded log"),
    "simulate": ("simulate", "closed-loop simulation of identified parameters (EMPS)"),
    "study": ("study", "optimisers × friction models × seeds on the EMPS (thesis §6.3)"),
    "report": ("report", "HTML report of a result on any data (figures per joint), or the EMPS benchmark report"),
    "excite": ("excite", "optimise a Fourier excitation trajectory within the joint limits"),
    "synth": ("synth", "synthesise a JointState bag from a trajectory (Pinocchio + friction + noise)"),
    "consistency": ("consistency", "physical consistency of identified robot base parameters"),
    "export": ("export", "write a robot result as a URDF, a MuJoCo model and a parameters file (YAML)"),
    "compare": ("compare", "compare fits side by side, or a fit with the ground truth of synthetic data"),
    "fleet": ("fleet", "identify every log of a fleet of robots, track each parameter and alarm when one drifts"),
}
PLUGIN_GROUP = "frictionid.commands"

Handler = Callable[[argparse.Namespace], int]


def build_parser(commands: Iterable[str] | None = None) -> tuple[argparse.ArgumentParser, dict[str, Handler]]:
    """The ``frictionid`` parser and the handlers of ``commands`` (default: every core command).

    Only the named commands get their arguments (and plugins named there are loaded); the others
    are listed with their help line. Plugins are looked up only when a named command is not a
    core one or none is named (top-level ``--help``).
    """
    wanted = set(COMMANDS) if commands is None else set(commands)
    parser = argparse.ArgumentParser(prog="frictionid",
                                     description="Joint friction identification for robot manipulators.")
    sub = parser.add_subparsers(dest="command", required=True)
    handlers: dict[str, Handler] = {}
    for name, (module, help_line) in COMMANDS.items():
        p = sub.add_parser(name, help=help_line)
        if name in wanted:
            lazy.attribute(f"{__name__}.{module}", "add_arguments")(p)
            handlers[name] = lazy.attribute(f"{__name__}.{module}", "run")
    if not wanted or not wanted <= set(COMMANDS):
        _add_plugins(sub, wanted, handlers)
    return parser, handlers


def _add_plugins(sub, wanted: set[str], handlers: dict[str, Handler]) -> None:
    """Commands of the entry-point group :data:`PLUGIN_GROUP`: the ``wanted`` ones are loaded and
    registered, the others only listed (their module is not imported)."""
    from importlib.metadata import entry_points

    for ep in entry_points(group=PLUGIN_GROUP):
        if ep.name in COMMANDS:
            continue
        if ep.name not in wanted:
            sub.add_parser(ep.name, help=f"command of the plugin {ep.module} (see 'frictionid {ep.name} --help')")
            continue
        try:
            handlers[ep.name] = ep.load()(sub)
        except Exception as exc:  # a broken plugin must not break the core commands
            print(f"frictionid: warning: command '{ep.name}' unavailable ({exc})", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Run ``frictionid`` with ``argv`` (default: the process arguments); returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # The top-level parser has no option taking a value: the first word is the command.
    chosen = next((a for a in argv if not a.startswith("-")), None)
    try:  # Ctrl-C while the command's modules load
        parser, handlers = build_parser([chosen] if chosen else [])
        args = parser.parse_args(argv)
    except KeyboardInterrupt:
        return interrupted()
    if args.command not in handlers:
        print(f"frictionid: error: command '{args.command}' is not available", file=sys.stderr)
        return 2
    return run_handler(handlers[args.command], args)
