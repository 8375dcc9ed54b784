"""Synthetic joint-state data of a robot following a trajectory.

τ = rnea(q, q̇, q̈) (Pinocchio, rigid bodies + armature Ia·q̈) + τ_f(q̇) + offset + noise,
sampled at ``rate`` Hz; the recorded position is q + noise. The ground truth (standard and
base parameters, friction, offsets, noise, the thesis joint-2 equivalents for the TX40) is
returned beside the data so identification results can be compared with it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.friction import FRICTIONS, get_model
from frictionid_core.timeseries import JointSeries

DEFAULT_POSITION_NOISE = 1e-6  # rad, robots without a noise table (≈ 0.057e-3 deg)
DEFAULT_TORQUE_NOISE = 0.05  # N·m (SPEC §6)


def tx40_friction(friction: str, asymmetric: bool) -> dict[str, dict[str, float]]:
    """SPEC friction of the TX40 for the law ``friction`` (asymmetric: the v < 0 branch has 0.85·Fv,
    0.85·Fc, 0.85·Fs and the same vs, δ — an assumption, SPEC is symmetric)."""
    from frictionid_core.robots.tx40 import FRICTION, JOINTS

    if friction == "threlfall":
        raise FrictionIdError("SPEC gives no Threlfall parameters for the TX40; pass --friction-params")
    names = get_model(friction, False).names
    out = {}
    for k, j in enumerate(JOINTS):
        sym = {n: float(FRICTION[n][k]) for n in names}
        if not asymmetric:
            out[j] = sym
        else:
            neg = {n: (0.85 * v if n in ("Fv", "Fc", "Fs") else v) for n, v in sym.items()}
            out[j] = {**{f"{n}_pos": v for n, v in sym.items()}, **{f"{n}_neg": v for n, v in neg.items()}}
    return out


def friction_torques(friction: str, asymmetric: bool, params: dict[str, dict[str, float]], joints: list[str],
                     qd: np.ndarray) -> np.ndarray:
    """τ_f for velocities (N, J) of ``joints`` with per-joint parameters {joint: {name: value}}."""
    model = get_model(friction, asymmetric)
    out = np.empty_like(qd)
    for k, j in enumerate(joints):
        if j not in params:
            raise InputError(f"friction parameters missing for joint '{j}' (given: {sorted(params)})")
        missing = [n for n in model.names if n not in params[j]]
        if missing:
            raise InputError(f"friction parameters of joint '{j}' lack {missing} for {model.label} "
                             f"({list(model.names)})")
        out[:, k] = model.torque(np.array([params[j][n] for n in model.names]), qd[:, k])
    return out


def synthesize(robot, trajectory, *, friction: str = "stribeck", asymmetric: bool = False,
               friction_params: dict[str, dict[str, float]] | None = None, offsets: dict[str, float] | None = None,
               position_noise: float | np.ndarray | None = None, torque_noise: float = DEFAULT_TORQUE_NOISE,
               rate: float = 1000.0, seed: int = 0, names: dict[str, str] | None = None,
               source: str = "synthetic") -> tuple[JointSeries, dict]:
    """Data of ``robot`` following ``trajectory`` (see the module doc) and its ground truth.

    Args:
        friction: the friction law; asymmetric: separate v > 0 and v < 0 parameters.
        friction_params: {model joint: {param: value}} (default: SPEC values for the TX40).
        offsets: {model joint: N·m} constant torque offsets (default 0).
        position_noise: 1σ per joint (scalar or (nv,)), rad (default: SPEC for the TX40, else 1e−6).
        names: {model joint: name written in the data} (default: model names).
    """
    from frictionid_core.robots.excitation import check_trajectory

    if friction not in FRICTIONS:
        raise FrictionIdError(f"unknown friction model '{friction}'; choose one of {', '.join(FRICTIONS)}")
    check_trajectory(robot, trajectory, rate)
    if friction_params is None:
        if robot.name != "tx40":
            raise InputError(f"no default friction for {robot.name}: give per-joint friction parameters")
        friction_params = tx40_friction(friction, asymmetric)
    if position_noise is None:
        if robot.name == "tx40":
            from frictionid_core.robots.tx40 import POSITION_NOISE

            position_noise = np.array(POSITION_NOISE)
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
    tau += friction_torques(friction, asymmetric, friction_params, robot.joints, qd)
    tau += np.array([offsets[j] for j in robot.joints])
    rng = np.random.default_rng(seed)
    position = q + rng.standard_normal(q.shape) * sigma_q
    effort = tau + rng.standard_normal(tau.shape) * torque_noise
    data_names = [(names or {}).get(j, j) for j in robot.joints]
    series = JointSeries(t, data_names, position, effort, source=source)
    truth = ground_truth(robot, friction, asymmetric, friction_params, offsets, sigma_q, torque_noise, rate, seed,
                         trajectory, data_names)
    return series, truth


def ground_truth(robot, friction, asymmetric, friction_params, offsets, sigma_q, torque_noise, rate, seed,
                 trajectory, data_names) -> dict:
    """The JSON-ready ground truth of a synthetic recording."""
    from frictionid_core.robots.base import base_parameter_names, robot_base_parameters

    base = robot_base_parameters(robot)
    model = get_model(friction, asymmetric)
    truth = {
        "robot": robot.name,
        "model_source": robot.source,
        "joints": list(robot.joints),
        "data_joint_names": list(data_names),
        "rate_hz": rate,
        "seed": seed,
        "friction": {"kind": friction, "asymmetric": asymmetric,  # "kind": the truth files' format
                     "params": {j: {n: float(friction_params[j][n]) for n in model.names} for j in robot.joints}},
        "offsets": offsets,
        "noise": {"position_rad": dict(zip(robot.joints, map(float, sigma_q))), "torque": float(torque_noise)},
        "standard_parameters": dict(zip(robot.parameter_names(), map(float, robot.parameters()))),
        "base_parameters": dict(zip(base_parameter_names(base), map(float, base.from_standard(robot.parameters())))),
        "base_combinations": dict(zip(base_parameter_names(base), base.describe().values())),
        "limits": robot.limits_table(),
    }
    moving = [j for j, moves in zip(trajectory.joints, trajectory.moves()) if moves]
    truth["moving_joints"] = moving
    if robot.name == "tx40":
        from frictionid_core.robots.tx40 import ASSUMPTIONS, joint2_effective_parameters

        truth["assumptions"] = list(ASSUMPTIONS) + (
            ["asymmetric friction: v < 0 branch 0.85·(Fv, Fc, Fs) of SPEC"] if asymmetric else [])
        if moving == ["joint_2"]:
            t, q, _, _ = trajectory.sample(rate)
            hold = q[0, [trajectory.joints.index(j) for j in robot.joints]]
            eff = joint2_effective_parameters(robot, hold)
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
    (base parameters, ``<joint>/<friction>``, ``<joint>/offset``; data joint names)."""
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


# --------------------------------------------------------------------- CLI
def _read_friction(path: Path) -> tuple[dict, str | None, bool | None]:
    try:
        d = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: cannot read friction parameters ({exc})") from None
    friction, asymmetric, params = truth_friction(d)
    return params, friction, asymmetric


def _parse_values(text: str | None, n: int, what: str) -> np.ndarray | None:
    if text is None:
        return None
    try:
        vals = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise FrictionIdError(f"{what} '{text}': expected a number or {n} comma-separated numbers") from None
    if len(vals) not in (1, n):
        raise FrictionIdError(f"{what}: expected 1 or {n} values, got {len(vals)}")
    return np.array(vals)


def register(subparsers):
    """Add ``synth``: trajectory → synthetic JointState bag (+ ground-truth JSON).

        frictionid synth TRAJ --system tx40 --out BAG [--friction stribeck] [--asymmetric]
                         [--friction-params F.json] [--offsets J=V,…] [--position-noise RAD[,…]]
                         [--torque-noise 0.05] [--rate 1000] [--seed 0] [--truth T.json] [--names A,B,…]
    """
    p = subparsers.add_parser("synth",
                              help="synthesise a JointState bag from a trajectory (Pinocchio + friction + noise)")
    p.add_argument("trajectory", type=Path,
                   help="trajectory from 'frictionid excite' (.npz) or CSV (t, q:<joint>, …)")
    p.add_argument("--system", required=True, help="robot: tx40 | tx40-j2 (the TX40) | urdf:PATH")
    p.add_argument("--out", type=Path, required=True, help="bag directory to create (MCAP)")
    p.add_argument("--friction", default="stribeck", choices=FRICTIONS, help="friction law (default stribeck)")
    p.add_argument("--asymmetric", action="store_true", help="asymmetric friction (v > 0 and v < 0 parameters)")
    p.add_argument("--friction-params", type=Path,
                   help="JSON {joint: {Fv: …, Fc: …}} or a truth file (default for the TX40: SPEC §6)")
    p.add_argument("--offsets", help="constant torque offsets JOINT=N·m,… (default 0)")
    p.add_argument("--position-noise",
                   help="1σ position noise, rad: one value or one per joint (default: SPEC for the TX40, else 1e-6)")
    p.add_argument("--torque-noise", type=float, default=DEFAULT_TORQUE_NOISE,
                   help="1σ torque noise, N·m (default 0.05)")
    p.add_argument("--rate", type=float, default=1000.0, help="sample rate, Hz (default 1000)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--names",
                   help="joint names written in the bag, comma-separated in model order (default: model names)")
    p.add_argument("--truth", type=Path, help="write the ground truth as JSON here")
    return _cmd_synth


def _cmd_synth(args) -> int:
    from frictionid_core.io.bag import write_joint_state_bag
    from frictionid_core.robots.excitation import load_trajectory, robot_of
    from frictionid_core.systems import get_system

    robot, _ = robot_of(get_system(args.system), args.system)
    traj = load_trajectory(args.trajectory)
    params, kind, asym = (None, None, None)
    if args.friction_params is not None:
        params, kind, asym = _read_friction(args.friction_params)
        if kind is not None and (kind != args.friction or bool(asym) != args.asymmetric):
            raise FrictionIdError(f"{args.friction_params} holds {kind}{' (asymmetric)' if asym else ''} parameters; "
                                  f"pass --friction {kind}{' --asymmetric' if asym else ''}")
    offsets = {}
    for item in filter(None, (s.strip() for s in (args.offsets or "").split(","))):
        j, _, v = item.partition("=")
        try:
            offsets[j.strip()] = float(v)
        except ValueError:
            raise FrictionIdError(f"--offsets item '{item}': expected JOINT=VALUE") from None
    bad = [j for j in offsets if j not in robot.joints]
    if bad:
        raise InputError(f"--offsets: joint(s) {bad} not in {robot.name} {robot.joints}")
    names = None
    if args.names:
        given = [n.strip() for n in args.names.split(",")]
        if len(given) != robot.nv:
            raise FrictionIdError(f"--names: {robot.nv} names needed (model order {robot.joints}), got {len(given)}")
        names = dict(zip(robot.joints, given))
    series, truth = synthesize(robot, traj, friction=args.friction, asymmetric=args.asymmetric, friction_params=params,
                               offsets=offsets, position_noise=_parse_values(args.position_noise, robot.nv,
                                                                             "--position-noise"),
                               torque_noise=args.torque_noise, rate=args.rate, seed=args.seed, names=names,
                               source=str(args.out))
    truth["trajectory_file"] = str(args.trajectory)
    write_joint_state_bag(args.out, series)
    if args.truth is not None:
        args.truth.write_text(json.dumps(truth, indent=2) + "\n")
    print(f"{args.out}: {len(series)} samples × {len(series.joints)} joints of {robot.name} at {args.rate:g} Hz, "
          f"{args.friction}{' (asymmetric)' if args.asymmetric else ''} friction"
          + (f"; truth in {args.truth}" if args.truth else ""))
    return 0
