"""Write a synthetic fleet for ``frictionid fleet``: N robots × M daily MCAP logs with chosen drifts and
broken logs, its ``fleet.yaml`` and ``truth.json`` (:func:`frictionid_core.fleet.synthesize_fleet`).

    python tools/synth_fleet.py OUT --robots 12 --logs 40 \\
        --drift 2:0:20:0.2:10 --drift 5:1:25:0.3:10 --drift 9:2:18:0.15:5 --broken 3:7:truncated

A drift is ROBOT:JOINT:START:SIZE:RAMP (0-based robot, joint and first raised log; +SIZE relative,
reached RAMP logs later); a broken log is ROBOT:LOG:KIND (truncated or garbage).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _drift(text: str):
    from frictionid_core.fleet import Drift

    try:
        robot, joint, start, size, ramp = text.split(":")
        return Drift(int(robot), int(joint), int(start), float(size), int(ramp))
    except ValueError:
        raise argparse.ArgumentTypeError(f"drift '{text}': expected ROBOT:JOINT:START:SIZE:RAMP") from None


def _broken(text: str):
    from frictionid_core.fleet import Broken

    try:
        robot, log, kind = text.split(":")
        return Broken(int(robot), int(log), kind)
    except ValueError:
        raise argparse.ArgumentTypeError(f"broken log '{text}': expected ROBOT:LOG:KIND") from None


def main(argv: list[str] | None = None) -> int:
    from frictionid_core.errors import FrictionIdError
    from frictionid_core.fleet import synthesize_fleet

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", type=Path, help="new (or empty) folder for the fleet")
    p.add_argument("--robots", type=int, default=4, help="robots (default 4)")
    p.add_argument("--logs", type=int, default=20, help="daily logs per robot (default 20)")
    p.add_argument("--duration", type=float, default=20.0, help="seconds per log (default 20)")
    p.add_argument("--rate", type=float, default=200.0, help="sample rate, Hz (default 200)")
    p.add_argument("--drift", type=_drift, action="append", default=[], help="ROBOT:JOINT:START:SIZE:RAMP")
    p.add_argument("--broken", type=_broken, action="append", default=[], help="ROBOT:LOG:truncated|garbage")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    args = p.parse_args(argv)
    try:
        fleet = synthesize_fleet(args.out, robots=args.robots, logs=args.logs, drifts=tuple(args.drift),
                                 broken=tuple(args.broken), duration_s=args.duration, rate_hz=args.rate,
                                 seed=args.seed)
    except FrictionIdError as exc:
        print(f"synth_fleet: error: {exc}", file=sys.stderr)
        return 2
    print(f"{fleet}: {args.robots} robots × {args.logs} logs, {len(args.drift)} drifts, {len(args.broken)} broken")
    return 0


if __name__ == "__main__":
    sys.exit(main())
