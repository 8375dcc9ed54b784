"""The friction-only system: the rigid-body torque is already removed from the effort,
τ = τ_f(q̇) + offset, on any number of joints; pre-processing chosen from the data."""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import Prepared, Preprocessing
from frictionid_core.systems.system import System


def _no_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    return np.zeros((p.qd.size, 0))


FRICTION_ONLY = System("friction-only", None, _no_columns, (), {}, Preprocessing())
