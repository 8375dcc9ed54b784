"""One-joint systems τ = J·q̈ + τ_f(q̇) + offset: one inertia (or mass) parameter.

A one-joint system differs from another only by its parameter's name and bounds and its
pre-processing defaults, so a new one is one :func:`one_joint` entry in :data:`ONE_JOINT`.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import Prepared, Preprocessing
from frictionid_core.systems.system import System


def _inertia_column(p: Prepared, joints: list[str]) -> np.ndarray:
    return p.qdd[:, :1]


def one_joint(name: str, inertia: str, bounds: tuple[float, float], preprocessing: Preprocessing) -> System:
    """The one-joint system ``name`` whose inertia parameter ``inertia`` has search ``bounds``."""
    return System(name, 1, _inertia_column, (inertia,), {inertia: bounds}, preprocessing)


# EMPS (1-DOF prismatic, M in kg): τ = M·q̈ + τ_f(q̇) + offset; protocol of docs/reference.md#emps-idim-ls at 1 kHz.
EMPS = one_joint("emps", "M", (0.0, 500.0), Preprocessing(cutoff_hz=100.0, order=4, decimate=10, trim_start=49))

ONE_JOINT = (EMPS,)
