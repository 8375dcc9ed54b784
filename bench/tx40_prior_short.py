"""What the URDF prior buys on short, poorly exciting data (not a test).

    .venv/bin/python bench/tx40_prior_short.py

Coulomb fits of 2 s and 1.5 s windows of the synthetic bags/tx40_excitation (offsets fixed at their
true 0), unconstrained, ``--consistent`` and ``--consistent --prior urdf`` at weights 1…1000,
validated on bags/tx40_validation. Writes bench/results/tx40_prior_short.txt.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

from _results import publish

from frictionid_core.identification import IdentifyRequest, identify, validate
from frictionid_core.io import load

ROOT = Path(__file__).resolve().parents[1]
WEIGHTS = (None, 1.0, 10.0, 100.0, 1000.0)


def main() -> int:
    est, val = load(ROOT / "bags" / "tx40_excitation"), load(ROOT / "bags" / "tx40_validation")
    lines = ["synthetic TX40, Coulomb LS on a short window; relative error % on the fit / on tx40_validation; "
             "link masses kg (model: 8.61 4.85 4.07 3.62 1.02 0.2)"]
    for window in ((4.0, 6.0), (2.0, 3.5)):
        free = IdentifyRequest(system="tx40", friction="coulomb", window=window, fixed={"offset": 0.0})
        r = identify(est, free).to_dict()
        lines.append(f"{window[0]:g}–{window[1]:g} s unconstrained       {r['metrics']['relerr_pct']:7.3f} / "
                     f"{validate(val, r)['relerr_pct']:7.3f}")
        for w in WEIGHTS:
            consistent = replace(free, consistent=True, prior=None if w is None else "urdf", prior_weight=w or 1.0)
            r = identify(est, consistent).to_dict()
            tag = "consistent" if w is None else f"consistent W={w:g}"
            masses = " ".join(f"{s['mass']:.3g}" for s in r["standard_parameters"].values())
            lines.append(f"{window[0]:g}–{window[1]:g} s {tag:<21} {r['metrics']['relerr_pct']:7.3f} / "
                         f"{validate(val, r)['relerr_pct']:7.3f}   masses {masses}")
    publish("tx40_prior_short", "\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
