"""Should the consistent fit impose Fs ≥ Fc? The synthetic TX40 says no (not a test).

    .venv/bin/python bench/tx40_stribeck_order.py

The bundled TX40 bags follow the published friction (docs/reference.md#tx40), whose joints 1, 3
and 4 have Fs < Fc. Stribeck hybrid (DE 10 × 3 + lm, variable projection) on bags/tx40_excitation,
then the consistent linear part without and with Fs ≥ Fc (``--stribeck-order``); relative
errors on the fit and on bags/tx40_validation. Writes bench/results/tx40_stribeck_order.txt.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from _results import publish

from frictionid_core.consistency import consistent_fit
from frictionid_core.identification import IdentifyRequest, SolverOptions, build_model, identify, model_metrics
from frictionid_core.io import load
from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import get_system

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    est, val = load(ROOT / "bags" / "tx40_excitation"), load(ROOT / "bags" / "tx40_validation")
    t0 = time.perf_counter()
    solver = SolverOptions("hybrid", pop=10, generations=3)
    r = identify(est, IdentifyRequest(system="tx40", friction="stribeck", solver=solver)).to_dict()
    lines = [f"synthetic TX40 stribeck hybrid (DE 10 × 3 + lm, seed 0; {time.perf_counter() - t0:.0f} s); "
             "relative error % on the fit / on tx40_validation"]
    pre = Preprocessing.from_dict(r["preprocessing"])
    system = get_system("tx40")
    model = build_model(est, system, "stribeck", False, pre)
    vmodel = build_model(val, system, "stribeck", False, pre)
    x = np.array([r["params"][n] for n in model.names])

    def row(tag: str, p: np.ndarray) -> None:
        levels = " ".join(f"{j}: Fc {p[model.names.index(f'{j}/Fc')]:.3f} Fs {p[model.names.index(f'{j}/Fs')]:.3f}"
                          for j in est.joints)
        lines.append(f"{tag:<34} {model_metrics(model, p)['relerr_pct']:.4f} / "
                     f"{model_metrics(vmodel, p)['relerr_pct']:.4f}"
                     f"   {levels}")

    row("unconstrained", x)
    for order in (False, True):
        fit = consistent_fit(model, x, system.robot, stribeck_order=order)
        row(f"consistent{' + Fs ≥ Fc' if order else ''} (SDP {fit.record['sdp_wall_s']:.2f} s)", fit.x)
    publish("tx40_stribeck_order", "\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
