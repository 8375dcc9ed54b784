"""Inverse dynamic models ("systems"): rigid-body columns and pre-processing presets.

A system turns pre-processed signals into the full-rate rigid-body columns of the
observation matrix and says how its data are pre-processed by default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.observation import Observation, build_observation
from frictionid_core.preprocess import Prepared, Preprocessing, prepare
from frictionid_core.timeseries import JointSeries


@dataclass(frozen=True)
class System:
    """An inverse dynamic model without its friction.

    Attributes:
        name: system id (``emps``, ``friction-only``, …).
        rigid_names: rigid-body parameter names.
        rigid_bounds: default search bounds of those parameters.
        preprocessing: default pre-processing.
        columns: prepared signals + joint names → rigid columns (J·N, R), joint-major rows.
        joints: joint count the system needs (None: any).
        sample_period: the nominal sample period of the system's protocol, s (None: from stamps).
    """

    name: str
    rigid_names: tuple[str, ...]
    rigid_bounds: dict[str, tuple[float, float]]
    preprocessing: Preprocessing
    columns: Callable[[Prepared, list[str]], np.ndarray]
    joints: int | None = None
    sample_period: float | None = None


def _emps_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    return p.qdd[:, :1]


def _no_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    return np.zeros((p.qd.size, 0))


SYSTEMS: dict[str, System] = {
    # EMPS (1-DOF prismatic): τ = M·q̈ + τ_f(q̇) + offset; protocol of SPEC §5.1 at 1 kHz.
    "emps": System("emps", ("M",), {"M": (0.0, 500.0)},
                   Preprocessing(cutoff_hz=100.0, order=4, decimate=10, trim_start=49), _emps_columns,
                   joints=1),
    # Friction only (the rigid-body torque already removed from the effort): τ = τ_f(q̇) + offset.
    "friction-only": System("friction-only", (), {}, Preprocessing(), _no_columns),
}


def get_system(name: str) -> System:
    try:
        return SYSTEMS[name]
    except KeyError:
        raise FrictionIdError(f"unknown system '{name}'; choose one of {', '.join(SYSTEMS)}") from None


def observe(series: JointSeries, system: System, settings: Preprocessing | None = None) -> Observation:
    """Pre-process ``series`` and build the decimated observation of ``system``."""
    if system.joints is not None and len(series.joints) != system.joints:
        raise InputError(
            f"{series.source}: system '{system.name}' models {system.joints} joint(s) but the data has "
            f"{len(series.joints)}: {series.joints}; select with --joints"
        )
    settings = settings or system.preprocessing
    prepared = prepare(series, settings, dt=system.sample_period)
    rigid = system.columns(prepared, series.joints)
    return build_observation(prepared, series.joints, rigid, list(system.rigid_names), settings)
