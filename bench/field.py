"""Real logs through the command line with defaults, beside an independent least-squares baseline (not a test).

    .venv/bin/python bench/field.py DATA_DIR [DATA_DIR ...]   # e.g. ../shared/data/tx40_real ../shared/data/tiago_real

Each DATA_DIR is one of the real recordings of ``../shared/data`` (told apart by their files):

* ``tx40_real`` (``pos_read_data.csv`` + ``curr_data.csv``, 5 kHz, motor side, coupled wrist): what the
  README's worked example types: a layout, ``--drive tx40 --system tx40``; identify 0–6.3 s, validate on
  the rest.
* ``tiago_real`` (``tiago_position.csv`` + ``tiago_effort.csv`` + ``tiago.urdf``): what docs/field.md's
  TIAGo example types: a layout with ``effort_file``, ``--system urdf:tiago.urdf --hold-missing``;
  identify on the first 70 %, validate on the last 30 %.

The tool runs with its defaults (Coulomb, ``ls``, every pre-processing setting chosen from the data).
The baseline is an ordinary least-squares fit written here, sharing nothing with the tool but the
robot's description (the URDF, or the TX40 table and drive ratios): Pinocchio's joint torque regressor
of every body (10 standard parameters each, the joints the log lacks at 0) plus, per motor, a rotor
inertia, viscous and Coulomb friction and an offset acting through the transmission (τ = Rᵀ·f for the
motor angles R·q); dependent columns dropped by a pivoted QR; hand-chosen settings per log
(:data:`SETTINGS`): a zero-phase Butterworth filter of the positions, a decimation, trims, and rows of a
joint slower than a share of its top speed left out of the fit and of the metric, as the tool leaves out
its slow rows. Both validation errors are 100·‖τ̂ − τ‖/‖τ‖ against the recorded effort at the analysis
instants, overall and per joint.

Prints the table and writes bench/results/field.{json,txt}.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from _results import publish
from scipy import linalg, signal

TX40_LAYOUT = """\
header: true
rate_hz: 5000
joints: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6]
position: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort: [Joint_1, Joint_2, Joint_3, Joint_4, Joint_5, Joint_6]
effort_file: curr_data.csv
"""
TIAGO_JOINTS = ["torso_lift_joint"] + [f"arm_{k}_joint" for k in range(1, 8)]
TIAGO_LAYOUT = f"""\
header: true
time: {{column: t}}
joints: [{", ".join(TIAGO_JOINTS)}]
position: [{", ".join(f'"- {j}_position"' for j in TIAGO_JOINTS)}]
effort: [{", ".join(f'"- {j}_effort"' for j in TIAGO_JOINTS)}]
effort_file: tiago_effort.csv
"""

# Hand-chosen baseline settings: Butterworth order-4 cut-off (Hz), the rate the fit runs at (Hz), the
# trim at each end of each window (s), and the share of a joint's top speed (99th percentile) below
# which its rows are left out.
SETTINGS = {"tx40": {"cutoff_hz": 10.0, "rate_hz": 250.0, "trim_s": 0.2, "min_speed_share": 0.02},
            "tiago": {"cutoff_hz": 5.0, "rate_hz": 100.0, "trim_s": 1.0, "min_speed_share": 0.02}}
RANK_TOL = 1e-6  # pivots of the unit-norm columns below this share of the first: dependent columns


@dataclass
class Log:
    """One real recording: what the baseline reads and what the tool is given.

    Attributes:
        name: ``tx40`` or ``tiago``.
        t: sample times (s), increasing.
        q, effort: joint-side positions (rad or m) and torques (N·m or N), (N, J) in ``joints`` order.
        joints: the logged joints, model names.
        model: the Pinocchio model.
        R: (J, J) motor angles = R·q (the friction acts on the motors); identity without a transmission.
        rows: the joints whose efforts are fitted (those with a usable effort).
        split_s: identify before it, validate after it (s).
        tool: the CLI arguments after ``identify SOURCE`` (without the window and output).
        source: the file given to the CLI.
    """

    name: str
    t: np.ndarray
    q: np.ndarray
    effort: np.ndarray
    joints: list[str]
    model: object
    R: np.ndarray
    rows: list[str]
    split_s: float
    tool: list[str]
    source: Path


def _csv(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path) as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def read_tx40(folder: Path, tmp: Path) -> Log:
    """FIGAROH's TX40 log: motor angles and torques at 5 kHz, taken to the joint side by the drive's ratios."""
    from frictionid_core.drive import load_drive
    from frictionid_core.robots import build_tx40

    _, qm = _csv(folder / "pos_read_data.csv")
    _, y = _csv(folder / "curr_data.csv")
    drive = load_drive("tx40")
    R = np.diag(np.array(drive.gear_ratio, dtype=float))
    for motor, joint, ratio in drive.coupling:
        R[motor, joint] = ratio
    t = np.arange(len(qm)) / 5000.0
    layout = tmp / "tx40_layout.yaml"
    layout.write_text(TX40_LAYOUT)
    return Log("tx40", t, np.linalg.solve(R, qm.T).T, y @ R, list(drive.joints), build_tx40().model, R,
               list(drive.joints), 6.3, ["--layout", str(layout), "--drive", "tx40", "--system", "tx40"],
               folder / "pos_read_data.csv")


def read_tiago(folder: Path, tmp: Path) -> Log:
    """FIGAROH's TIAGo log: torso and arm at ~100 Hz (jittery stamps), one CSV per quantity; arm_5…7
    report no usable effort (their README), so their rows are not fitted."""
    import pinocchio as pin

    header, p = _csv(folder / "tiago_position.csv")
    _, e = _csv(folder / "tiago_effort.csv")
    joints = [c.removeprefix("- ").removesuffix("_position") for c in header[1:]]
    t = p[:, 0]
    layout = tmp / "tiago_layout.yaml"
    layout.write_text(TIAGO_LAYOUT)
    urdf = folder / "tiago.urdf"
    return Log("tiago", t, p[:, 1:], e[:, 1:], joints, pin.buildModelFromUrdf(str(urdf)), np.eye(len(joints)),
               joints[:5], float(t[0] + 0.7 * (t[-1] - t[0])),
               ["--layout", str(layout), "--system", f"urdf:{urdf}", "--hold-missing"], folder / "tiago_position.csv")


READERS = {"pos_read_data.csv": read_tx40, "tiago_position.csv": read_tiago}


# ------------------------------------------------------------------------------ the tool
def run_tool(log: Log, tmp: Path) -> tuple[dict, dict]:
    """(identification result, validation metrics) of the CLI with its defaults."""
    fit, val = tmp / f"{log.name}.json", tmp / f"{log.name}_val.json"
    _cli("identify", str(log.source), *log.tool, "--end", f"{log.split_s:.6g}", "--json", str(fit))
    layout = log.tool[log.tool.index("--layout") + 1]
    _cli("validate", str(log.source), "--layout", layout, "--params", str(fit), "--start", f"{log.split_s:.6g}",
         "--json", str(val))
    return json.loads(fit.read_text()), json.loads(val.read_text())["metrics"]


def _cli(*args: str) -> None:
    out = subprocess.run([sys.executable, "-m", "frictionid_core.cli", *args], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"frictionid {' '.join(args)} failed:\n{out.stderr}")
    print(out.stdout.rstrip() + ("\n" + out.stderr.rstrip() if out.stderr.strip() else ""), file=sys.stderr)


# ------------------------------------------------------------------------------ the baseline
def baseline(log: Log) -> dict:
    """The ordinary least-squares baseline (module doc): its validation relerr overall and per fitted joint."""
    import pinocchio as pin

    s = SETTINGS[log.name]
    rate = (len(log.t) - 1) / (log.t[-1] - log.t[0])
    grid = np.arange(log.t[0], log.t[-1], 1.0 / rate)  # uniform at the log's mean rate (jittery stamps)
    q = np.column_stack([np.interp(grid, log.t, c) for c in log.q.T])
    tau = np.column_stack([np.interp(grid, log.t, c) for c in log.effort.T])
    b, a = signal.butter(4, s["cutoff_hz"] / (rate / 2))
    qf = signal.filtfilt(b, a, q, axis=0)
    qd = np.gradient(qf, 1.0 / rate, axis=0)
    qdd = np.gradient(qd, 1.0 / rate, axis=0)
    pick = np.arange(0, len(grid), max(1, round(rate / s["rate_hz"])))
    t, q, qd, qdd, tau = grid[pick], qf[pick], qd[pick], qdd[pick], tau[pick]

    model = log.model
    data = model.createData()
    iq = [model.joints[model.getJointId(j)].idx_q for j in log.joints]
    iv = [model.joints[model.getJointId(j)].idx_v for j in log.joints]
    rows = [log.joints.index(j) for j in log.rows]
    q0 = pin.neutral(model)  # the joints the log lacks: at 0 (continuous joints: angle 0)
    n, nj = len(t), len(log.joints)
    Y = np.empty((n, len(rows), 10 * (model.njoints - 1)))
    for k in range(n):
        qk, vk, ak = q0.copy(), np.zeros(model.nv), np.zeros(model.nv)
        qk[iq], vk[iv], ak[iv] = q[k], qd[k], qdd[k]
        Y[k] = pin.computeJointTorqueRegressor(model, data, qk, vk, ak)[[iv[r] for r in rows]]
    w, wd = qd @ log.R.T, qdd @ log.R.T  # motor velocities and accelerations
    motor = np.zeros((n, len(rows), 4 * nj))  # per motor m: Ia, Fv, Fc, offset, through τ = Rᵀ·f
    for m in range(nj):
        for c, col in enumerate((wd[:, m], w[:, m], np.sign(w[:, m]), np.ones(n))):
            motor[:, :, 4 * m + c] = col[:, None] * log.R[m, rows][None, :]
    X = np.concatenate([Y, motor], axis=2)
    y = tau[:, rows]
    speed = np.abs(qd[:, rows])
    fast = speed >= s["min_speed_share"] * np.percentile(speed, 99, axis=0)
    trim = s["trim_s"]
    windows = {"estimation": (t >= t[0] + trim) & (t <= log.split_s - trim),
               "validation": (t >= log.split_s + trim) & (t <= t[-1] - trim)}

    def stacked(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        keep = fast & mask[:, None]  # (n, rows)
        return X.transpose(1, 0, 2)[keep.T], y.T[keep.T]

    Xe, ye = stacked(windows["estimation"])
    norms = np.linalg.norm(Xe, axis=0)
    live = np.flatnonzero(norms > 1e-10 * norms.max())
    _, Rq, piv = linalg.qr(Xe[:, live] / norms[live], mode="economic", pivoting=True)
    rank = int(np.sum(np.abs(np.diag(Rq)) > RANK_TOL * abs(Rq[0, 0])))
    cols = live[piv[:rank]]
    theta = np.linalg.lstsq(Xe[:, cols], ye, rcond=None)[0]
    out = {"settings": s, "rank": rank, "columns": int(live.size)}
    for name, mask in windows.items():
        use = fast & mask[:, None]
        err = np.where(use, X[:, :, cols] @ theta - y, 0.0)
        ref = np.where(use, y, 0.0)
        out[name] = {"relerr_pct": float(100 * np.linalg.norm(err) / np.linalg.norm(ref)),
                     "per_joint": {log.rows[r]: float(100 * np.linalg.norm(err[:, r]) / np.linalg.norm(ref[:, r]))
                                   for r in range(len(rows))}}
    return out


# ------------------------------------------------------------------------------ report
def summary(runs: dict) -> str:
    lines = ["real logs: the tool with defaults (CLI) beside an independent least-squares baseline; "
             "validation relerr % against the recorded effort"]
    for name, r in runs.items():
        tool, base = r["tool"]["validation"], r["baseline"]["validation"]
        lines.append(f"{name}: {r['command']}")
        lines.append(f"  {'':<18} {'tool':>8} {'baseline':>9}")
        lines.append(f"  {'overall':<18} {tool['relerr_pct']:8.2f} {base['relerr_pct']:9.2f}   ratio "
                     f"{tool['relerr_pct'] / base['relerr_pct']:.3f}")
        for joint, value in base["per_joint"].items():
            mine = tool.get("per_joint", {}).get(joint, {}).get("relerr_pct", float("nan"))
            lines.append(f"  {joint:<18} {mine:8.2f} {value:9.2f}")
        left = r["no_effort_joints"]
        lines.append(f"  tool: rank {r['identifiability']['rank']} of {r['identifiability']['columns']}, "
                     f"unresolved {r['identifiability']['unresolved'] or 'none'}, no usable effort {left or 'none'}, "
                     f"{len(r['held_joints'])} model joints held; baseline: rank {r['baseline']['rank']} of "
                     f"{r['baseline']['columns']} columns")
    return "\n".join(lines)


def main() -> int:
    if len(sys.argv) < 2:
        raise SystemExit(__doc__.split("\n\n")[1])
    tmp = Path(tempfile.mkdtemp(prefix="field_"))
    runs = {}
    for arg in sys.argv[1:]:
        folder = Path(arg)
        reader = next((r for f, r in READERS.items() if (folder / f).is_file()), None)
        if reader is None:
            raise SystemExit(f"{folder}: not a real log this bench knows (expected one of {sorted(READERS)} in it)")
        log = reader(folder, tmp)
        result, validation = run_tool(log, tmp)
        runs[log.name] = {"data": str(folder), "command": "identify " + " ".join(
                              a if not a.startswith(str(tmp)) else Path(a).name for a in log.tool),
                          "split_s": log.split_s, "tool": {"estimation": result["metrics"], "validation": validation},
                          "identifiability": result.get("identifiability") or {},
                          "held_joints": result.get("held_joints") or {},
                          "no_effort_joints": result.get("no_effort_joints") or [],
                          "baseline": baseline(log)}
    publish("field", summary(runs), runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
