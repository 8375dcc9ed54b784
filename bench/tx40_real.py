"""The real Stäubli TX40 recording through the command line only (not a test).

    .venv/bin/python bench/tx40_real.py [DATA_DIR]     # default ../shared/data/tx40_real

DATA_DIR holds FIGAROH's TX40 log: ``pos_read_data.csv`` (motor angles, rad) and ``curr_data.csv``
(motor torques, N·m), 45 000 rows at 5 kHz, no time column. A clone of this repository has no such
folder: this is a benchmark, never run by ``make test``.

Exactly what a user does with the README: one layout file, the bundled drive ``tx40`` and the CLI,
no preprocessing flag. Identify on 0–6.3 s, validate on 6.3–9 s:

* ``coupled``: Coulomb LS with ``--drive tx40`` (coupled wrist; each motor's friction and rotor
  inertia act through the coupling);
* ``joint friction``: the same fit with the drive's ``friction_on: joint`` (the kinematic coupling
  kept, friction and rotor inertia per joint: what a tool without motor-side friction fits);
* ``no coupling``: a drive without the coupling term at all (joint 6 read from motor 6 alone);
* ``stribeck``: Stribeck hybrid with ``--drive tx40``, timed;
* ``lugre``: LuGre hybrid with ``--drive tx40`` (the dynamic law: standstill and reversals
  predicted), timed; every run's validation also on all rows (``metrics.all_rows``).

Prints the acceptance of the issue and writes bench/results/tx40_real.{json,txt}.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import publish

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "tx40_real"
SPLIT_S = 6.3
FIGAROH_MOTOR6 = {"Fv": 0.616, "Fc": 1.95}  # TX40_config.yaml (fvm6, fsm6), joint side of the coupling

LAYOUT = """\
header: true
rate_hz: 5000
joints: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6]
position: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort_file: curr_data.csv
"""


def drive_variant(folder: Path, name: str, *, friction_on: str, coupling: bool) -> str:
    """A copy of the bundled tx40 drive with ``friction_on`` and the coupling term on or off."""
    from frictionid_core.drive import load_drive

    d = load_drive("tx40").to_dict()
    d.update(name=name, friction_on=friction_on)
    if not coupling:
        d["coupling"] = []
    path = folder / f"{name}.yaml"
    path.write_text(json.dumps(d))  # JSON is YAML
    return str(path)


def frictionid(*args: str) -> float:
    """Run the CLI; its wall time, s."""
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "frictionid_core.cli", *args], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        raise SystemExit(f"frictionid {' '.join(args)} failed:\n{out.stderr}")
    print(out.stdout.rstrip(), file=sys.stderr)
    if out.stderr.strip():
        print(out.stderr.rstrip(), file=sys.stderr)
    return wall


def prepare(prefix: str) -> tuple[Path, Path, Path, Path]:
    """(data folder from argv, its CSV, a temporary folder, the layout file written there)."""
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_DATA
    source = data / "pos_read_data.csv"
    if not source.is_file():
        raise SystemExit(f"{source}: not found (give the folder of FIGAROH's TX40 log)")
    tmp = Path(tempfile.mkdtemp(prefix=prefix))
    layout = tmp / "layout.yaml"
    layout.write_text(LAYOUT)
    return data, source, tmp, layout


def fit_and_validate(source: Path, layout: Path, drive: str, friction: str, solver: str, fit: Path, val: Path,
                     *flags: str) -> tuple[float, dict, dict]:
    """Identify on 0–SPLIT_S s and validate on the rest through the CLI: (identify wall [s], result, validation)."""
    wall = frictionid("identify", str(source), "--layout", str(layout), "--drive", drive, "--system", "tx40",
                      "--friction", friction, "--solver", solver, "--end", str(SPLIT_S), *flags, "--json", str(fit))
    frictionid("validate", str(source), "--layout", str(layout), "--params", str(fit), "--start", str(SPLIT_S),
               "--json", str(val))
    return wall, json.loads(fit.read_text()), json.loads(val.read_text())


def main() -> int:
    data, source, tmp, layout = prepare("tx40_real_")
    drives = {"coupled": "tx40",
              "joint friction": drive_variant(tmp, "tx40_joint_friction", friction_on="joint", coupling=True),
              "no coupling": drive_variant(tmp, "tx40_no_coupling", friction_on="joint", coupling=False)}
    runs = {name: ("coulomb", "ls", drive) for name, drive in drives.items()}
    runs["stribeck"] = ("stribeck", "hybrid", "tx40")
    runs["lugre"] = ("lugre", "hybrid", "tx40")
    out: dict = {"data": str(data), "layout": LAYOUT, "split_s": SPLIT_S, "runs": {}}
    for name, (friction, solver, drive) in runs.items():
        wall, r, v = fit_and_validate(source, layout, drive, friction, solver, tmp / f"{name}.json",
                                      tmp / f"{name}_val.json")
        out["runs"][name] = {"command": f"identify --drive {Path(drive).stem} --friction {friction} --solver {solver}",
                             "wall_s": wall, "estimation": r["metrics"], "validation": v["metrics"],
                             "params": r["params"], "preprocessing": r.get("preprocessing"),
                             "warnings": r.get("warnings", [])}
    out["acceptance"] = acceptance(out["runs"])
    publish("tx40_real", summary(out), out)
    return 0 if all(c["pass"] for c in out["acceptance"]) else 1


def _val(run: dict, joint: str | None = None) -> float:
    m = run["validation"]
    return m["relerr_pct"] if joint is None else m["per_joint"][joint]["relerr_pct"]


def acceptance(runs: dict) -> list[dict]:
    c, j, s = runs["coupled"], runs["joint friction"], runs["stribeck"]
    p = c["params"]
    rotors = {k: v for k, v in p.items() if k.endswith((".Ia", ".IaR"))}
    checks = [
        ("validation relerr coupled ≤ 0.75 × joint friction", _val(c) / _val(j), _val(c) <= 0.75 * _val(j)),
        ("joint-5 validation error cut ≥ 3×", _val(j, "joint_5") / _val(c, "joint_5"),
         _val(j, "joint_5") >= 3 * _val(c, "joint_5")),
        ("motor-6 Fv within 20 % of 0.616", p["motor_6/Fv"], abs(p["motor_6/Fv"] / FIGAROH_MOTOR6["Fv"] - 1) <= 0.2),
        ("motor-6 Fc within 20 % of 1.95", p["motor_6/Fc"], abs(p["motor_6/Fc"] / FIGAROH_MOTOR6["Fc"] - 1) <= 0.2),
        ("no negative rotor inertia", min(rotors.values()), min(rotors.values()) >= 0.0),
        ("stribeck hybrid ≤ 15 s", s["wall_s"], s["wall_s"] <= 15.0),
        ("stribeck validation not worse than coulomb ls", _val(s), _val(s) <= _val(c)),
        ("lugre all-rows validation ≤ 24 %", _all(runs["lugre"]), _all(runs["lugre"]) <= 24.0),
        ("lugre moving-row validation ≤ stribeck's + 0.3", _val(runs["lugre"]) - _val(s),
         _val(runs["lugre"]) <= _val(s) + 0.3),
        ("lugre hybrid ≤ 15 s", runs["lugre"]["wall_s"], runs["lugre"]["wall_s"] <= 15.0),
    ]
    return [{"criterion": name, "value": float(value), "pass": bool(ok)} for name, value, ok in checks]


def _all(run: dict) -> float:
    return run["validation"]["all_rows"]["relerr_pct"]


def summary(out: dict) -> str:
    lines = [f"real TX40 ({out['data']}): identify 0–{SPLIT_S} s, validate {SPLIT_S} s–end; CLI + layout + drive"]
    for name, r in out["runs"].items():
        per = r["validation"].get("per_joint", {})
        lines.append(f"{name:<15} {r['command']:<60} wall {r['wall_s']:6.1f} s  estimation "
                     f"{r['estimation']['relerr_pct']:6.2f} %  validation {r['validation']['relerr_pct']:6.2f} % "
                     f"(all rows {_all(r):6.2f} %)  "
                     "per joint " + " ".join(f"{v['relerr_pct']:.1f}" for v in per.values()))
    for c in out["acceptance"]:
        lines.append(f"{'PASS' if c['pass'] else 'FAIL'}  {c['criterion']}: {c['value']:.4g}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
