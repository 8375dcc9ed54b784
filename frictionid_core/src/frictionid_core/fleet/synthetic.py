"""Synthetic fleets for tests, benchmarks and the demo: N robots × M daily logs (MCAP) with chosen drifts.

Each robot has independent joints (the ``joint`` system): τ = J·q̈ + Fv·q̇ + Fc·sign(q̇) + offset, its
own parameters, and one log a day: a new random multi-sine motion, sampled at ``rate_hz`` for
``duration_s``, encoder noise on the position and sensor noise on the effort (``torque_noise`` of the
joint's effort range), and the day's temperature on ``/joint_temperatures`` (``effort`` field, °C).
The true Coulomb level varies from day to day with the temperature (``temperature_coefficient`` per
°C) and by ``day_scatter`` (relative, 1σ), and a drift adds a ramp: +``size`` (relative) reached
``ramp_logs`` logs after its ``start`` log. Broken logs are truncated or garbage files.
The truth (every log's parameters) is written beside the logs as ``truth.json``.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError

DAY_NS = 86_400 * 1_000_000_000
FIRST_DAY_NS = 1_767_254_400 * 1_000_000_000  # 2026-01-01T08:00:00Z
TEMPERATURE_TOPIC = "/joint_temperatures"


@dataclass(frozen=True)
class Drift:
    """A drift of one robot's joint parameter: +``size`` (relative) ramped in over ``ramp_logs`` logs,
    the first raised one being log ``start`` (0-based)."""

    robot: int
    joint: int
    start: int
    size: float = 0.2
    ramp_logs: int = 10
    parameter: str = "Fc"

    def factor(self, log: int) -> float:
        """The parameter's multiplier on ``log``."""
        return 1.0 + self.size * float(np.clip((log - self.start + 1) / self.ramp_logs, 0.0, 1.0))


@dataclass(frozen=True)
class Broken:
    """Log ``log`` of robot ``robot`` is ``kind``: ``truncated`` (its first 40 % of bytes) or ``garbage``."""

    robot: int
    log: int
    kind: str = "truncated"


def _motion(rng: np.random.Generator, t: np.ndarray, joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ (N, joints) of a random sum of 4 sines per joint (0.1–0.6 Hz, 0.1–0.4 rad)."""
    q, qd, qdd = (np.zeros((t.size, joints)) for _ in range(3))
    for j in range(joints):
        for _ in range(4):
            a, w, phase = rng.uniform(0.1, 0.4), 2 * np.pi * rng.uniform(0.1, 0.6), rng.uniform(0, 2 * np.pi)
            q[:, j] += a * np.sin(w * t + phase)
            qd[:, j] += a * w * np.cos(w * t + phase)
            qdd[:, j] -= a * w * w * np.sin(w * t + phase)
    return q, qd, qdd


def synthesize_fleet(out_dir: str | Path, *, robots: int = 4, logs: int = 20, joints: int = 3,
                     drifts: tuple[Drift, ...] = (), broken: tuple[Broken, ...] = (), duration_s: float = 20.0,
                     rate_hz: float = 200.0, torque_noise: float = 0.02, position_noise: float = 1e-4,
                     day_scatter: float = 0.005, temperature_coefficient: float = -0.003, seed: int = 0,
                     baseline_logs: int = 10) -> Path:
    """Write a fleet (module doc) under ``out_dir``: ``<robot>/day_NNN.mcap``, ``truth.json`` and the
    fleet file ``fleet.yaml`` (system joint, Coulomb friction, ls; watching Fc and Fv; the temperature
    as a covariate); returns the fleet file's path."""
    import yaml

    from frictionid_core.files import write_json, write_text
    from frictionid_core.friction import get_model
    from frictionid_core.io import write_joint_state_bag
    from frictionid_core.timeseries import JointSeries

    out = Path(out_dir)
    if out.exists() and any(out.iterdir()):
        raise FrictionIdError(f"{out}: exists and is not empty; choose a new folder for the synthetic fleet")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    names = [f"j{k + 1}" for k in range(joints)]
    coulomb = get_model("coulomb", False)
    t = np.arange(int(round(duration_s * rate_hz))) / rate_hz
    truth: dict = {"robots": {}, "drifts": [d.__dict__ for d in drifts], "broken": [b.__dict__ for b in broken]}
    for r in range(robots):
        robot = f"arm{r + 1:02d}"
        folder = out / robot
        folder.mkdir()
        inertia = rng.uniform(0.05, 1.0, joints)
        fv, fc, offset = rng.uniform(0.5, 4.0, joints), rng.uniform(1.0, 8.0, joints), rng.uniform(-0.5, 0.5, joints)
        truth["robots"][robot] = {"J": inertia.tolist(), "Fv": fv.tolist(), "Fc": fc.tolist(),
                                  "offset": offset.tolist(), "logs": []}
        for day in range(logs):
            day_rng = np.random.default_rng([seed, r, day])
            temperature = 22.0 + 3.0 * day_rng.standard_normal()
            level = fc * (1 + temperature_coefficient * (temperature - 22.0)) * (
                1 + day_scatter * day_rng.standard_normal(joints))
            viscous = fv.copy()
            for d in drifts:
                if d.robot == r:
                    (level if d.parameter == "Fc" else viscous)[d.joint] *= d.factor(day)
            q, qd, qdd = _motion(day_rng, t, joints)
            tau = inertia * qdd + offset + np.column_stack(
                [coulomb.torque(np.array([viscous[j], level[j]]), qd[:, j]) for j in range(joints)])
            effort = tau + day_rng.standard_normal(tau.shape) * torque_noise * np.ptp(tau, axis=0)
            position = q + day_rng.standard_normal(q.shape) * position_noise
            temperatures = temperature + 0.5 * day_rng.standard_normal((t.size, joints)) + np.arange(joints)
            series = JointSeries(t, names, position, effort, source=robot)
            name = f"day_{day + 1:03d}.mcap"
            start_ns = FIRST_DAY_NS + day * DAY_NS + int(day_rng.integers(0, 3600)) * 1_000_000_000
            with tempfile.TemporaryDirectory(dir=out) as tmp:
                bag = write_joint_state_bag(Path(tmp) / "bag", series, t0_ns=start_ns,
                                            extra_topics={TEMPERATURE_TOPIC: ("effort", temperatures)})
                shutil.move(str(next(bag.glob("*.mcap"))), folder / name)
            truth["robots"][robot]["logs"].append({"log": f"{robot}/{name}", "temperature": temperature,
                                                   "Fc": level.tolist(), "Fv": viscous.tolist()})
    for b in broken:
        path = out / f"arm{b.robot + 1:02d}" / f"day_{b.log + 1:03d}.mcap"
        if b.kind == "truncated":
            path.write_bytes(path.read_bytes()[: int(0.4 * path.stat().st_size)])
        elif b.kind == "garbage":
            path.write_bytes(np.random.default_rng([seed, b.robot, b.log, 7]).bytes(4096))
        else:
            raise FrictionIdError(f"broken log kind '{b.kind}': choose truncated or garbage")
    write_json(out / "truth.json", truth)
    fleet = {"defaults": {"system": "joint", "friction": "coulomb", "solver": "ls", "topic": "/joint_states",
                          "covariates": {"temperature": {"topic": TEMPERATURE_TOPIC, "field": "effort"}}},
             "robots": [{"name": f"arm{r + 1:02d}", "logs": f"arm{r + 1:02d}/*.mcap", "joints": list(names)}
                        for r in range(robots)],
             "baseline_logs": baseline_logs,
             "alarm": {"parameters": ["Fc", "Fv"], "false_alarm_rate": 0.001}}
    return write_text(out / "fleet.yaml", yaml.safe_dump(fleet, sort_keys=False))
