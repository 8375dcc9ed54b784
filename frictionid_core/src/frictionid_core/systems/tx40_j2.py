"""TX40 joint 2 alone, the thesis model (§5.2, docs/reference.md#inverse-dynamic-models):

    τ = ZZ·q̈ + τ_grav(q) + τ_f(q̇) + offset,   τ_grav = −g·MX·cos θ + g·MY·sin θ

with the DH angle θ = q − π/2 (q = 0: arm upright), ZZ in kg·m², MX, MY in kg·m. Pre-processing
chosen from the data, as the robot systems (:mod:`frictionid_core.systems.robot`).
"""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import Prepared
from frictionid_core.robots import tx40
from frictionid_core.systems.robot import ROBOT_PREPROCESSING
from frictionid_core.systems.system import System


def _columns(p: Prepared, joints: list[str]) -> np.ndarray:
    # The thesis formula is written in the DH angle θ₂ = q₂ + θoffset₂.
    return tx40.joint2_columns(p.q[:, 0] + tx40.DH[1][3], p.qdd[:, 0])


TX40_J2 = System("tx40-j2", 1, _columns, ("ZZ", "MX", "MY"),
                 {"ZZ": (0.0, 5.0), "MX": (-10.0, 10.0), "MY": (-10.0, 10.0)},
                 ROBOT_PREPROCESSING)
