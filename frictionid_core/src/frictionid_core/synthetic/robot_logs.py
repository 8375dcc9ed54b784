"""Synthetic joint-state data of a robot following a trajectory.

τ = rnea(q, q̇, q̈) (Pinocchio, rigid bodies + armature Ia·q̈) + τ_f(q̇) + offset + noise (a joint's
``Fc_load`` in its friction parameters adds Fc_load·|rnea|·sign(q̇): load-dependent Coulomb friction),
sampled at ``rate`` Hz; the recorded position is q + noise. The ground truth (standard and
base parameters, friction, offsets, noise, the thesis joint-2 equivalents for the TX40) is
returned beside the data so identification results can be compared with it.

With a drive (:mod:`frictionid_core.drive.transmission`) the data are what that drive logs (motor angles,
efforts in its units: :meth:`~frictionid_core.drive.transmission.Drive.to_recorded_side` of the noisy joint
side). With its friction on the motors, friction acts per motor on w = C·q̇ and the rotor
inertias (the model's armature, one per motor) on ẇ = C·q̈:
τ = rnea_bodies + Cᵀ·(Ia ⊙ C·q̈) + Cᵀ·f(C·q̇) + offset.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.excitation import check_trajectory
from frictionid_core.files import read_json
from frictionid_core.friction import FRICTIONS, elements_of, get_model
from frictionid_core.model import LOAD_NAME
from frictionid_core.robots import MotorSide, base_parameter_names, robot_base_parameters, tx40
from frictionid_core.timeseries import JointSeries

DEFAULT_POSITION_NOISE = 1e-6  # rad, robots without a noise table (≈ 0.057e-3 deg)
DEFAULT_TORQUE_NOISE = 0.05  # N·m (docs/reference.md#tx40)


def friction_torques(friction: str, asymmetric: bool, params: dict[str, dict[str, float]], joints: list[str],
                     qd: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
    """τ_f for velocities (N, J) of ``joints`` with per-joint parameters {joint: {name: value}};
    a dynamic law's states integrated along the sample times ``t`` (N,) (s)."""
    model = get_model(friction, asymmetric, elements_of(friction, next(iter(params.values()), {})))
    out = np.empty_like(qd)
    for k, j in enumerate(joints):
        if j not in params:
            raise InputError(f"friction parameters missing for joint '{j}' (given: {sorted(params)})")
        missing = [n for n in model.names if n not in params[j]]
        if missing:
            raise InputError(f"friction parameters of joint '{j}' lack {missing} for {model.label} "
                             f"({list(model.names)})")
        out[:, k] = model.torque(np.array([params[j][n] for n in model.names]), qd[:, k],
                                 t=t if model.is_dynamic else None)
    return out


def synthesize(robot, trajectory, *, friction: str = "stribeck", asymmetric: bool = False,
               friction_params: dict[str, dict[str, float]] | None = None, offsets: dict[str, float] | None = None,
               position_noise: float | np.ndarray | None = None, torque_noise: float = DEFAULT_TORQUE_NOISE,
               rate: float = 1000.0, seed: int = 0, names: dict[str, str] | None = None,
               source: str = "synthetic", drive=None) -> tuple[JointSeries, dict]:
    """Data of ``robot`` following ``trajectory`` (see the module doc) and its ground truth.

    Args:
        friction: the friction law; asymmetric: separate v > 0 and v < 0 parameters.
        friction_params: {model joint: {param: value}}, or {motor: …} (``motor_<k>``) under a
            drive with friction on the motors (default: the published values for the TX40,
            motor k taking joint k's).
        offsets: {model joint: N·m} constant joint torque offsets (default 0).
        position_noise: 1σ per joint (scalar or (nv,)), rad (default: the published TX40 noise, else 1e−6).
        names: {model joint: name written in the data} (default: model names).
        drive: a Drive whose joints are the robot's: the data are its log (module doc).
    """
    if friction not in FRICTIONS:
        raise FrictionIdError(f"unknown friction model '{friction}'; choose one of {', '.join(FRICTIONS)}")
    check_trajectory(robot, trajectory, rate)
    motors = _motor_side(robot, drive)
    if friction_params is None:
        if robot.name != "tx40":
            raise InputError(f"no default friction for {robot.name}: give per-joint friction parameters")
        friction_params = tx40.published_friction(friction, asymmetric)
        if motors is not None:
            friction_params = {m: friction_params[j] for m, j in zip(motors.motors, robot.joints)}
    if position_noise is None:
        if robot.name == "tx40":
            position_noise = np.array(tx40.POSITION_NOISE)
        else:
            position_noise = DEFAULT_POSITION_NOISE
    sigma_q = np.broadcast_to(np.asarray(position_noise, dtype=float), (robot.nv,)).copy()
    bad = [j for j in (offsets or {}) if j not in robot.joints]
    if bad:
        raise InputError(f"offsets for joint(s) {bad} not in {robot.name} {robot.joints}")
    offsets = {j: float((offsets or {}).get(j, 0.0)) for j in robot.joints}
    t, q, qd, qdd = trajectory.sample(rate)
    order = [trajectory.joints.index(j) for j in robot.joints]
    q, qd, qdd = q[:, order], qd[:, order], qdd[:, order]
    tau = robot.inverse_dynamics(q, qd, qdd)
    load = np.array([float(friction_params.get(j, {}).get(LOAD_NAME, 0.0)) for j in robot.joints])
    if load.any() and motors is not None:
        raise InputError(f"{LOAD_NAME}: load-dependent friction is synthesised on the joints, not under a drive with "
                         "friction on the motors")
    tau += load * np.abs(tau) * np.sign(qd)  # Fc + Fc_load·|τ_rigid| (frictionid_core.model.load_dependence)
    if motors is None:
        tau += friction_torques(friction, asymmetric, friction_params, robot.joints, qd, t)
    else:  # rotor inertias and friction on the motors: τ = Cᵀ·(Ia ⊙ ẇ + f(w))
        tau += motors.rotor_torques(qdd, robot.armature) - qdd * robot.armature
        tau += friction_torques(friction, asymmetric, friction_params, motors.motors, qd @ motors.C.T, t) @ motors.C
    tau += np.array([offsets[j] for j in robot.joints])
    rng = np.random.default_rng(seed)
    position = q + rng.standard_normal(q.shape) * sigma_q
    effort = tau + rng.standard_normal(tau.shape) * torque_noise
    data_names = [(names or {}).get(j, j) for j in robot.joints]
    series = JointSeries(t, list(robot.joints), position, effort, source=source)
    if drive is not None:
        series = drive.to_recorded_side(series)  # in the drive's joint order
    rename = dict(zip(robot.joints, data_names))
    series.joints = [rename[j] for j in series.joints]
    truth = ground_truth(robot, friction, asymmetric, friction_params, offsets, sigma_q, torque_noise, rate, seed,
                         trajectory, data_names, motors)
    if drive is not None:
        truth["drive"] = drive.to_dict()
    return series, truth


def _motor_side(robot, drive):
    """The robot's motor rows under ``drive`` when its friction acts on the motors, else None."""
    if drive is None:
        return None
    if sorted(drive.joints) != sorted(robot.joints):
        raise InputError(f"drive '{drive.name}' joints {list(drive.joints)} are not the joints of {robot.name} "
                         f"{robot.joints}")
    if drive.friction_on != "motor":
        return None
    return MotorSide(robot, drive)


def ground_truth(robot, friction, asymmetric, friction_params, offsets, sigma_q, torque_noise, rate, seed,
                 trajectory, data_names, motors=None) -> dict:
    """The JSON-ready ground truth of a synthetic recording (``motors``: its MotorSide when
    friction and rotor inertias act on the motors: ``friction`` then holds each motor's, the
    standard and base parameters are those of the motor rows, ``motor_offsets`` = C⁻ᵀ·offsets)."""
    rows = motors or robot
    base = robot_base_parameters(robot, rows=motors)
    owners = motors.motors if motors is not None else robot.joints
    model = get_model(friction, asymmetric)
    truth = {
        "robot": robot.name,
        "model_source": robot.source,
        "joints": list(robot.joints),
        "data_joint_names": list(data_names),
        "rate_hz": rate,
        "seed": seed,
        "friction": {"kind": friction, "asymmetric": asymmetric,  # "kind": the truth files' format
                     "params": {j: {n: float(friction_params[j][n]) for n in model.names} for j in owners}},
        "offsets": offsets,
        "noise": {"position_rad": dict(zip(robot.joints, map(float, sigma_q))), "torque": float(torque_noise)},
        "standard_parameters": dict(zip(rows.parameter_names(), map(float, robot.parameters()))),
        "base_parameters": dict(zip(base_parameter_names(base), map(float, base.from_standard(robot.parameters())))),
        "base_combinations": dict(zip(base_parameter_names(base), base.describe().values())),
        "limits": robot.limits_table(),
    }
    if motors is not None:
        truth["friction"]["on"] = "motor"
        u = np.array([offsets[j] for j in robot.joints]) @ np.linalg.inv(motors.C)
        truth["motor_offsets"] = dict(zip(motors.motors, map(float, u)))
    moving = [j for j, moves in zip(trajectory.joints, trajectory.moves()) if moves]
    truth["moving_joints"] = moving
    if robot.name == "tx40":
        truth["assumptions"] = list(tx40.ASSUMPTIONS) + (
            ["asymmetric friction: v < 0 branch 0.85·(Fv, Fc, Fs) of SPEC"] if asymmetric else [])
        if moving == ["joint_2"]:
            t, q, _, _ = trajectory.sample(rate)
            hold = q[0, [trajectory.joints.index(j) for j in robot.joints]]
            eff = tx40.joint2_effective_parameters(robot, hold)
            truth["joint2_thesis_model"] = {
                "ZZ": eff["ZZ"], "MX": eff["MX"], "MY": eff["MY"],
                "note": "only joint 2 moves, the others are held: τ₂ = ZZ·q̈ − g·MX·cos θ + g·MY·sin θ "
                        "exactly, θ = q₂ − π/2; ZZ = M₂₂ (links 2…6 + rotor), MX, MY from the Pinocchio "
                        "gravity torque",
                "hold": dict(zip(robot.joints, map(float, hold))),
            }
    return truth


def expected_parameters(truth: dict, system: str, joints: list[str] | None = None) -> dict[str, float]:
    """The truth under the parameter names an identification of ``system`` reports.

    ``system``: ``tx40-j2`` (one joint: ZZ, MX, MY, friction, offset) or a robot system
    (base parameters, ``<joint>/<friction>``, ``<joint>/offset``; data joint names; with friction
    on the motors ``motor_<k>/<friction>`` and ``motor_<k>/offset``)."""
    _, _, friction_params = truth_friction(truth)
    data = dict(zip(truth["joints"], truth["data_joint_names"]))
    out: dict[str, float] = {}
    if system == "tx40-j2":
        if "joint2_thesis_model" not in truth:
            raise FrictionIdError("the truth has no thesis joint-2 equivalents (joint 2 was not the only joint moving)")
        j2 = truth["joint2_thesis_model"]
        out.update(ZZ=j2["ZZ"], MX=j2["MX"], MY=j2["MY"])
        out.update(friction_params["joint_2"])
        out["offset"] = truth["offsets"]["joint_2"]
        return out
    out.update(truth["base_parameters"])
    if "motor_offsets" in truth:  # friction and offsets per motor
        for m, value in truth["motor_offsets"].items():
            out.update({f"{m}/{n}": v for n, v in friction_params[m].items()})
            out[f"{m}/offset"] = value
        return out
    for j in joints or truth["joints"]:
        model_j = {v: k for k, v in data.items()}.get(j, j)
        out.update({f"{j}/{n}": v for n, v in friction_params[model_j].items()})
        out[f"{j}/offset"] = truth["offsets"][model_j]
    return out



def truth_friction(truth: dict) -> tuple[str | None, bool | None, dict[str, dict[str, float]]]:
    """(friction law, asymmetric, {joint: {parameter: value}}) of a ground truth, of its
    ``friction`` block or of bare per-joint parameters (law and asymmetry then None)."""
    block = truth["friction"] if isinstance(truth.get("friction"), dict) else truth
    if "params" in block:
        return block.get("kind"), block.get("asymmetric"), block["params"]
    return None, None, block


def read_friction_params(path: str | Path) -> tuple[dict, str | None, bool | None]:
    """Per-joint friction parameters from JSON ``{joint: {Fv: …, Fc: …}}``, a ``friction`` block
    ``{"kind", "asymmetric", "params"}`` or a truth file: (params, law or None, asymmetric or None)."""
    friction, asymmetric, params = truth_friction(read_json(path, "friction parameters"))
    if not isinstance(params, dict) or not all(isinstance(v, dict) for v in params.values()):
        raise InputError(f"{path}: expected friction parameters {{joint: {{parameter: value}}}}, got {params!r:.100}")
    bad = [f"{joint}.{name} = {v!r}" for joint, values in params.items() for name, v in values.items()
           if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)]
    if bad:
        raise InputError(f"{path}: friction parameter(s) {', '.join(bad)} are not finite numbers")
    return params, friction, asymmetric
