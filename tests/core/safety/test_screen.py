"""The one safety screen of parameter sets (frictionid_core.safety): finite values, physical signs,
magnitudes within the robot's limits or the identification data's, each refusal naming the
parameter and the limit; the limits of a URDF, of the built-in TX40 and of the data."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from frictionid_core import FrictionIdError, IdentifyRequest, JointSeries, identify
from frictionid_core.robots import tx40
from frictionid_core.safety import (
    Limit,
    data_limits,
    explicit_bounds,
    result_refusals,
    robot_limits,
    screen_parameters,
)
from frictionid_core.systems import get_system

EMPS = {"emps": Limit(300.0, 0.25, "the data")}


@pytest.mark.parametrize("params, needle", [
    ({"Fc": 1e300}, "parameter 'Fc' = 1e+300 is over the effort limit 300 of 'emps' (the data)"),
    ({"Fv": -1e6}, "parameter 'Fv' = -1e+06 is negative (a physical magnitude, >= 0)"),
    ({"Fc_neg": -0.5}, "parameter 'Fc_neg' = -0.5 is negative"),
    ({"M": -2.0}, "parameter 'M' = -2 is negative"),
    ({"Fs": math.nan}, "parameter 'Fs' = nan is not finite"),
    ({"Fv": math.inf}, "parameter 'Fv' = inf is not finite"),
    ({"Fv": 3000.0}, "parameter 'Fv' = 3000: its torque 750 at the speed 0.25 of 'emps' is over 2 x the effort "
                     "limit 300"),
    ({"offset": -400.0}, "parameter 'offset' = -400 is over the effort limit 300"),
    ({"M": 2e3}, "parameter 'M' = 2000 is over the limit |value| <= 1000"),
])
def test_each_refusal_names_the_parameter_and_the_limit(params, needle):
    good = {"M": 95.0, "Fv": 200.0, "Fc": 20.0, "offset": -3.0}
    refusals = screen_parameters({**good, **params}, EMPS)
    assert len(refusals) == 1 and refusals[0].startswith(needle), refusals


def test_an_accepted_set_and_what_allows_a_negative_value():
    assert screen_parameters({"M": 95.0, "Fv": 200.0, "Fc": 20.0, "offset": -3.0, "MX": -2.5}, EMPS) == []
    # a viscous torque at the speed limit up to twice the effort limit: an extrapolated estimate, accepted
    # an estimate a little below 0, within 3 standard errors: 0 within its uncertainty (an unconstrained fit)
    assert screen_parameters({"joint_5/Fv": -0.03}, {}, std={"joint_5/Fv": 0.02}) == []
    for sigma, more in ((0.005, ", 6 standard errors below 0"), (math.inf, ""), (math.nan, ""), (0.0, "")):
        assert screen_parameters({"joint_5/Fv": -0.03}, {}, std={"joint_5/Fv": sigma}) == [
            f"parameter 'joint_5/Fv' = -0.03 is negative (a physical magnitude, >= 0){more}"], sigma
    wrist = {"joint_6": Limit(30.72, 12.2, "the TX40's")}
    assert screen_parameters({"joint_6/Fv": 2.7}, wrist) == []  # 33 N·m at 12.2 rad/s, 1.07 x 30.72 N·m
    assert screen_parameters({"joint_6/Fv": 5.1}, wrist)[0].endswith("is over 2 x the effort limit 30.72 (the TX40's)")
    # a negative low bound asked for (or a negative value fixed) by the user allows it
    assert screen_parameters({"Fc": -0.5}, EMPS, bounds={"Fc": (-1.0, 1.0)}) == []
    result = {"params": {"Fc": -0.5}, "bounds": {"Fc": [-1.0, 1.0]}, "fixed": {"offset": -2.0}}
    assert explicit_bounds(result) == {"Fc": (-1.0, 1.0), "offset": (-2.0, -2.0)}
    # per joint: prefixed names take their joint's limit; one without takes the default
    two = {"a": Limit(10.0, 1.0, "a's")}
    assert screen_parameters({"a/Fc": 5.0, "b/Fc": 50.0}, two, default=Limit(40.0)) == [
        "parameter 'b/Fc' = 50 is over the effort limit 40 of 'b'"]
    assert screen_parameters({"a/Fc": 11.0}, two) == ["parameter 'a/Fc' = 11 is over the effort limit 10 of 'a' (a's)"]
    # the rotor inertia of a robot is a magnitude; another base parameter may be negative
    assert screen_parameters({"joint_3.Ia": -0.1, "joint_2.mxR": -3.0}, {}) == [
        "parameter 'joint_3.Ia' = -0.1 is negative (a physical magnitude, >= 0)"]


def test_limits_of_a_urdf_the_tx40_table_and_the_data(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text("""<robot name="arm"><link name="base"/><link name="l1"><inertial><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
      <limit effort="12.5" lower="-3" upper="3" velocity="2.5"/></joint></robot>""")
    limit = robot_limits(get_system(f"urdf:{urdf}"))["j1"]
    assert (limit.effort, limit.speed) == (12.5, 2.5) and "arm" in limit.source
    limits = robot_limits(get_system("tx40"))
    assert [limits[j].effort for j in tx40.JOINTS] == list(tx40.EFFORT_LIMIT)
    assert limits["joint_1"].speed == pytest.approx(287.0 * math.pi / 180.0)
    assert robot_limits(get_system("emps")) == {}  # no robot model
    # the data: 2 × the largest |effort| and |velocity| per joint (velocity from the positions if not recorded)
    t = np.arange(1001) * 1e-3
    q = np.column_stack([0.1 * np.sin(2 * np.pi * t), 0.2 * np.sin(2 * np.pi * t)])
    series = JointSeries(t, ["a", "b"], q, np.column_stack([3.0 * np.cos(2 * np.pi * t), np.zeros_like(t)]))
    limits = data_limits(series)
    assert list(limits) == ["a"]  # b has no effort
    assert limits["a"].effort == pytest.approx(6.0) and limits["a"].speed == pytest.approx(4 * np.pi * 0.1, rel=1e-4)
    assert Limit.from_dict(limits["a"].to_dict()) == limits["a"]
    with pytest.raises(FrictionIdError, match="limit: effort must be a finite number > 0"):
        Limit.from_dict({"effort": math.inf})


def test_real_identifications_pass_and_the_export_refuses_an_absurd_set(emps_estimation):
    """An EMPS identification passes the screen with the limits of its own data; a TX40 result
    within its URDF limits passes, one with Fc over joint 1's effort limit is refused by export --yaml."""
    result = identify(emps_estimation, IdentifyRequest(system="emps"))
    assert result_refusals(result, data_limits(emps_estimation)) == []
    rows = {f"{j}/{name}": float(values[k]) for name, values in tx40.FRICTION.items()
            for k, j in enumerate(tx40.JOINTS)}
    good = {"system": "tx40", "friction": "stribeck", "asymmetric": False, "joints": list(tx40.JOINTS), "params": rows}
    assert result_refusals(good) == []
    from frictionid_core.export import yaml_text

    bad = {**good, "params": {**rows, "joint_1/Fc": 500.0}}
    with pytest.raises(FrictionIdError, match=r"parameter 'joint_1/Fc' = 500 is over the effort limit 131.84 of "
                                               r"'joint_1' \(effort and velocity limits of tx40\)"):
        yaml_text(SimpleNamespace(result=bad))
