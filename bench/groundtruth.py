#!/usr/bin/env python
"""Ground truth: frictionid's friction and rotor-inertia estimates against known values and mujoco.sysid.

    .venv/bin/python bench/groundtruth.py --quick   # UR5 with MuJoCo's friction only (~3–5 min)
    .venv/bin/python bench/groundtruth.py           # the three scenarios below (~10 min)

Scenarios (MuJoCo arms, :class:`frictionid_core.loop.sim.SimArm`, 1 kHz):

* ``ur5_mujoco``: the UR5 of example-robot-data with MuJoCo's own joint ``damping`` (viscous),
  ``frictionloss`` (dry friction, a constraint of MuJoCo's solver that sticks at low speed) and
  ``armature`` (rotor inertia) hidden per joint;
* ``ur5_coulomb``: the control — the same arm and values, the friction applied as the core's law
  (Stribeck with Fs = Fc: viscous + Coulomb, sign smoothed over 1e-3 rad/s), as the loop simulator does;
* ``tx40_mujoco``: the core's ``tx40`` system with MuJoCo's friction (the published Fv, Fc) and
  rotor inertias 20 % above the model's.

Each arm follows a ``frictionid excite`` trajectory under PD + computed torque (the controller's
model knows the rotor inertias, not the friction), logged at 1 kHz with quantised encoder positions
and white torque noise of 1.5 % of each joint's torque range. Estimation and validation logs come
from different excitation and noise seeds. On the estimation log:

* frictionid through its CLI (``identify --json``), the rigid body held at the URDF's
  (``--known-rigid-body`` when ``identify --help`` lists it, else ``--fix`` of every base parameter
  of ``nominal_parameters`` that holds no rotor inertia), with the defaults (coulomb, ls), each law
  (tustin, stribeck: hybrid) and the issue's two diagnoses (``--min-speed 0.05``, ``--cutoff 50``);
* mujoco.sysid (bench/.venv-sysid, its own process: ``_sysid_worker.py``): Gauss-Newton on open-loop
  rollouts of the logged torque, damping, frictionloss and armature per joint.

Per parameter: truth, estimate, error %, σ (and the robust σ when the result has one), whether
1.96σ covers the truth; per run: wall time of the whole process and ``frictionid validate``'s
relative torque error on the validation log (truth and mujoco.sysid's values go through the same
``validate``, written into a copy of the Coulomb result). Also per joint: the share of samples
where the arm sticks (|dry friction| below its level) and the fastest such sample.
Results: bench/results/groundtruth{,_quick}.{txt,json}.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import optimizers  # ensure_venv: the peers' venvs
from _results import publish

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
FRICTIONID = [sys.executable, "-m", "frictionid_core.cli"]
RATE = 1000.0  # Hz, the simulation step and the log
ENCODER_COUNTS = 2**19  # per revolution: the position quantum 2π/2^19 ≈ 1.2e-5 rad
TORQUE_NOISE = 0.015  # 1σ white torque noise, fraction of the joint's torque range in the log
STICK_LEVEL = 0.99  # a sample sticks when |dry friction| < this × its level (Fc, frictionloss)
Z95 = 1.96
# log name: (excitation seed, noise seed)
LOGS = {"estimation": (1, 11), "validation": (2, 21)}


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A hidden truth: ``robot`` (a ``--system`` spec), ``law`` ``mujoco`` (MuJoCo's damping and
    frictionloss) or ``core`` (the core's Stribeck law with Fs = Fc), per joint ``damping``
    [N·m·s/rad], ``frictionloss`` [N·m] and rotor inertia ``armature`` [kg·m²]."""

    robot: str
    law: str
    damping: tuple
    frictionloss: tuple
    armature: tuple


def _ur5() -> str:
    from frictionid_core.robots import example_robot_data_dir

    return f"urdf:{example_robot_data_dir() / 'ur_description' / 'urdf' / 'ur5_robot.urdf'}"


UR5_DAMPING = (6.0, 5.0, 3.5, 1.2, 1.0, 0.8)
UR5_FRICTIONLOSS = (7.0, 6.5, 4.5, 1.5, 1.4, 1.3)
UR5_ARMATURE = (0.40, 0.40, 0.20, 0.06, 0.06, 0.06)


def scenarios() -> dict[str, Scenario]:
    from frictionid_core.robots.tx40 import FRICTION, ROTOR_INERTIA

    ur5 = _ur5()
    return {
        "ur5_mujoco": Scenario(ur5, "mujoco", UR5_DAMPING, UR5_FRICTIONLOSS, UR5_ARMATURE),
        "ur5_coulomb": Scenario(ur5, "core", UR5_DAMPING, UR5_FRICTIONLOSS, UR5_ARMATURE),
        "tx40_mujoco": Scenario("tx40", "mujoco", FRICTION["Fv"], FRICTION["Fc"],
                                tuple(1.2 * a for a in ROTOR_INERTIA)),
    }


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def run_cli(*args: str) -> tuple[float, str]:
    """``frictionid ARGS`` in a process of its own: (wall s, stdout); exits on failure."""
    t0 = time.perf_counter()
    proc = subprocess.run([*FRICTIONID, *args], capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    if proc.returncode:
        raise SystemExit(f"frictionid {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr}")
    return wall, proc.stdout


# ----------------------------------------------------------------------------- the logs
def truth_robot(sc: Scenario):
    """The scenario's RobotModel with its hidden rotor inertias (the simulator's and the controller's)."""
    import pinocchio as pin

    from frictionid_core.loop import load_robot

    robot = load_robot(sc.robot)
    model = pin.Model(robot.model)
    model.armature[:] = np.asarray(sc.armature, dtype=float)
    return dataclasses.replace(robot, model=model, _data=None)


class Reference:
    """The sampled excitation as the tracking controller's trajectory (``at(t)`` → q, q̇, q̈)."""

    def __init__(self, trajectory, joints: list[str]):
        self.t, q, qd, qdd = trajectory.sample(RATE)
        order = [trajectory.joints.index(j) for j in joints]
        self.q, self.qd, self.qdd = q[:, order], qd[:, order], qdd[:, order]
        self.q0 = self.q[0]

    def at(self, t: float):
        k = min(int(round(t * RATE)), len(self.t) - 1)
        return self.q[k], self.qd[k], self.qdd[k]


def simulate(sc: Scenario, trajectory) -> dict:
    """Track ``trajectory`` on the scenario's arm: per step k (before it) t, q, q̇ (N,)/(N, J), the
    torque τ applied during it and the friction torque of the step (``friction``, opposing the motion)."""
    from frictionid_core.loop import Controller, SimArm

    robot = truth_robot(sc)
    ref = Reference(trajectory, robot.joints)
    if sc.law == "mujoco":
        sim = SimArm(robot, None, q0=ref.q0, damping=sc.damping, frictionloss=sc.frictionloss)
    else:  # the core's Stribeck law with Fs = Fc: viscous + Coulomb
        fv, fc = np.asarray(sc.damping), np.asarray(sc.frictionloss)
        sim = SimArm(robot, np.column_stack([fv, fc, fc, np.full_like(fc, 0.05), np.full_like(fc, 2.0)]), q0=ref.q0)
    sim.data.qvel[:] = ref.qd[0]
    controller = Controller(robot, ref)
    n = len(ref.t) - 1
    out = {k: np.empty((n, robot.nv)) for k in ("q", "qd", "tau", "friction", "qd_after")}
    for k in range(n):
        out["q"][k], out["qd"][k] = sim.q, sim.qd
        tau, _, _ = controller.command(k / RATE, out["q"][k], out["qd"][k])
        sim.step(tau)
        out["tau"][k], out["friction"][k], out["qd_after"][k] = tau, sim.tau_friction, sim.qd
    out["t"] = ref.t[:n]
    out["tracking_error_max"] = np.max(np.abs(out["q"] - ref.q[:n]), axis=0)
    out["joints"] = list(robot.joints)
    return out


def stick_figures(sc: Scenario, sim: dict) -> dict:
    """Per joint: share of steps whose dry friction (the step's friction minus the viscous part
    at the step's end velocity, as both laws integrate it) is below STICK_LEVEL × its level — the
    arm sticks, or creeps under MuJoCo's soft frictionloss — and the fastest |q̇| among them [rad/s]."""
    qd = sim["qd_after"][1:]  # from the second step: the first starts the solver cold
    dry = sim["friction"][1:] - np.asarray(sc.damping) * qd
    stuck = np.abs(dry) < STICK_LEVEL * np.asarray(sc.frictionloss)
    speed = np.abs(qd)
    return {"share": stuck.mean(axis=0).tolist(),
            "max_speed": [float(speed[stuck[:, j], j].max()) if stuck[:, j].any() else 0.0
                          for j in range(stuck.shape[1])]}


def make_log(sc: Scenario, folder: Path, name: str, seed_offset: int = 0) -> dict:
    """Excite, simulate and record the ``name`` log of ``sc`` in ``folder`` (reused when present),
    its seeds those of LOGS + ``seed_offset``: {"bag": path, "npz": path of the clean record and noise levels}."""
    from frictionid_core.excitation import load_trajectory
    from frictionid_core.io import write_joint_state_bag
    from frictionid_core.timeseries import JointSeries

    excite_seed, noise_seed = (s + seed_offset for s in LOGS[name])
    bag, npz = folder / f"{name}_bag", folder / f"{name}.npz"
    if bag.exists() and npz.exists():
        return {"bag": bag, "npz": npz}
    traj_path = folder / f"{name}_excitation.npz"
    run_cli("excite", "--system", sc.robot, "--out", str(traj_path), "--seed", str(excite_seed))
    sim = simulate(sc, load_trajectory(traj_path))
    rng = np.random.default_rng(noise_seed)
    quantum = 2.0 * np.pi / ENCODER_COUNTS
    position = np.round(sim["q"] / quantum) * quantum
    sigma_tau = TORQUE_NOISE * np.ptp(sim["tau"], axis=0)
    effort = sim["tau"] + rng.standard_normal(sim["tau"].shape) * sigma_tau
    series = JointSeries(sim["t"], sim["joints"], position, effort, source=f"{name} log")
    if bag.exists():
        import shutil

        shutil.rmtree(bag)
    write_joint_state_bag(bag, series)
    np.savez(npz, position=position, effort=effort, torque_noise=sigma_tau, quantum=quantum,
             **{k: np.asarray(v) for k, v in sim.items()})
    return {"bag": bag, "npz": npz}


# ----------------------------------------------------------------------------- frictionid
@dataclasses.dataclass
class RigidBody:
    """The rigid body of ``--system`` ``spec`` as modelled: ``nominal`` {base parameter: value};
    ``rotor`` {joint: (base parameter holding its rotor inertia, coefficient)}; ``armature`` the
    model's rotor inertias {joint: kg·m²}."""

    nominal: dict
    rotor: dict
    armature: dict

    @classmethod
    def of(cls, spec: str) -> RigidBody:
        from frictionid_core.systems import get_system, nominal_parameters

        system = get_system(spec)
        nominal = nominal_parameters(system)
        names, A = list(nominal), system.robot.base.combination_matrix()
        standard = list(system.robot.base.names)
        robot = system.robot.model
        rotor = {}
        for j in robot.joints:
            rows = np.flatnonzero(A[:, standard.index(f"{j}.Ia")])
            if rows.size != 1:
                raise SystemExit(f"{spec}: the rotor inertia of {j} is in {rows.size} base parameters")
            rotor[j] = (names[rows[0]], float(A[rows[0], standard.index(f"{j}.Ia")]))
        return cls(nominal, rotor, dict(zip(robot.joints, map(float, robot.armature))))

    def fixed(self) -> dict:
        """The base parameters that hold no rotor inertia (what ``--fix`` holds)."""
        held = {name for name, _ in self.rotor.values()}
        return {k: v for k, v in self.nominal.items() if k not in held}

    def armature_of(self, params: dict) -> dict:
        """{joint: rotor inertia} of identified base parameters (the others at their nominal)."""
        return {j: self.armature[j] + (params[name] - self.nominal[name]) / c for j, (name, c) in self.rotor.items()}

    def with_armature(self, armature: dict) -> dict:
        """{base parameter holding a rotor inertia: its value} for rotor inertias ``armature``."""
        return {name: self.nominal[name] + c * (armature[j] - self.armature[j]) for j, (name, c) in self.rotor.items()}


# label: identify arguments besides the source, the system and the rigid body
RUNS = {
    "coulomb ls (defaults)": ("--friction", "coulomb", "--solver", "ls"),
    "coulomb ls --min-speed 0.05": ("--friction", "coulomb", "--solver", "ls", "--min-speed", "0.05"),
    "coulomb ls --cutoff 50": ("--friction", "coulomb", "--solver", "ls", "--cutoff", "50"),
    "coulomb ls --min-speed 0.05 --cutoff 50": ("--friction", "coulomb", "--solver", "ls", "--min-speed", "0.05",
                                                "--cutoff", "50"),
    "tustin hybrid": ("--friction", "tustin", "--solver", "hybrid"),
    "stribeck hybrid": ("--friction", "stribeck", "--solver", "hybrid"),
}
DEFAULT_RUN = "coulomb ls (defaults)"


def rigid_arguments(rigid: RigidBody) -> tuple[list[str], str]:
    """(identify arguments holding the rigid body at the model's, how): ``--known-rigid-body`` when
    the CLI has it, else one ``--fix`` per base parameter that holds no rotor inertia."""
    _, helptext = run_cli("identify", "--help")
    if "--known-rigid-body" in helptext:
        return ["--known-rigid-body"], "--known-rigid-body"
    fixed = rigid.fixed()
    return [f"--fix={k}={v!r}" for k, v in fixed.items()], f"{len(fixed)} --fix (the rotor inertias free)"


def run_frictionid(sc: Scenario, bag: Path, folder: Path, label: str, rigid_args: list[str]) -> dict:
    """One ``frictionid identify`` run: its result JSON and the process's wall time."""
    out = folder / (re.sub(r"[^a-z0-9]+", "_", label.lower()).strip("_") + ".json")
    wall, _ = run_cli("identify", str(bag), "--system", sc.robot, *RUNS[label], *rigid_args, "--json", str(out))
    return {"label": label, "json": str(out), "wall_s": wall, "result": json.loads(out.read_text())}


def validation_relerr(params_json: Path, bag: Path) -> float:
    """``frictionid validate``'s relative torque error [%] of a result file on the validation log."""
    out = params_json.with_suffix(".validation.json")
    run_cli("validate", str(bag), "--params", str(params_json), "--json", str(out))
    return float(json.loads(out.read_text())["metrics"]["relerr_pct"])


def parameter_set(template: dict, rigid: RigidBody, values: dict) -> dict:
    """A Coulomb result (``template``) carrying other values: ``values`` {joint: {Fv, Fc, armature}},
    offsets 0, no σ — the truth's or mujoco.sysid's, for ``frictionid validate``."""
    out = copy.deepcopy(template)
    params = out["params"]
    params.update(rigid.with_armature({j: v["armature"] for j, v in values.items()}))
    for j, v in values.items():
        params[f"{j}/Fv"], params[f"{j}/Fc"], params[f"{j}/offset"] = v["Fv"], v["Fc"], 0.0
    out["std"] = {}
    return out


def truth_values(sc: Scenario, joints: list[str]) -> dict:
    return {j: {"Fv": float(sc.damping[k]), "Fc": float(sc.frictionloss[k]), "armature": float(sc.armature[k])}
            for k, j in enumerate(joints)}


# ----------------------------------------------------------------------------- mujoco.sysid
SYSID_START = {"damping": 1.0, "frictionloss": 1.0, "armature": 0.1}  # the same for every joint and arm
SYSID_BOUNDS = {"damping": (0.0, 50.0), "frictionloss": (0.0, 50.0), "armature": (1e-3, 5.0)}
SYSID_CHUNK_S = 0.5
SYSID_VELOCITY_WINDOW = 21  # samples of the Savitzky–Golay velocity at each chunk's start
SYSID_MAX_ITERS = 100


def sysid_xml(spec: str) -> str:
    """The MJCF of ``spec`` as modelled (:func:`frictionid_core.loop.sim.mjcf`) with a motor and a
    jointpos sensor per joint."""
    from frictionid_core.loop.sim import load_robot, mjcf

    robot = load_robot(spec)
    motors = "".join(f'<motor name="{j}_motor" joint="{j}"/>' for j in robot.joints)
    sensors = "".join(f'<jointpos name="{j}_pos" joint="{j}"/>' for j in robot.joints)
    return mjcf(robot).replace("</mujoco>", f"  <actuator>{motors}</actuator>\n  <sensor>{sensors}</sensor>\n</mujoco>")


def run_sysid(sc: Scenario, npz: Path, folder: Path, py: Path, joints: list[str]) -> dict:
    """mujoco.sysid on the estimation log in bench/.venv-sysid (``_sysid_worker.py``): its output
    and the process's wall time."""
    z = np.load(npz)
    log_path = folder / "sysid_log.npz"
    np.savez(log_path, t=z["t"], position=z["position"], effort=z["effort"])
    job = {"xml": sysid_xml(sc.robot), "log": str(log_path), "joints": joints, "chunk_s": SYSID_CHUNK_S,
           "velocity_window": SYSID_VELOCITY_WINDOW, "start": SYSID_START,
           "bounds": {k: list(v) for k, v in SYSID_BOUNDS.items()}, "max_iters": SYSID_MAX_ITERS}
    job_path, out_path = folder / "sysid_job.json", folder / "sysid_out.json"
    job_path.write_text(json.dumps(job))
    t0 = time.perf_counter()
    proc = subprocess.run([str(py), str(BENCH / "_sysid_worker.py"), str(job_path), str(out_path)],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode:
        raise SystemExit(f"mujoco.sysid worker failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return {"wall_s": wall, **json.loads(out_path.read_text())}


# ----------------------------------------------------------------------------- figures
KEYS = ("Fv", "Fc", "armature")
ROBUST_STD_KEYS = ("std_robust", "robust_std")  # where a result would keep a robust σ
# A fit diverged when an estimate is not finite, Fv, Fc or a rotor inertia is off by more than
# DIVERGED_ERROR_PCT, |Fs| exceeds DIVERGED_FS_FACTOR × the true Fc (Fs below Fc is no blow-up: it
# fits MuJoCo's friction, which stays under its level at low speed) or the validation error
# exceeds DIVERGED_RELERR_FACTOR × the truth's.
DIVERGED_ERROR_PCT = 100.0
DIVERGED_FS_FACTOR = 10.0
DIVERGED_RELERR_FACTOR = 2.0


def pct(est: float, truth: float) -> float:
    return 100.0 * (est - truth) / truth


def frictionid_rows(result: dict, rigid: RigidBody, truth: dict) -> list[dict]:
    """Per joint and parameter (Fv, Fc, armature; Fs too when the law has it, against Fc: the
    truth has no Stribeck hump): truth, estimate, error %, σ, robust σ, 1.96σ covers the truth."""
    params, std = result["params"], result.get("std") or {}
    robust = next((result[k] for k in ROBUST_STD_KEYS if isinstance(result.get(k), dict)), None)
    armature = rigid.armature_of(params)
    rows = []
    for j, tv in truth.items():
        name_of = {"Fv": f"{j}/Fv", "Fc": f"{j}/Fc", "Fs": f"{j}/Fs", "armature": rigid.rotor[j][0]}
        for key in (*KEYS, "Fs"):
            name = name_of[key]
            if name not in params:
                continue
            coef = rigid.rotor[j][1] if key == "armature" else 1.0
            est = armature[j] if key == "armature" else params[name]
            t = tv["Fc" if key == "Fs" else key]
            sd = std.get(name)
            sd = None if sd is None else abs(sd / coef)
            rsd = None if robust is None or robust.get(name) is None else abs(robust[name] / coef)
            rows.append({"joint": j, "param": key, "truth": t, "estimate": est, "error_pct": pct(est, t),
                         "std": sd, "std_robust": rsd,
                         "covered": None if sd is None else bool(abs(est - t) <= Z95 * sd),
                         "covered_robust": None if rsd is None else bool(abs(est - t) <= Z95 * rsd)})
    return rows


def sysid_rows(out: dict, truth: dict) -> list[dict]:
    kind = {"Fv": "damping", "Fc": "frictionloss", "armature": "armature"}
    rows = []
    for j, tv in truth.items():
        for key in KEYS:
            est, sd = out["params"][f"{j}/{kind[key]}"], out["std"][f"{j}/{kind[key]}"]
            rows.append({"joint": j, "param": key, "truth": tv[key], "estimate": est,
                         "error_pct": pct(est, tv[key]), "std": sd, "std_robust": None,
                         "covered": bool(abs(est - tv[key]) <= Z95 * sd), "covered_robust": None})
    return rows


def summary(rows: list[dict]) -> dict:
    """Largest |error| % per parameter kind and the coverage counts of Fv, Fc and armature."""
    out = {f"max_abs_error_pct_{k}": max((abs(r["error_pct"]) for r in rows if r["param"] == k), default=None)
           for k in (*KEYS, "Fs")}
    core = [r for r in rows if r["param"] in KEYS]
    for key in ("covered", "covered_robust"):
        known = [r[key] for r in core if r[key] is not None]
        out[key] = [sum(known), len(known)] if known else None
    return out


def diverged(rows: list[dict], relerr: float, truth_relerr: float) -> bool:
    """See DIVERGED_ERROR_PCT."""
    if not all(np.isfinite(r["estimate"]) for r in rows) or not np.isfinite(relerr):
        return True
    return (any(abs(r["error_pct"]) > DIVERGED_ERROR_PCT for r in rows if r["param"] in KEYS)
            or any(abs(r["estimate"]) > DIVERGED_FS_FACTOR * r["truth"] for r in rows if r["param"] == "Fs")
            or relerr > DIVERGED_RELERR_FACTOR * truth_relerr)


def run_scenario(name: str, sc: Scenario, folder: Path, sysid_py: Path | None, seed_offset: int = 0) -> dict:
    folder.mkdir(parents=True, exist_ok=True)
    log(f"[{name}] logs ...")
    logs = {k: make_log(sc, folder, k, seed_offset) for k in LOGS}
    est = np.load(logs["estimation"]["npz"])
    joints = [str(j) for j in est["joints"]]
    truth = truth_values(sc, joints)
    rigid = RigidBody.of(sc.robot)
    rigid_args, rigid_how = rigid_arguments(rigid)
    out = {"robot": sc.robot, "law": sc.law, "joints": joints, "truth": truth, "rigid_body": rigid_how,
           "log": {"seconds": float(est["t"][-1] - est["t"][0]), "rate_hz": RATE,
                   "position_quantum_rad": float(est["quantum"]),
                   "torque_noise": dict(zip(joints, map(float, est["torque_noise"]))),
                   "tracking_error_max_rad": dict(zip(joints, map(float, est["tracking_error_max"])))},
           "runs": {}}
    out["stick"] = {k: stick_figures(sc, np.load(v["npz"])) for k, v in logs.items()}
    template = None
    for label in RUNS:
        log(f"[{name}] frictionid {label} ...")
        r = run_frictionid(sc, logs["estimation"]["bag"], folder, label, rigid_args)
        relerr = validation_relerr(Path(r["json"]), logs["validation"]["bag"])
        rows = frictionid_rows(r["result"], rigid, truth)
        out["runs"][label] = {"tool": "frictionid", "wall_s": r["wall_s"], "fit_s": r["result"].get("wall_s"),
                              "validation_relerr_pct": relerr, "rows": rows, **summary(rows),
                              "preprocessing": {k: r["result"]["preprocessing"].get(k)
                                                for k in ("cutoff_hz", "decimate", "min_speed")}}
        if label == DEFAULT_RUN:
            template = r["result"]
    truth_json = folder / "truth_params.json"
    truth_json.write_text(json.dumps(parameter_set(template, rigid, truth)))
    out["truth_validation_relerr_pct"] = validation_relerr(truth_json, logs["validation"]["bag"])
    for run in out["runs"].values():
        run["diverged"] = diverged(run["rows"], run["validation_relerr_pct"], out["truth_validation_relerr_pct"])
    if sysid_py is not None:
        log(f"[{name}] mujoco.sysid ...")
        s = run_sysid(sc, logs["estimation"]["npz"], folder, sysid_py, joints)
        values = {j: {"Fv": s["params"][f"{j}/damping"], "Fc": s["params"][f"{j}/frictionloss"],
                      "armature": s["params"][f"{j}/armature"]} for j in joints}
        sysid_json = folder / "sysid_params.json"
        sysid_json.write_text(json.dumps(parameter_set(template, rigid, values)))
        rows = sysid_rows(s, truth)
        relerr = validation_relerr(sysid_json, logs["validation"]["bag"])
        out["runs"]["mujoco.sysid"] = {
            "tool": "mujoco.sysid", "wall_s": s["wall_s"], "fit_s": s["fit_s"], "validation_relerr_pct": relerr,
            "rows": rows, **summary(rows), "diverged": diverged(rows, relerr, out["truth_validation_relerr_pct"]),
            "settings": {"start": SYSID_START, "bounds": SYSID_BOUNDS, "chunk_s": SYSID_CHUNK_S,
                         "velocity_window": SYSID_VELOCITY_WINDOW, "max_iters": SYSID_MAX_ITERS},
            **{k: s[k] for k in ("cost_start", "cost", "residuals", "chunks", "mujoco")}}
    return out


# ----------------------------------------------------------------------------- targets and report
FV_FC_TOL_PCT, ARMATURE_TOL_PCT = 3.0, 10.0  # MuJoCo's friction, defaults, rigid body known
COULOMB_TOL_PCT = 2.0  # the near-ideal Coulomb truth
COVERAGE_MIN = 0.8  # share of Fv, Fc, armature whose 1.96σ (the robust one) covers the truth
SPEEDUP_MIN = 20.0  # mujoco.sysid's wall time over frictionid's defaults, same log, same run


def targets(res: dict) -> list[dict]:
    """The acceptance checks of every scenario (name, measured, PASS/FAIL)."""
    out = []
    for name, sc in res["scenarios"].items():
        d = sc["runs"][DEFAULT_RUN]
        if sc["law"] == "mujoco":
            worst = {k: d[f"max_abs_error_pct_{k}"] for k in KEYS}
            ok = worst["Fv"] <= FV_FC_TOL_PCT and worst["Fc"] <= FV_FC_TOL_PCT and worst["armature"] <= ARMATURE_TOL_PCT
            out.append({"scenario": name, "target": f"defaults: Fv, Fc within {FV_FC_TOL_PCT:g} %, armature within "
                        f"{ARMATURE_TOL_PCT:g} %", "measured": ", ".join(f"{k} {v:.3g} %" for k, v in worst.items()),
                        "pass": ok})
        else:
            worst = max(d["max_abs_error_pct_Fv"], d["max_abs_error_pct_Fc"])
            out.append({"scenario": name, "target": f"defaults: Fv, Fc within {COULOMB_TOL_PCT:g} %",
                        "measured": f"{worst:.3g} %", "pass": worst <= COULOMB_TOL_PCT})
        bad = [lb for lb, r in sc["runs"].items() if "hybrid" in lb and r["diverged"]]
        out.append({"scenario": name, "target": "no hybrid fit diverges", "measured": ", ".join(bad) or "none",
                    "pass": not bad})
        key = "covered_robust" if d["covered_robust"] else "covered"
        hit, n = d[key]
        which = "robust σ" if key == "covered_robust" else "σ: no robust σ in the result"
        out.append({"scenario": name, "target": f"1.96σ covers the truth for ≥ {COVERAGE_MIN:.0%} of Fv, Fc, armature",
                    "measured": f"{hit}/{n} ({which})", "pass": hit >= COVERAGE_MIN * n})
        if "mujoco.sysid" in sc["runs"]:
            ratio = sc["runs"]["mujoco.sysid"]["wall_s"] / d["wall_s"]
            out.append({"scenario": name, "target": f"≥ {SPEEDUP_MIN:g}× faster than mujoco.sysid",
                        "measured": f"{ratio:.1f}×", "pass": ratio >= SPEEDUP_MIN})
    return out


def _f(x, spec: str = ".3g") -> str:
    return "—" if x is None else format(x, spec)


def report(res: dict) -> str:
    lines = [f"groundtruth{' (quick)' if res['quick'] else ''}: friction and rotor inertias against known values "
             f"({res['host']['python']}, load {res['host']['load_start']} → {res['host']['load_end']}, "
             f"{res['wall_s']:.0f} s in all)"]
    for name, sc in res["scenarios"].items():
        lg = sc["log"]
        lines += ["", f"== {name}: {Path(sc['robot']).name if sc['robot'] != 'tx40' else 'tx40'}, "
                      f"{'MuJoCo damping + frictionloss' if sc['law'] == 'mujoco' else 'core law, Fs = Fc'}; "
                      f"rigid body: {sc['rigid_body']}",
                  f"   logs {lg['seconds']:.0f} s at {lg['rate_hz']:g} Hz, position quantum "
                  f"{lg['position_quantum_rad']:.3g} rad, torque noise σ "
                  + ", ".join(f"{v:.3g}" for v in lg["torque_noise"].values()) + " N·m"]
        if "stick" in sc:
            st = sc["stick"]["estimation"]
            lines.append(f"   samples sticking (|dry friction| < {STICK_LEVEL:g} × its level) per joint: "
                         + ", ".join(f"{100 * s:.1f} %" for s in st["share"])
                         + f"; at speeds up to {max(st['max_speed']):.3g} rad/s")
        lines.append(f"   truth's validation relerr {sc['truth_validation_relerr_pct']:.3f} %")
        lines.append(f"   {'run':<41}{'wall s':>8}{'fit s':>8}{'val %':>9}{'|Fv| %':>9}{'|Fc| %':>9}"
                     f"{'|Ia| %':>9}{'|Fs| %':>10}{'1.96σ':>8}{'robust':>8}  diverged")
        for label, r in sc["runs"].items():
            cov = "/".join(map(str, r["covered"])) if r["covered"] else "—"
            rcov = "/".join(map(str, r["covered_robust"])) if r["covered_robust"] else "—"
            lines.append(f"   {label:<41}{r['wall_s']:>8.2f}{_f(r['fit_s'], '.2f'):>8}"
                         f"{r['validation_relerr_pct']:>9.4g}"
                         f"{_f(r['max_abs_error_pct_Fv']):>9}{_f(r['max_abs_error_pct_Fc']):>9}"
                         f"{_f(r['max_abs_error_pct_armature']):>9}{_f(r['max_abs_error_pct_Fs']):>10}"
                         f"{cov:>8}{rcov:>8}  {'YES' if r['diverged'] else 'no'}")
        for label in (DEFAULT_RUN, "mujoco.sysid"):
            if label not in sc["runs"]:
                continue
            lines.append(f"   {label}: per parameter")
            lines.append(f"     {'joint':<22}{'param':<10}{'truth':>10}{'estimate':>12}{'err %':>9}{'σ':>11}"
                         f"{'robust σ':>11}  1.96σ covers")
            for row in sc["runs"][label]["rows"]:
                if row["param"] not in KEYS:
                    continue
                cov = "—" if row["covered"] is None else ("yes" if row["covered"] else "NO")
                lines.append(f"     {row['joint']:<22}{row['param']:<10}{row['truth']:>10.4g}{row['estimate']:>12.5g}"
                             f"{row['error_pct']:>+9.2f}{_f(row['std'], '.3g'):>11}{_f(row['std_robust'], '.3g'):>11}"
                             f"  {cov}")
        errs = {label: {k: [r["error_pct"] for r in run["rows"] if r["param"] == k] for k in (*KEYS, "Fs")}
                for label, run in sc["runs"].items()}
        lines.append("   error % per joint (Fv | Fc | armature):")
        for label, e in errs.items():
            lines.append(f"     {label:<41}" + " | ".join(" ".join(f"{v:+.1f}" for v in e[k]) for k in KEYS))
        hyb = {label: e["Fs"] for label, e in errs.items() if e["Fs"]}
        for label, e in hyb.items():
            lines.append(f"     {label:<41}Fs vs Fc: " + " ".join(f"{v:+.3g}" for v in e))
    lines += ["", "targets (the acceptance, on these logs):"]
    for t in res["targets"]:
        lines.append(f"  {'PASS' if t['pass'] else 'FAIL'}  {t['scenario']:<12} {t['target']}: {t['measured']}")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="ur5_mujoco only (~3–5 min)")
    p.add_argument("--scenarios", help="comma-separated scenarios (default: all; --quick: ur5_mujoco)")
    p.add_argument("--keep", type=Path, help="keep (and reuse) the logs and results in this folder")
    p.add_argument("--no-sysid", action="store_true", help="leave mujoco.sysid out")
    p.add_argument("--no-install", action="store_true", help="never create bench/.venv-sysid")
    p.add_argument("--seed-offset", type=int, default=0,
                   help="add this to every excitation and noise seed: other logs of the same arms (default 0)")
    args = p.parse_args(argv)
    all_scenarios = scenarios()
    names = (args.scenarios.split(",") if args.scenarios else ["ur5_mujoco"] if args.quick else list(all_scenarios))
    unknown = [n for n in names if n not in all_scenarios]
    if unknown:
        p.error(f"unknown scenario(s) {unknown}; choose from {list(all_scenarios)}")
    sysid_py = None
    if not args.no_sysid:
        sysid_py, reason = optimizers.ensure_venv("sysid", BENCH / "requirements-sysid.txt",
                                                  install=not args.no_install)
        if sysid_py is None:
            log(f"mujoco.sysid unavailable: {reason}")
    t0 = time.perf_counter()
    res = {"quick": args.quick, "host": {"python": platform.python_version(), "cpus": os.cpu_count(),
                                         "load_start": round(os.getloadavg()[0], 2)},
           "settings": {"rate_hz": RATE, "encoder_counts": ENCODER_COUNTS, "torque_noise_of_range": TORQUE_NOISE,
                        "logs": LOGS, "seed_offset": args.seed_offset, "runs": {k: list(v) for k, v in RUNS.items()}},
           "sysid": None if sysid_py is not None or args.no_sysid else "unavailable",
           "scenarios": {}}
    with tempfile.TemporaryDirectory(prefix="groundtruth_") as tmp:
        base = args.keep or Path(tmp)
        for name in names:
            folder = base / (name if not args.seed_offset else f"{name}_seeds+{args.seed_offset}")
            res["scenarios"][name] = run_scenario(name, all_scenarios[name], folder, sysid_py, args.seed_offset)
    res["wall_s"] = time.perf_counter() - t0
    res["host"]["load_end"] = round(os.getloadavg()[0], 2)
    res["targets"] = targets(res)
    custom = bool(args.scenarios or args.no_sysid or args.seed_offset)  # not the figures of record
    publish(("groundtruth_quick" if args.quick else "groundtruth") + ("_custom" if custom else ""), report(res), res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
