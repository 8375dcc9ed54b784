"""Independent-joint systems τ_j = J_j·q̈_j + τ_f(q̇_j) + offset_j: one inertia (or mass) per joint,
and with gravity (``joint`` with ``gravity``) τ_j = J_j·q̈_j + τ_f(q̇_j) + g_sin_j·sin q_j + g_cos_j·cos q_j
+ offset_j.

A system of this family differs from another only by its parameter's name and bounds, how
many joints it takes and its pre-processing, so a new one is one :func:`one_joint` entry in
:data:`ONE_JOINT`.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import Prepared, Preprocessing
from frictionid_core.systems.system import System


def _inertia_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    """(J·N, J): q̈_j on the rows of joint j."""
    n, nj = p.qdd.shape
    out = np.zeros((nj * n, nj))
    for j in range(nj):
        out[j * n : (j + 1) * n, j] = p.qdd[:, j]
    return out


def _gravity_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    """(J·N, 3J): q̈_j, sin q_j and cos q_j on the rows of joint j."""
    n, nj = p.qdd.shape
    out = np.zeros((nj * n, 3 * nj))
    for j in range(nj):
        rows = slice(j * n, (j + 1) * n)
        out[rows, 3 * j], out[rows, 3 * j + 1], out[rows, 3 * j + 2] = p.qdd[:, j], np.sin(p.q[:, j]), np.cos(p.q[:, j])
    return out


def one_joint(name: str, inertia: str, bounds: tuple[float, float], preprocessing: Preprocessing,
              joints: int | None = 1) -> System:
    """The system ``name`` of ``joints`` independent joints (None: any number), each with the
    inertia parameter ``inertia`` (search ``bounds``)."""
    return System(name, joints, _inertia_columns, (inertia,), {inertia: bounds}, preprocessing, per_joint=True)


# EMPS (1-DOF prismatic, M in kg): τ = M·q̈ + τ_f(q̇) + offset under the fixed benchmark protocol of
# docs/reference.md#emps-idim-ls at 1 kHz (49 samples trimmed at the start, every row kept, metrics on
# the decimated filtered force), exact to the reference figures.
EMPS_PROTOCOL = Preprocessing(cutoff_hz=100.0, order=4, decimate=10, trim_start_s=0.049, trim_end_s=0.0,
                              min_speed=0.0, metric="filtered")
EMPS = one_joint("emps", "M", (0.0, 500.0), EMPS_PROTOCOL)
# Any joints, each τ = J·q̈ + τ_f(q̇) + offset (J in kg·m², or kg for a prismatic joint); pre-processing
# chosen from the data.
JOINT = one_joint("joint", "J", (0.0, 1e3), Preprocessing(), joints=None)

# ``joint`` with a gravity term per joint (a revolute joint whose axis is not vertical, whatever
# moves with it held still): the load's g·m·r·sin(q + φ) is g_sin·sin q + g_cos·cos q (N·m, any φ).
JOINT_GRAVITY = System("joint", None, _gravity_columns, ("J", "g_sin", "g_cos"),
                       {"J": (0.0, 1e3), "g_sin": (-1e3, 1e3), "g_cos": (-1e3, 1e3)}, Preprocessing(), per_joint=True)

ONE_JOINT = (EMPS, JOINT)
