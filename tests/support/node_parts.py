"""The node's ROS-free parts fed by hand: a configuration, a two-joint motion (joints a, b with
Coulomb + viscous friction) fed into the input buffers as real JointState messages, and a window."""

from __future__ import annotations

import logging
import warnings
from pathlib import Path

import numpy as np

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from builtin_interfaces.msg import Time
    from frictionid_interfaces.srv import Identify
    from sensor_msgs.msg import JointState

from frictionid_ros.identification import IdentifyService, parse_request, window_series
from frictionid_ros.inputs import Inputs
from frictionid_ros.parameters import PARAMETERS, make_config
from frictionid_ros.store import ActiveParameters

NS = 1_000_000_000


T0 = 1_700_000_000 * NS  # first stamp [ns]
PERIOD = 1_000_000  # 1 kHz [ns]
LOG = logging.getLogger(__name__)
ROOT = Path(__file__).resolve().parents[2]


FV, FC = np.array([2.0, 1.0]), np.array([0.5, 0.3])  # joints a, b


def node_config(tmp_path, **changes):
    values = {name: p.default for name, p in PARAMETERS.items()}
    values.update({"joints": ["a", "b"], "system": "friction-only", "results_file": str(tmp_path / "p.json"),
                   **changes})
    return make_config(values)


def stamp_time(ns: int) -> Time:
    return Time(sec=ns // NS, nanosec=ns % NS)


def motion(n: int):
    """Stamps [ns], positions, velocities and Coulomb + viscous torques of joints a, b (n, 2)."""
    t = np.arange(n) * 1e-3
    w = 2 * np.pi * np.array([0.8, 1.1])
    q = 0.3 * np.sin(np.outer(t, w))
    v = 0.3 * w * np.cos(np.outer(t, w))
    return T0 + np.arange(n) * PERIOD, q, v, FV * v + FC * np.sign(v)


def feed(inputs: Inputs, n: int = 1000, skip=(), effort: bool = True, names=("b", "a")):
    """Joint states of _motion (names in another order than the node's joints), stamp k skipped for k in skip."""
    stamps, q, _, tau = motion(n)
    col = [["a", "b"].index(j) for j in names]
    for k in range(n):
        if k in skip:
            continue
        m = JointState(name=list(names), position=q[k, col].tolist(), effort=tau[k, col].tolist() if effort else [])
        m.header.stamp = stamp_time(int(stamps[k]))
        inputs.joint_state(m, int(stamps[k]))
    return stamps, q, tau


def make_inputs(cfg) -> Inputs:
    inputs = Inputs(lambda: cfg, warn=lambda text: None)
    inputs.setup(list(cfg.joints))
    return inputs


def select_window(cfg, inputs, **request):
    job = parse_request(Identify.Request(**request), cfg, inputs.joints)
    return window_series(job, cfg, inputs.ring, "/joint_states", inputs.effort_ring, "/effort")


def service_with_parameters(tmp_path, **changes):
    """An IdentifyService (worker thread) on 1 s of data that identified once, and its active parameters."""
    cfg = node_config(tmp_path, identification_worker="thread", max_budget=100_000, **changes)
    inputs = make_inputs(cfg)
    feed(inputs)
    active = ActiveParameters(cfg.results_file, lambda r: None, log=LOG)
    service = IdentifyService(lambda: cfg, inputs, active, {"joint_states": "/joint_states"}, None, log=LOG)
    assert service.handle(Identify.Request()).ok
    return service, active


# An identification of minutes on any machine: for cancel and the wall-time limit.
HUGE = dict(friction_model="tustin", solver="de", population=200, budget=100_000)


def identification_dict(joints, params):
    """A hand-written identification result (the JSON of ``frictionid identify``) of ``params``."""
    return {"system": "friction-only", "friction": "coulomb", "asymmetric": False, "solver": "ls", "source": "x",
            "joints": joints, "params": params, "std": dict.fromkeys(params, 0.1),
            "metrics": {"relerr_pct": 1.0, "r2": 0.99, "samples": 200}, "wall_s": 0.01}
