"""TX40 joint 2 alone, the thesis model (§5.2, docs/reference.md#inverse-dynamic-models):

    τ = ZZ·q̈ + τ_grav(q) + τ_f(q̇) + offset,   τ_grav = −g·MX·cos θ + g·MY·sin θ

with the DH angle θ = q − π/2 (q = 0: arm upright), ZZ in kg·m², MX, MY in kg·m. Pre-processing
and slow-row exclusion as the robot systems (:mod:`frictionid_core.systems.robot`), except a
decimation by 2 (joint-2 reversals are slow; it halves the rows of the thesis' searches).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from frictionid_core.preprocess import Prepared
from frictionid_core.robots.tx40 import DH, joint2_columns
from frictionid_core.systems.robot import ROBOT_MIN_SPEED, ROBOT_PREPROCESSING
from frictionid_core.systems.system import System


def _columns(p: Prepared, joints: list[str]) -> np.ndarray:
    # The thesis formula is written in the DH angle θ₂ = q₂ + θoffset₂.
    return joint2_columns(p.q[:, 0] + DH[1][3], p.qdd[:, 0])


TX40_J2 = System("tx40-j2", 1, _columns, ("ZZ", "MX", "MY"),
                 {"ZZ": (0.0, 5.0), "MX": (-10.0, 10.0), "MY": (-10.0, 10.0)},
                 replace(ROBOT_PREPROCESSING, decimate=2), min_speed=ROBOT_MIN_SPEED)
