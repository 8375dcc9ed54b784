"""Consistent parameters on the real Stäubli TX40 through the command line (not a test).

    .venv/bin/python bench/tx40_consistent.py [DATA_DIR]     # default ../shared/data/tx40_real

As bench/tx40_real.py (same layout, bundled drive ``tx40``, identify 0–6.3 s, validate 6.3–9 s):
each fit unconstrained, ``--consistent``, and ``--consistent --prior urdf`` at a few weights; for
each: validation relerr, ``frictionid consistency`` verdict, SDP wall time and the whole
command's wall time. Writes bench/results/tx40_consistent.{json,txt}.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from _results import publish
from tx40_real import SPLIT_S, fit_and_validate, prepare

VARIANTS = {"unconstrained": [], "consistent": ["--consistent"],
            "consistent + prior W=1": ["--consistent", "--prior", "urdf", "--prior-weight", "1"],
            "consistent + prior W=100": ["--consistent", "--prior", "urdf", "--prior-weight", "100"]}
FITS = {"coulomb ls": ("coulomb", "ls"), "stribeck hybrid": ("stribeck", "hybrid")}


def consistency(path: Path) -> str:
    out = subprocess.run([sys.executable, "-m", "frictionid_core.cli", "consistency", str(path)],
                         capture_output=True, text=True)
    return "FEASIBLE" if out.returncode == 0 else ("NOT FOUND FEASIBLE" if out.returncode == 3 else out.stderr)


def main() -> int:
    data, source, tmp, layout = prepare("tx40_consistent_")
    runs = {}
    for fit_name, (friction, solver) in FITS.items():
        for var, flags in VARIANTS.items():
            name = f"{fit_name} · {var}"
            fit = tmp / f"{len(runs)}.json"
            wall, r, v = fit_and_validate(source, layout, "tx40", friction, solver, fit, tmp / f"{len(runs)}_val.json",
                                          *flags)
            c = r.get("consistency") or {}
            runs[name] = {"command": "identify --drive tx40 --friction {} --solver {} {}".format(friction, solver,
                                                                                                " ".join(flags)),
                          "wall_s": wall, "estimation_relerr_pct": r["metrics"]["relerr_pct"],
                          "validation_relerr_pct": v["metrics"]["relerr_pct"], "consistency_check": consistency(fit),
                          "sdp_wall_s": c.get("sdp_wall_s"), "cost_increase_pct": c.get("cost_increase_pct"),
                          "masses": {j: s["mass"] for j, s in (r.get("standard_parameters") or {}).items()}}
    out = {"data": str(data), "split_s": SPLIT_S, "runs": runs, "acceptance": acceptance(runs)}
    publish("tx40_consistent", summary(out), out)
    return 0 if all(c["pass"] for c in out["acceptance"]) else 1


def acceptance(runs: dict) -> list[dict]:
    checks = []
    for fit_name in FITS:
        base = runs[f"{fit_name} · unconstrained"]
        for var in list(VARIANTS)[1:]:
            r = runs[f"{fit_name} · {var}"]
            d = r["validation_relerr_pct"] - base["validation_relerr_pct"]
            checks += [(f"{fit_name} · {var}: FEASIBLE", 1.0, r["consistency_check"] == "FEASIBLE"),
                       (f"{fit_name} · {var}: validation within +0.5 points (Δ)", d, d <= 0.5),
                       (f"{fit_name} · {var}: SDP ≤ 5 s", r["sdp_wall_s"], r["sdp_wall_s"] <= 5.0)]
    return [{"criterion": n, "value": float(v), "pass": bool(ok)} for n, v, ok in checks]


def summary(out: dict) -> str:
    lines = [f"real TX40 ({out['data']}): identify 0–{SPLIT_S} s, validate {SPLIT_S} s–end; CLI + layout + drive tx40"]
    for name, r in out["runs"].items():
        sdp = "" if r["sdp_wall_s"] is None else f"  SDP {r['sdp_wall_s']:5.2f} s"
        lines.append(f"{name:<42} wall {r['wall_s']:6.1f} s  estimation {r['estimation_relerr_pct']:6.2f} %  "
                     f"validation {r['validation_relerr_pct']:6.2f} %  {r['consistency_check']}{sdp}  masses "
                     + " ".join(f"{m:.3g}" for m in r["masses"].values()))
    for c in out["acceptance"]:
        lines.append(f"{'PASS' if c['pass'] else 'FAIL'}  {c['criterion']}: {c['value']:.4g}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
