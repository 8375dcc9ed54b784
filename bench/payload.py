#!/usr/bin/env python
"""Payload identification against known payloads, through the command line (not a test).

    .venv/bin/python bench/payload.py [DATA_DIR]     # default ../shared/data/tx40_real

* synthetic TX40 and UR5 (``tests/support/payload_logs.py``: 10 s Fourier excitations, Coulomb
  friction, 0.05 N·m torque noise, a 2.8 kg payload on the last link): ``identify`` on the
  unloaded log → BASE, ``payload`` on a loaded log, ``validate --payload`` on another loaded log,
  against a full re-identification on the loaded log validated on the same;
* the real TX40 log of FIGAROH (DATA_DIR, README's layout and ``--drive tx40``) with the torque of
  the same payload added: its joint motion filtered (zero-phase Butterworth 20 Hz, central
  differences), the payload's torque from Pinocchio (the model with and without it), taken back to
  motor torques through the drive and added to ``curr_data.csv``. BASE: ``identify`` on 0–6.3 s of
  the real log; ``payload`` on 0–6.3 s of the loaded one; validation on 6.3–9 s of the loaded one,
  BASE + payload against a full re-identification on 0–6.3 s of it.

Acceptance of the payload issue: mass within 1 % and centre of mass within 5 mm (synthetic), the
truth within 3 σ of every resolved quantity, validation with BASE + payload ≤ 1.1 × the full
re-identification's; on the real log the mass within 10 %. Writes bench/results/payload.{json,txt}.
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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "tx40_real"
SPLIT_S = 6.3
MOTION_CUTOFF_HZ = 20.0
LAYOUT = """\
header: true
rate_hz: 5000
joints: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6]
position: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort_file: curr_data.csv
"""


def frictionid(*args: str) -> float:
    """Run the CLI; its wall time, s (exits on failure)."""
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "frictionid_core.cli", *args], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"frictionid {' '.join(args)} failed:\n{out.stderr}")
    return time.perf_counter() - t0


def run_case(name: str, base_src: list[str], loaded_src: list[str], val_src: list[str], folder: Path,
             truth) -> dict:
    """identify BASE, payload, validate with it, full re-identification: the case's figures."""
    from frictionid_core.robots import body_quantities

    files = {k: folder / f"{name}_{k}.json" for k in ("base", "p", "full", "val_p", "val_full", "val_base")}
    system = ["--system", "tx40" if name.startswith("tx40") else truth["system"]]
    frictionid("identify", *base_src, *system, "--json", str(files["base"]))
    wall = frictionid("payload", *loaded_src, "--base", str(files["base"]), "--json", str(files["p"]))
    frictionid("identify", *loaded_src, *system, "--json", str(files["full"]))
    frictionid("validate", *val_src, "--params", str(files["base"]), "--payload", str(files["p"]), "--json",
               str(files["val_p"]))
    frictionid("validate", *val_src, "--params", str(files["full"]), "--json", str(files["val_full"]))
    frictionid("validate", *val_src, "--params", str(files["base"]), "--json", str(files["val_base"]))
    out = json.loads(files["p"].read_text())
    p = out["payload"]
    estimate = np.array(body_quantities(_standard(p)))
    expected = np.array(body_quantities(truth["payload"].standard()))
    sigma = np.array([_sigma(p, q) for q in _quantities()], dtype=float)
    resolved = np.array([q in p["resolved"] for q in _quantities()])
    z = np.abs(estimate - expected) / np.where(resolved, sigma, np.nan)
    val = {k: json.loads(files[k].read_text())["metrics"]["relerr_pct"] for k in ("val_p", "val_full", "val_base")}
    return {"mass": p["mass"], "mass_err_pct": 100 * (p["mass"] / truth["payload"].mass - 1),
            "com_err_mm": 1e3 * float(np.max(np.abs(np.subtract(p["com"], truth["payload"].com)))),
            "max_z_resolved": float(np.nanmax(z)), "resolved": p["resolved"], "feasible": p["feasible"],
            "loaded_relerr_pct": {"base": out["metrics_base"]["relerr_pct"],
                                  "base+payload": out["metrics"]["relerr_pct"]},
            "validation_relerr_pct": {"base": val["val_base"], "base+payload": val["val_p"], "full": val["val_full"]},
            "validation_ratio": val["val_p"] / val["val_full"], "payload_wall_s": wall, "payload": p}


def _quantities() -> tuple[str, ...]:
    from frictionid_core.robots import QUANTITIES

    return QUANTITIES


def _standard(p: dict) -> np.ndarray:
    from frictionid_core.robots.payload_model import body_parameters

    return body_parameters(p["mass"], p["com"], p["inertia"])


def _sigma(p: dict, quantity: str) -> float:
    from frictionid_core.robots import INERTIA_ENTRIES

    s = p["sigma"]
    if quantity == "mass":
        value = s["mass"]
    elif quantity.startswith("com."):
        value = s["com"]["xyz".index(quantity[-1])]
    else:
        a, b = INERTIA_ENTRIES[quantity.split(".")[1]]
        value = s["inertia"][a][b]
    return np.nan if value is None else value


def synthetic(folder: Path) -> dict:
    from frictionid_core.io import save_csv
    from support.payload_logs import loaded_logs

    out = {}
    for name in ("tx40", "ur5"):
        logs = loaded_logs(name)
        src = {}
        for part in ("base", "loaded", "validation"):
            src[part] = folder / f"{name}_{part}.csv"
            save_csv(getattr(logs, part), src[part])
        out[name] = run_case(name, [str(src["base"])], [str(src["loaded"])], [str(src["validation"])], folder,
                             {"system": logs.system, "payload": logs.payload})
    return out


def real_loaded(data: Path, folder: Path, payload) -> Path:
    """A copy of the real log with the payload's torque added to ``curr_data.csv``: its folder."""
    from frictionid_core.drive import load_drive
    from frictionid_core.io import load
    from frictionid_core.preprocess import central_difference, lowpass_position
    from frictionid_core.robots import build_tx40, robot_with_payload
    from frictionid_core.timeseries import JointSeries

    (folder / "layout.yaml").write_text(LAYOUT)
    series = load(data / "pos_read_data.csv", layout=folder / "layout.yaml")
    drive = load_drive("tx40")
    joint = drive.to_joint_side(series)
    fs = 1.0 / joint.dt
    q = lowpass_position(joint.position, fs, MOTION_CUTOFF_HZ)
    qd = central_difference(q, joint.dt)
    qdd = central_difference(qd, joint.dt)
    robot = build_tx40()
    order = [joint.joints.index(j) for j in robot.joints]
    q, qd, qdd = q[:, order], qd[:, order], qdd[:, order]
    added = robot_with_payload(robot, payload).inverse_dynamics(q, qd, qdd) - robot.inverse_dynamics(q, qd, qdd)
    torque = np.zeros_like(joint.effort)
    torque[:, order] = added
    extra = drive.to_recorded_side(JointSeries(joint.t, list(joint.joints), joint.position, torque, source="payload"))
    loaded = folder / "loaded"
    loaded.mkdir()
    (loaded / "pos_read_data.csv").write_bytes((data / "pos_read_data.csv").read_bytes())
    effort = np.loadtxt(data / "curr_data.csv", delimiter=",", skiprows=1)
    cols = [series.joints.index(j) for j in extra.joints]
    effort[:, cols] += extra.effort
    np.savetxt(loaded / "curr_data.csv", effort, delimiter=",", comments="", fmt="%.9g",
               header=",".join(f"Joint_{k}" for k in range(1, 7)))
    return loaded


def real(data: Path, folder: Path) -> dict:
    from frictionid_core.robots import Payload, build_tx40, default_link
    from support.payload_logs import PAYLOAD

    payload = Payload(default_link(build_tx40()), **PAYLOAD)
    loaded = real_loaded(data, folder, payload)
    common = ["--layout", str(folder / "layout.yaml"), "--drive", "tx40"]
    base = [str(data / "pos_read_data.csv"), *common, "--end", str(SPLIT_S)]
    fit = [str(loaded / "pos_read_data.csv"), *common, "--end", str(SPLIT_S)]
    val = [str(loaded / "pos_read_data.csv"), *common, "--start", str(SPLIT_S)]
    return run_case("tx40_real", base, fit, val, folder, {"system": "tx40", "payload": payload})


def main() -> int:
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_DATA
    folder = Path(tempfile.mkdtemp(prefix="payload_bench_"))
    out = {"synthetic": synthetic(folder)}
    if (data / "pos_read_data.csv").is_file():
        out["tx40_real"] = real(data, folder)
    checks = []
    for name, r in {**out["synthetic"], **({"tx40_real": out["tx40_real"]} if "tx40_real" in out else {})}.items():
        mass_tol = 10.0 if name == "tx40_real" else 1.0
        checks += [(f"{name}: mass within {mass_tol:g} %", r["mass_err_pct"], abs(r["mass_err_pct"]) <= mass_tol),
                   (f"{name}: validation BASE + payload ≤ 1.1 × full re-identification", r["validation_ratio"],
                    r["validation_ratio"] <= 1.1)]
        if name != "tx40_real":
            checks += [(f"{name}: centre of mass within 5 mm", r["com_err_mm"], r["com_err_mm"] <= 5.0),
                       (f"{name}: truth within 3 σ of every resolved quantity", r["max_z_resolved"],
                        r["max_z_resolved"] <= 3.0)]
    out["acceptance"] = [{"criterion": c, "value": float(v), "pass": bool(ok)} for c, v, ok in checks]
    lines = ["payload identification (a 2.8 kg payload on the last link), through the CLI"]
    for name, r in {**out["synthetic"], **({"tx40_real": out["tx40_real"]} if "tx40_real" in out else {})}.items():
        v = r["validation_relerr_pct"]
        lines.append(f"{name}: mass {r['mass']:.4f} kg ({r['mass_err_pct']:+.3f} %), centre of mass within "
                     f"{r['com_err_mm']:.2f} mm, max |error|/σ over the {len(r['resolved'])} resolved "
                     f"{r['max_z_resolved']:.2f}; validation relerr base {v['base']:.3g} %, base + payload "
                     f"{v['base+payload']:.4g} %, full re-identification {v['full']:.4g} % (ratio "
                     f"{r['validation_ratio']:.3f}); payload command {r['payload_wall_s']:.1f} s")
    lines += [f"{'PASS' if c['pass'] else 'FAIL'}  {c['criterion']}: {c['value']:.4g}" for c in out["acceptance"]]
    publish("payload", "\n".join(lines), out)
    return 0 if all(c["pass"] for c in out["acceptance"]) else 1


if __name__ == "__main__":
    sys.exit(main())
