"""Shared fixtures: the EMPS bags (read once per session) and factories of small synthetic data
(:mod:`support.data`)."""

from __future__ import annotations

import pytest

from support.data import EMPS_ESTIMATION, EMPS_VALIDATION, emps_like, joint_state_msgs, write_ros2_bag


# --------------------------------------------------------------------------- EMPS bags
@pytest.fixture(scope="session")
def emps_estimation():
    """The EMPS estimation run, loaded once from its MCAP bag."""
    from frictionid_core.io import load

    return load(EMPS_ESTIMATION)


@pytest.fixture(scope="session")
def emps_validation():
    """The EMPS validation run, loaded once from its MCAP bag."""
    from frictionid_core.io import load

    return load(EMPS_VALIDATION)


@pytest.fixture
def synthetic():
    """Factory of noise-free EMPS-like series (see :func:`emps_like`)."""
    return emps_like


@pytest.fixture
def ros2_bag():
    """The :func:`write_ros2_bag` helper."""
    return write_ros2_bag


@pytest.fixture
def js_msgs():
    """The :func:`joint_state_msgs` helper."""
    return joint_state_msgs
