"""Identify the EMPS friction (and mass) from the bundled MCAP bag and print the parameters.

    python examples/identify_from_bag.py [OUT_DIR]

With OUT_DIR, the result is also written to OUT_DIR/emps_coulomb.json, the same JSON as
``frictionid identify --json`` (the input of examples/feedforward_torque.py).
"""

import json
import sys
from pathlib import Path

import frictionid_core as fid

BAG = Path(__file__).resolve().parents[1] / "bags" / "emps_estimation"


def main(argv: list[str]) -> int:
    series = fid.load(BAG)  # /joint_states: position (m) and effort (N) of the single joint
    result = fid.identify(series, fid.IdentifyRequest(system="emps", friction="coulomb", solver="ls"))
    print(f"{result.system} · {result.friction} · solver {result.solver} · {result.metrics['samples']} samples")
    for name, value in result.params.items():
        print(f"{name:<8}{value:>12.6g}  ± {result.std[name]:.3g}")
    print(f"relative error {result.metrics['relerr_pct']:.6g} %, condition number {result.metrics['cond']:.6g}")
    if argv:
        out = Path(argv[0])
        out.mkdir(parents=True, exist_ok=True)
        path = out / "emps_coulomb.json"
        path.write_text(json.dumps(result.to_dict(), indent=2) + "\n")
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
