"""What several commands share: source arguments, value parsing, tables, JSON output, error handling.

Imports only the standard library and ``frictionid_core.errors`` at module level (it is
loaded for ``frictionid --help``).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import warnings
from pathlib import Path

from frictionid_core.errors import FrictionIdError

EXIT_INPUT = 2  # bad input: one line on stderr
EXIT_INTERNAL = 1  # a bug
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), as a shell reports it

# ------------------------------------------------------------------- arguments
def add_json_argument(p: argparse.ArgumentParser, what: str = "the result") -> None:
    p.add_argument("--json", type=Path, help=f"write {what} as JSON to this file")


def add_source_arguments(p: argparse.ArgumentParser) -> None:
    """SOURCE(s) and the options choosing what to read from them (identify, validate)."""
    p.add_argument("source", nargs="+", metavar="SOURCE",
                   help="MAT (EMPS), CSV, rosbag2 directory / .mcap / .db3, or ROS 1 .bag; several sources are "
                        "each pre-processed alone and fitted together (same joints)")
    p.add_argument("--topic", help="JointState topic of a bag (default /joint_states, else the only one)")
    p.add_argument("--joints", help="comma-separated joint names to use, in order (default: all)")
    p.add_argument("--effort-topic", help="separate effort topic (JointState or Float64MultiArray)")
    p.add_argument("--layout", type=Path,
                   help="YAML layout of a CSV not in frictionid's own format (columns of time, positions, efforts…)")
    p.add_argument("--strict-time", action="store_true",
                   help="fail on duplicated or out-of-order time stamps instead of repairing them")
    p.add_argument("--strict-rows", action="store_true",
                   help="fail on a broken row (of a CSV: malformed, not numeric, truncated; of any log: a value NaN, "
                        "inf or beyond any measurement, a time stamp off the log's time line) instead of skipping "
                        "broken rows with a warning")
    p.add_argument("--start", type=float, metavar="S", help="use the data from S seconds after the first sample")
    p.add_argument("--end", type=float, metavar="S", help="use the data up to S seconds after the first sample")
    add_json_argument(p)


def add_drive_argument(p: argparse.ArgumentParser,
                       role: str = "the log is taken to the joint side with it (default: none, a joint-side log "
                                   "in N·m)") -> None:
    """``--drive FILE|NAME``: the log's transmission (gear ratios, coupling, effort units); ``role``
    ends its help."""
    p.add_argument("--drive", metavar="FILE|NAME",
                   help=f"drive model (gear ratios, coupling, effort units, friction on joints or motors): a YAML "
                        f"file or a bundled drive (tx40); {role}")


def add_hold_arguments(p: argparse.ArgumentParser) -> None:
    """``--hold JOINT=VALUE`` and ``--hold-missing``: model joints held still (robot systems)."""
    p.add_argument("--hold", action="append", metavar="JOINT=VALUE",
                   help="tx40, urdf:PATH: hold a model joint still at this position (rad or m), e.g. one the log "
                        "lacks; repeatable (or JOINT=VALUE,JOINT=VALUE)")
    p.add_argument("--hold-missing", action="store_true", default=None,
                   help="tx40, urdf:PATH: hold every model joint the log lacks still at 0 (or at the drive's "
                        "position_offset of that joint); the result lists them in held_joints")


def hold_option(args) -> dict[str, float] | None:
    """{model joint: position} of the ``--hold`` items, or None without."""
    return None if args.hold is None else parse_joint_values(",".join(args.hold), "--hold", "POSITION")


def drive_option(args):
    """The Drive named by ``--drive``, or None."""
    if args.drive is None:
        return None
    from frictionid_core.drive import load_drive

    return load_drive(args.drive)


def load_sources(args) -> list:
    """The JointSeries named by :func:`add_source_arguments`' options, one per source (not yet
    cut to the window: see :func:`window_of`)."""
    from frictionid_core.io import load

    return [load(source, topic=args.topic, joints=split_list(args.joints) or None, effort_topic=args.effort_topic,
                 strict_time=args.strict_time, layout=args.layout, strict_rows=args.strict_rows)
            for source in args.source]


def window_of(args) -> tuple[float | None, float | None] | None:
    """(--start, --end) in seconds, or None when neither is given."""
    return None if args.start is None and args.end is None else (args.start, args.end)


def split_list(text: str | None) -> list[str] | None:
    """``"a, b,c"`` → ``["a", "b", "c"]`` (empty items dropped); None stays None."""
    return None if text is None else [item.strip() for item in text.split(",") if item.strip()]


def parse_joint_values(text: str | None, option: str, unit: str = "VALUE") -> dict[str, float]:
    """``"j1=0.5,j2=-1"`` → ``{"j1": 0.5, "j2": -1.0}``; FrictionIdError naming ``option`` otherwise."""
    out = {}
    for item in split_list(text) or []:
        joint, sep, value = item.partition("=")
        try:
            if not sep:
                raise ValueError
            out[joint.strip()] = float(value)
        except ValueError:
            raise FrictionIdError(f"{option} item '{item}': expected JOINT={unit}") from None
    return out


def parse_bounds(items: list[str]) -> dict[str, tuple[float, float]]:
    """``--bounds NAME=LO:HI`` items → {name: (lo, hi)}."""
    out = {}
    for item in items:
        name, _, rng = item.partition("=")
        lo, _, hi = rng.partition(":")
        try:
            out[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise FrictionIdError(f"--bounds '{item}': expected NAME=LO:HI, e.g. vs=1e-4:1") from None
    return out


def parse_fixed(items: list[str]) -> dict[str, float]:
    """``--fix NAME=VALUE`` items → {name: value}."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise FrictionIdError(f"--fix '{item}': expected NAME=VALUE, e.g. offset=0") from None
    return out


# ---------------------------------------------------------------------- output
def fmt(x, digits: int = 6) -> str:
    """A number with ``digits`` significant digits; None and NaN as "—"."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    return f"{x:.{digits}g}" if isinstance(x, (int, float)) else str(x)


def metrics_line(metrics: dict) -> str:
    """The numbers of ``metrics`` on one line (per-joint metrics: :func:`joint_lines`)."""
    return "metrics: " + ", ".join(f"{k} {fmt(v)}" for k, v in metrics.items()
                                   if isinstance(v, (int, float)) or v is None)


def joint_lines(metrics: dict) -> list[str]:
    """One line per joint of ``metrics["per_joint"]`` (none without it), with its ``all_rows``
    metrics after a ``|`` when given (:func:`print_metrics`)."""
    rows = metrics.get("per_joint") or {}
    every = (metrics.get("all_rows") or {}).get("per_joint") or {}
    width = max(map(len, rows), default=0)
    def numbers(m: dict) -> str:
        return f"relerr {fmt(m.get('relerr_pct'), 4)} %, rmse {fmt(m.get('rmse'), 4)}, r2 {fmt(m.get('r2'), 4)}"

    return [f"  {joint:<{width}}  {numbers(m)}, noise floor {fmt(m.get('noise_floor_pct'), 3)} %"
            + (f" | all rows: {numbers(every[joint])}" if joint in every else "") for joint, m in rows.items()]


def print_metrics(metrics: dict, out=None) -> None:
    """The metrics line, then (with per-joint metrics) what they are taken against and one line per
    joint. When some rows were left out of them (slower than the min speed): which rows they are
    (the moving ones), a line of the metrics on every row (``all_rows``: standstill and reversals
    too), and each joint's after its moving-row metrics."""
    out = sys.stdout if out is None else out
    every = metrics.get("all_rows")
    split = every is not None and every.get("samples") != metrics.get("samples")
    line = metrics_line({k: v for k, v in metrics.items() if k != "all_rows"})
    if split:
        line = line.replace("metrics:", f"metrics on the moving rows ({fmt(metrics.get('samples'))} of "
                                         f"{fmt(every.get('samples'))}):", 1)
    print(line, file=out)
    if split:
        print(metrics_line(every).replace("metrics:", "metrics on all rows (standstill and reversals too):", 1),
              file=out)
    lines = joint_lines(metrics if split else {k: v for k, v in metrics.items() if k != "all_rows"})
    if lines:
        print(f"per joint, against the {metrics.get('against', 'effort')}:", file=out)
        for line in lines:
            print(line, file=out)


def preprocessing_line(p: dict) -> str:
    """One line saying how the data were pre-processed and which settings came from the data."""
    chosen = set(p.get("from_data", []))

    def mark(*names: str) -> str:
        return " (data)" if chosen.intersection(names) else ""

    speeds = sorted(set((p.get("min_speed") or {}).values())) or [0.0]
    speed = fmt(speeds[0], 2) if len(speeds) == 1 else f"{fmt(speeds[0], 2)}…{fmt(speeds[-1], 2)}"
    parts = []
    if p.get("filter") == "none":
        parts.append("no position filter")
    else:
        band = f", motion bandwidth {fmt(p['bandwidth_hz'], 3)} Hz" if p.get("bandwidth_hz") is not None else ""
        parts.append(f"Butterworth order {p.get('order')} at {cutoff_text(p.get('cutoff_hz'))} Hz{mark('cutoff_hz')}"
                     f"{band}")
    rate = f" → {fmt(p['analysis_rate_hz'], 4)} Hz" if p.get("analysis_rate_hz") else ""
    thin = p.get("thin") or 1
    thinned = (f" ({p.get('fit_rows')} rows: at the rate each dip crossing needs, 1 in {thin} elsewhere)"
               if thin > 1 else "")
    parts += [f"decimation {p.get('decimate')}{rate}{mark('decimate')}{thinned}",
              f"trims {fmt(p.get('trim_start_s'), 3)} + {fmt(p.get('trim_end_s'), 3)} s"
              f"{mark('trim_start_s', 'trim_end_s')}",
              f"min speed {speed}{mark('min_speed')}", f"velocity from {p.get('velocity', 'position')}"]
    lags = {channel: sorted({v for v in per_joint.values() if v})
            for channel, per_joint in (p.get("lag_s") or {}).items()}  # the channel lags the loader removed
    lagged = [f"{channel} {'…'.join(fmt(v * 1e3, 3) for v in dict.fromkeys((values[0], values[-1])))} ms"
              for channel, values in lags.items() if values]
    if lagged:
        parts.append(f"channel lag removed: {', '.join(lagged)}")
    for key, what in (("stick_rows", "stick rows left out"), ("reversal_rows", "rows near reversals left out")):
        counts = {j: n for j, n in (p.get(key) or {}).items() if n}
        if counts:
            parts.append(f"{what}: {', '.join(f'{j} {n}' for j, n in counts.items())}")
    if p.get("overridden"):
        parts.append(f"set: {', '.join(p['overridden'])}")
    why = p.get("kept_why") or {}
    for key, what in (("rechosen", "chosen from these data"), ("kept", "kept from the result"), ("set", "set")):
        reasons: dict[str, list[str]] = {}  # the names of one reason together: "kept from the result (why): a, b"
        for n in p.get(key) or []:
            reasons.setdefault(why.get(n, "") if key == "kept" else "", []).append(n)
        parts += [f"{what}{f' ({reason})' if reason else ''}: {', '.join(names)}" for reason, names in reasons.items()]
    return "preprocessing: " + ", ".join(parts)


def choice_line(p: dict) -> str | None:
    """One line saying how the cut-offs were chosen by cross-validation (the candidates, by their
    highest cut-off, with their errors) — and a second for the min speed when it was chosen so —
    or None when they were not."""
    cv = p.get("cross_validation")
    if not cv:
        return None
    if cv.get("cutoff_hz") is None:
        return f"cut-off: the rule's, not cross-validated ({cv.get('skipped', 'too little data')})"
    rule_low = min(cv["candidates"][0]["cutoff_hz"].values())  # the rule's comes first

    def label(k: int, cutoffs: dict[str, float]) -> str:
        """The rule's by its highest cut-off, the others by the cap on the rule's (≤) or the floor under them (≥)."""
        if k == 0:
            return f"rule {fmt(max(cutoffs.values()), 3)}"
        low = min(cutoffs.values())
        return f"≥ {fmt(low, 3)}" if low > rule_low else f"≤ {fmt(max(cutoffs.values()), 3)}"

    scores = ", ".join(f"{label(k, c['cutoff_hz'])} Hz {fmt(c['cv_relerr_pct'], 3)} %"
                       for k, c in enumerate(cv["candidates"]))
    line = (f"cut-off chosen by {cv['folds']}-fold blocked cross-validation (each part's torque predicted from "
            f"the others): {cutoff_text(cv['cutoff_hz'])} Hz; candidates (the rule's, capped ≤, raised ≥), "
            f"error: {scores}")
    composed = cv.get("composed")
    if composed and composed.get("cv_relerr_pct") is not None:
        line += (f"; each joint's own best together ({cutoff_text(composed['cutoff_hz'])} Hz) "
                 f"{fmt(composed['cv_relerr_pct'], 3)} %{'' if composed['taken'] else ', not taken'}")
    if cv.get("dips"):
        line += "; the folds' models include each joint's low-speed friction curve"
    speed = cv.get("min_speed") or {}
    if speed.get("min_speed"):
        names = ["rule"] + [f"{fmt(100 * share, 3)} % of top speed" for share in speed["shares_of_top_speed"]]
        tried = ", ".join(f"{name} {fmt(c['cv_relerr_pct'], 3)} %" for name, c in zip(names, speed["candidates"]))
        line += (f"\nmin speed chosen the same way (every candidate predicting the rows faster than the highest): "
                 f"{cutoff_text(speed['min_speed'])}; candidates, error: {tried}")
    return line


def law_line(choice: dict) -> str:
    """One line saying which friction law ``--friction auto`` took, why, and every candidate's
    cross-validated error."""
    def label(c: dict) -> str:
        gravity = " + gravity" if c.get("gravity") else ""
        score = "failed" if c.get("failed") else f"{fmt(c['cv_relerr_pct'], 3)} %"
        bound = f" ({', '.join(c['at_bound'])} at a bound)" if c.get("at_bound") else ""
        return f"{c['friction']}{gravity} {score}{bound}"

    chosen = choice["chosen"] + (" + gravity" if choice.get("gravity") else "")
    return (f"friction chosen by {choice['folds']}-fold cross-validation (each half's moving rows predicted from the "
            f"other): {chosen}, {choice['why']}; candidates: {', '.join(label(c) for c in choice['candidates'])}")


def cutoff_text(cutoff) -> str:
    """A cut-off setting (one value, or {joint: Hz}: one value when all agree, else the range)."""
    if not isinstance(cutoff, dict):
        return fmt(cutoff, 4)
    values = sorted(set(cutoff.values()))
    return fmt(values[0], 4) if len(values) == 1 else f"{fmt(values[0], 4)}…{fmt(values[-1], 4)} (per joint)"


def print_table(result: dict, out=None) -> None:
    """A readable table of an identification's pre-processing, parameters (± σ) and metrics (to
    ``out``, default stdout)."""
    out = sys.stdout if out is None else out
    head = (f"{result['system']} · {result['friction']}{' (asymmetric)' if result['asymmetric'] else ''}"
            f" · solver {result['solver']}")
    print(head, file=out)
    sources = result["source"] if isinstance(result["source"], list) else [result["source"]]
    print(f"source: {', '.join(map(str, sources))}", file=out)
    if result.get("preprocessing"):
        print(preprocessing_line(result["preprocessing"]), file=out)
        if (line := choice_line(result["preprocessing"])) is not None:
            print(line, file=out)
    if result.get("law_choice"):
        print(law_line(result["law_choice"]), file=out)
    if result.get("drive"):
        d = result["drive"]
        print(f"drive: {d.get('name') or 'unnamed'} ({d['side']}-side log, friction on the {d['friction_on']}s"
              f"{', coupling ' + str(d['coupling']) if d.get('coupling') else ''})", file=out)
    if result.get("window"):
        start, end = result["window"].get("start_s"), result["window"].get("end_s")
        print(f"window: {fmt(start or 0.0)} s to {'the end' if end is None else f'{fmt(end)} s'} of each source",
              file=out)
    if result.get("fixed"):
        print("fixed: " + ", ".join(f"{k} = {fmt(v)}" for k, v in result["fixed"].items()), file=out)
    # σ: of white residuals (std); σ calibrated: for coloured residuals and model error (std_robust,
    # "—" where the data do not determine the parameter): 1.96 of it is the error bar to quote
    calibrated = result.get("std_robust") or {}
    print(f"{'parameter':<16}{'value':>14}{'σ':>12}{'σ calibrated':>15}", file=out)
    at_bound = result.get("at_bound") or {}
    for name, value in result["params"].items():
        if name in at_bound:  # not an identified value: the bound it ends at, no σ
            print(f"{name:<16}{'at bound ' + fmt(at_bound[name]):>14}{'—':>12}{'—':>15}", file=out)
            continue
        print(f"{name:<16}{fmt(value):>14}{fmt(result['std'].get(name)):>12}{fmt(calibrated.get(name)):>15}",
              file=out)
    print_metrics(result["metrics"], out)


def warn(messages: list[str]) -> None:
    """Issue each message as a UserWarning: :func:`run_handler` prints it once as ``frictionid: warning: …``."""
    for message in messages:
        warnings.warn(message, UserWarning, stacklevel=2)


def save_json(path: Path | None, data) -> None:
    """Write ``data`` to ``path`` (the ``--json`` option) atomically; nothing when ``path`` is None."""
    if path is not None:
        from frictionid_core.files import write_json

        write_json(path, data)


# ------------------------------------------------------------ inputs and outputs
def source_inputs(args) -> dict[str, object]:
    """The files the source options of :func:`add_source_arguments` read (label → path(s)): the
    sources, ``--layout`` and the efforts file its layout names, and ``--drive``."""
    inputs = {"SOURCE": [Path(s) for s in args.source], "--layout": args.layout,
              "--drive": drive_file(getattr(args, "drive", None))}
    if args.layout is not None and Path(args.layout).is_file():
        from frictionid_core.io import load_layout

        effort_file = load_layout(args.layout).effort_file
        if effort_file:
            inputs["--layout's effort_file"] = [Path(s).parent / effort_file for s in args.source]
    return inputs


def drive_file(drive: str | None) -> Path | None:
    """The file of ``--drive FILE|NAME`` (None: a bundled drive's name, or no drive)."""
    return None if drive is None or not Path(drive).expanduser().is_file() else Path(drive)


def system_file(system: str | None) -> Path | None:
    """The URDF file of a ``urdf:PATH`` system name (also the packed ``urdf:PATH?map=…`` of older
    results), else None."""
    if not isinstance(system, str) or not system.startswith("urdf:"):
        return None
    return Path(system[len("urdf:"):].partition("?map=")[0])


def refuse_overwriting(outputs: dict[str, Path | None], inputs: dict[str, object]) -> None:
    """FrictionIdError naming both paths when an output is one of the ``inputs`` (label → path, list
    of paths or None; a directory stands for itself and its files, such as a rosbag2 directory's
    storage files) or two outputs are one file: a command never overwrites what it reads."""
    read = []
    for label, value in inputs.items():
        for path in value if isinstance(value, (list, tuple)) else [value]:
            if path is None:
                continue
            path = Path(path).expanduser()
            read.append((label, path, path))
            if path.is_dir():
                read += [(label, path, f) for f in sorted(path.iterdir()) if f.is_file()]
    written = []
    for label, out in outputs.items():
        if out is None:
            continue
        out = Path(out).expanduser()
        for in_label, path, file in read:
            if same_file(out, file):
                inner = "" if file == path else f" (its file {file.name})"
                raise FrictionIdError(f"{label} {out} is the input {in_label} {path}{inner}: refusing to overwrite "
                                      "what this command reads; choose another output file")
        for other_label, other in written:
            if same_file(out, other):
                raise FrictionIdError(f"{label} {out} is also {other_label}: give each output its own file")
        written.append((label, out))


def same_file(a: Path, b: Path) -> bool:
    """True when the paths ``a`` and ``b`` name one file (after symbolic links; hard links too)."""
    a, b = Path(a).expanduser(), Path(b).expanduser()
    if a.absolute() == b.absolute() or a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def output_folder(label: str, folder: Path, names: tuple[str, ...]) -> dict[str, Path]:
    """The files a command writes into the output directory ``folder`` (option ``label``), each
    labelled for :func:`refuse_overwriting`; FrictionIdError when ``folder`` exists and is not a
    directory."""
    folder = Path(folder).expanduser()
    if folder.exists() and not folder.is_dir():
        raise FrictionIdError(f"{label} {folder} is a file; expected a directory to write {', '.join(names)} into")
    return {f"{label} ({name})": folder / name for name in names}


# ---------------------------------------------------------------------- errors
def run_handler(handler, args: argparse.Namespace) -> int:
    """``handler(args)``'s exit code; a FrictionIdError becomes one line on stderr and exit code 2,
    any other exception one line and exit code 1 (the traceback with FRICTIONID_DEBUG=1).
    Library warnings are printed as ``frictionid: warning: …`` lines, each message once, unless
    the command fails on bad input: its one line then says what went wrong."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        try:
            code = handler(args)
        except FrictionIdError as exc:
            code = EXIT_INPUT
            print(f"frictionid: error: {' '.join(str(exc).split())}", file=sys.stderr)
        except BrokenPipeError:  # output piped into head & co.
            sys.stderr.close()
            code = 0
        except KeyboardInterrupt:  # Ctrl-C: one line and exit code 130, no traceback
            code = interrupted()
        except Exception as exc:  # a bug, not bad input: one line unless debugging
            if os.environ.get("FRICTIONID_DEBUG"):
                raise
            code = EXIT_INTERNAL
            print(f"frictionid: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} "
                  "(set FRICTIONID_DEBUG=1 for the traceback)", file=sys.stderr)
        if code != EXIT_INPUT:
            for message in dict.fromkeys(str(w.message) for w in caught if issubclass(w.category, UserWarning)):
                print(f"frictionid: warning: {message}", file=sys.stderr)
    return code


def interrupted() -> int:
    """Ctrl-C: one line on stderr, :data:`EXIT_INTERRUPTED` (a file being written keeps its old
    content: the atomic writer removes its temporary file)."""
    print("frictionid: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED
