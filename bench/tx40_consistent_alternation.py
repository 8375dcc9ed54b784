"""Stribeck + consistent parameters on the real TX40: does an alternation help? (not a test)

    .venv/bin/python bench/tx40_consistent_alternation.py [DATA_DIR]   # default ../shared/data/tx40_real

``identify --consistent`` keeps the shapes (vs, δ) of the unconstrained variable-projection search
and solves the constrained linear part once. Here, after that: re-fit the shapes with the
consistent linear part held (trust-region least squares), solve the convex program again; twice.
Fit 0–6.3 s, validate 6.3 s–end, as bench/tx40_consistent.py (library calls: the CLI has no
alternation). Writes bench/results/tx40_consistent_alternation.txt.
"""

from __future__ import annotations

import sys
import time

from _results import publish
from scipy.optimize import least_squares
from tx40_real import SPLIT_S, prepare

from frictionid_core.cli import build_parser
from frictionid_core.cli._common import drive_option, load_sources
from frictionid_core.consistency import consistent_fit
from frictionid_core.identification import SolverOptions, build_model, model_metrics, solve_model
from frictionid_core.systems import as_system


def main() -> int:
    _, source, _, layout = prepare("tx40_alt_")
    parser, _ = build_parser(["identify"])
    args = parser.parse_args(["identify", str(source), "--layout", str(layout), "--drive", "tx40",
                              "--system", "tx40"])
    sources, system = load_sources(args), as_system("tx40", None, drive_option(args))
    model = build_model([s.window(None, SPLIT_S) for s in sources], system, "stribeck", False)
    x, _ = solve_model(model, SolverOptions("hybrid", varpro=True))
    vmodel = build_model([s.window(SPLIT_S, None) for s in sources], system, "stribeck", False,
                         model.obs.preprocessing)
    lines = ["real TX40 stribeck hybrid (seed 0), fit 0–6.3 s, validate 6.3 s–end; cost = Σ residual² on the fit rows"]

    def report(tag: str, p) -> None:
        lines.append(f"{tag:<36} cost {model.batch_cost(p[None])[0]:.6g}  estimation "
                     f"{model_metrics(model, p)['relerr_pct']:.4f} %  "
                     f"validation {model_metrics(vmodel, p)['relerr_pct']:.4f} %")

    report("unconstrained", x)
    nl = model.searched_nonlinear_index
    lo, hi = model.bounds()
    for weight, tag in ((0.0, "consistent (tie-break 0.01)"), (1.0, "consistent + prior urdf W=1")):
        xc = consistent_fit(model, x, system.robot, prior_weight=weight).x
        report(tag, xc)
        for it in range(2):
            t0 = time.perf_counter()

            def residuals(theta, xc=xc):
                p = xc.copy()
                p[nl] = theta
                return model.residuals(p)

            p = xc.copy()
            p[nl] = least_squares(residuals, xc[nl], bounds=(lo[nl], hi[nl])).x
            xc = consistent_fit(model, p, system.robot, prior_weight=weight).x
            report(f"  + alternation {it + 1} ({time.perf_counter() - t0:.1f} s)", xc)
    publish("tx40_consistent_alternation", "\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
