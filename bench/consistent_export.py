#!/usr/bin/env python
"""One model from fit to robot: ``identify --consistent`` with its defaults, then ``export`` (not a test).

    .venv/bin/python bench/consistent_export.py DATA_DIR [DATA_DIR ...]
    .venv/bin/python bench/consistent_export.py ../shared/data/tx40_real ../shared/data/ur10e_real

For each real recording ``bench/field.py`` knows with a robot model (``tx40``, ``ur10e``, ``ur10e_12harm``,
``tiago``, …: its exact commands), through the command line:

1. ``identify`` as field.py types it, unconstrained, and the same with ``--consistent`` (no other flag);
2. ``validate`` of both on field.py's validation data;
3. ``export --urdf --mujoco --yaml`` of the consistent result (defaults: no ``--force``);
4. the URDF loaded in Pinocchio and the MJCF in MuJoCo: each moving joint's link mass, centre of mass and
   rotor inertia (MuJoCo's armature) against the result's ``standard_parameters``.

Targets (issue 38, item 4): the export succeeds, both files load with the identified inertials (to 1e-9
relative), and the consistent fit validates within +0.5 points of the unconstrained one. Prints a table
and writes bench/results/consistent_export.{json,txt}.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import publish
from field import READERS

VALIDATION_MARGIN = 0.5  # points of relative error the consistent fit may lose on validation
INERTIAL_RTOL = 1e-9


def cli(*args: str) -> tuple[int, str, str, float]:
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "frictionid_core.cli", *args], capture_output=True, text=True)
    return out.returncode, out.stdout, out.stderr, time.perf_counter() - t0


def loaded_inertials(result: dict, urdf: Path, mjcf: Path) -> dict:
    """Largest relative difference of mass, centre of mass and rotor inertia between the result's
    ``standard_parameters`` and the URDF (Pinocchio) and MJCF (MuJoCo) exported from it."""
    import mujoco
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(urdf))
    mj = mujoco.MjModel.from_xml_path(str(mjcf))
    worst = {"pinocchio_mass": 0.0, "pinocchio_com_m": 0.0, "mujoco_mass": 0.0, "mujoco_armature": 0.0}
    for joint, link in result["standard_parameters"].items():
        inertia = model.inertias[model.getJointId(joint)]
        scale = max(abs(link["mass"]), 1e-12)
        worst["pinocchio_mass"] = max(worst["pinocchio_mass"], abs(inertia.mass - link["mass"]) / scale)
        worst["pinocchio_com_m"] = max(worst["pinocchio_com_m"],
                                       float(np.max(np.abs(inertia.lever - np.asarray(link["com"])))))
        jm = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, joint)
        worst["mujoco_mass"] = max(worst["mujoco_mass"], abs(mj.body_mass[mj.jnt_bodyid[jm]] - link["mass"]) / scale)
        armature = mj.dof_armature[mj.jnt_dofadr[jm]]
        worst["mujoco_armature"] = max(worst["mujoco_armature"], abs(armature - link["rotor_inertia"])
                                       / max(abs(link["rotor_inertia"]), 1e-12))
    return worst


def run_case(case, tmp: Path) -> dict:
    out = {"commands": {}}
    fits = {}
    for kind, flags in (("unconstrained", []), ("consistent", ["--consistent"])):
        fit, val = tmp / f"{case.name}_{kind}.json", tmp / f"{case.name}_{kind}_val.json"
        code, _, err, wall = cli("identify", *case.identify, *flags, "--json", str(fit))
        out["commands"][f"identify {kind}"] = " ".join(["frictionid identify", *case.identify, *flags, "--json r.json"])
        if code:
            out[kind] = {"error": err.strip().splitlines()[-1]}
            continue
        code, _, err, _ = cli("validate", *case.validate, "--params", str(fit), "--json", str(val))
        result = json.loads(fit.read_text())
        fits[kind] = result
        validation = json.loads(val.read_text())["metrics"]["relerr_pct"] if not code else None
        out[kind] = {"identify_wall_s": wall, "estimation_relerr_pct": result["metrics"]["relerr_pct"],
                     "validation_relerr_pct": validation,
                     "implausible": (result.get("plausibility") or {}).get("implausible"),
                     "warnings": [w for w in err.splitlines() if "implausible" in w]}
        if kind == "consistent":
            c = result["consistency"]
            out[kind].update({k: c.get(k) for k in ("feasible", "held_directions", "data_scale", "sdp_wall_s",
                                                    "cost_increase_pct")})
            out[kind]["masses"] = {j: link["mass"] for j, link in result["standard_parameters"].items()}
    if "consistent" in fits:
        urdf, mjcf, yaml = (tmp / f"{case.name}.{ext}" for ext in ("urdf", "xml", "yaml"))
        code, stdout, err, _ = cli("export", str(tmp / f"{case.name}_consistent.json"), "--urdf", str(urdf),
                                   "--mujoco", str(mjcf), "--yaml", str(yaml))
        out["export"] = {"returncode": code, "error": err.strip().splitlines()[-1] if code else None,
                         "printed": stdout.strip().splitlines()}
        if not code:
            out["export"]["loaded"] = loaded_inertials(fits["consistent"], urdf, mjcf)
    val = [out.get(k, {}).get("validation_relerr_pct") for k in ("unconstrained", "consistent")]
    loaded = (out.get("export") or {}).get("loaded")
    out["targets"] = {
        "export succeeds": (out.get("export") or {}).get("returncode") == 0,
        "inertials loaded": bool(loaded) and max(loaded["pinocchio_mass"], loaded["mujoco_mass"],
                                                  loaded["mujoco_armature"]) <= INERTIAL_RTOL,
        f"validation within +{VALIDATION_MARGIN:g} points": None not in val and val[1] - val[0] <= VALIDATION_MARGIN}
    return out


def summary(runs: dict) -> str:
    lines = ["identify --consistent (defaults) → export --urdf --mujoco --yaml, real logs (bench/field.py's commands)"]
    nan = float("nan")
    for name, r in runs.items():
        u, c = r.get("unconstrained", {}), r.get("consistent", {})
        lines += ["", f"{name}:", *(f"  {cmd}" for cmd in r["commands"].values())]
        lines.append(f"  validation relerr: unconstrained {u.get('validation_relerr_pct', nan):.4g} %, "
                     f"consistent {c.get('validation_relerr_pct', nan):.4g} %; estimation "
                     f"{u.get('estimation_relerr_pct', nan):.4g} → {c.get('estimation_relerr_pct', nan):.4g} %")
        if "held_directions" in c:
            verdict = "FEASIBLE" if c["feasible"] else "NOT FEASIBLE"
            lines.append(f"  consistent: {verdict}, {c['held_directions']} link directions held at the model's, data "
                         f"scale {c['data_scale']:.3g}, SDP {c['sdp_wall_s']:.2f} s, implausible links "
                         f"{c['implausible'] or 'none'}; masses "
                         + ", ".join(f"{j} {m:.3g}" for j, m in c["masses"].items()))
        e = r.get("export") or {}
        if e:
            lines.append("  export: " + ("wrote the URDF, MJCF and YAML" if e["returncode"] == 0 else e["error"]))
            if e.get("loaded"):
                lines.append("  loaded: " + ", ".join(f"{k} {v:.2g}" for k, v in e["loaded"].items()))
        lines += [f"  {'PASS' if ok else 'FAIL'}  {t}" for t, ok in r["targets"].items()]
    return "\n".join(lines)


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if not args:
        raise SystemExit(__doc__.split("\n\n")[1])
    tmp = Path(tempfile.mkdtemp(prefix="consistent_export_"))
    runs = {}
    for arg in args:
        folder = Path(arg).resolve()
        reader = next((r for f, r in READERS.items() if (folder / f).is_file()), None)
        if reader is None:
            print(f"{folder}: not a recording bench/field.py knows: skipped", file=sys.stderr)
            continue
        for case in reader(folder, tmp):
            if "--system" not in case.identify or not any(a == "tx40" or a.startswith("urdf:") for a in case.identify):
                continue
            print(f"== {case.name}", file=sys.stderr)
            runs[case.name] = run_case(case, tmp)
    publish("consistent_export", summary(runs), runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
