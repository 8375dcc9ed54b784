"""Drive model: YAML contract, the TX40 transmission and the joint ↔ recorded side conversions."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from frictionid_core.drive import Drive, bundled_drives, drive_from_dict, load_drive
from frictionid_core.errors import InputError
from frictionid_core.files import read_json, write_json
from frictionid_core.timeseries import JointSeries

TX40_N = [32.0, 32.0, 45.0, -48.0, 45.0, 32.0]


def random_series(joints, n=200, seed=0, velocity=True) -> JointSeries:
    rng = np.random.default_rng(seed)
    nj = len(joints)
    return JointSeries(np.arange(n) * 2e-4, list(joints), rng.standard_normal((n, nj)),
                       rng.standard_normal((n, nj)), rng.standard_normal((n, nj)) if velocity else None,
                       source="mem")


# a drive with two couplings (one negative), per-joint effort units and offsets
COUPLED = dict(joints=["a", "b", "c"], side="motor", gear_ratio=[10.0, -20.0, 5.0],
               coupling=[[2, 0, 5.0], [0, 1, -3.0]], effort_scale=[0.1, 2e-3, 7.0],
               position_offset=[0.1, -0.2, 0.3], friction_on="motor", name="coupled")


# ----------------------------------------------------------------------------- TX40
def test_bundled_tx40_matrices():
    d = load_drive("tx40")
    assert "tx40" in bundled_drives()
    assert d.name == "tx40" and d.side == "motor" and d.friction_on == "motor"
    assert list(d.joints) == [f"joint_{k}" for k in range(1, 7)]
    expected_r = np.diag(TX40_N)
    expected_r[5, 4] = 32.0
    np.testing.assert_array_equal(d.R, expected_r)
    np.testing.assert_array_equal(d.N, TX40_N)
    expected_c = np.eye(6)
    expected_c[5, 4] = 1.0  # 32 / 32: motor 6 turns with joints 5 and 6 at one ratio
    np.testing.assert_array_equal(d.C, expected_c)
    assert d.coupled_motors() == [5]
    assert d.motor_names() == [f"motor_{k}" for k in range(1, 7)]
    assert d.effort_scale == (1.0,) * 6 and d.position_offset == (0.0,) * 6


def test_tx40_joint_torques_velocities_and_referred_motor_torques():
    d = load_drive("tx40")
    log = random_series(d.joints, seed=1)  # motor angles, motor velocities, motor torques y
    js = d.to_joint_side(log)
    y, tau = log.effort, js.effort
    # τ = Rᵀ·y: the coupled wrist adds motor 6's torque to joint 5.
    np.testing.assert_allclose(tau[:, 4], 45 * y[:, 4] + 32 * y[:, 5], rtol=1e-15, atol=1e-13)
    np.testing.assert_allclose(tau[:, 5], 32 * y[:, 5], rtol=1e-15)
    np.testing.assert_allclose(tau[:, :4], y[:, :4] * TX40_N[:4], rtol=1e-15)
    # q = R⁻¹·q_m: joint 6 = (q_m6 − 32·q5) / 32.
    q5 = log.position[:, 4] / 45
    np.testing.assert_allclose(js.position[:, 4], q5, rtol=1e-14)
    np.testing.assert_allclose(js.position[:, 5], (log.position[:, 5] - 32 * q5) / 32, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(js.velocity[:, 3], log.velocity[:, 3] / -48, rtol=1e-14)
    # referred motor velocity w = C·q̇: w6 = q̇5 + q̇6 (the referred motor 6 velocity is q̇_m6 / 32).
    w = d.motor_velocity(js.velocity)
    np.testing.assert_allclose(w[:, 5], js.velocity[:, 4] + js.velocity[:, 5], rtol=1e-15)
    np.testing.assert_allclose(w, log.velocity / TX40_N, rtol=1e-12, atol=1e-15)
    # referred motor torque u = C⁻ᵀ·τ = diag(N)·y: u5 = τ5 − τ6, u6 = τ6.
    u = d.referred_motor_torque(tau)
    np.testing.assert_allclose(u[:, 4], tau[:, 4] - tau[:, 5], rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(u[:, 5], tau[:, 5], rtol=1e-15)
    np.testing.assert_allclose(u, y * TX40_N, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(d.joint_torque(u), tau, rtol=1e-12, atol=1e-13)
    # one sample (J,) works as well as a block (N, J)
    np.testing.assert_allclose(d.motor_velocity(js.velocity[7]), w[7])
    assert any("motor-side log to joint side" in n for n in js.notes)


# ------------------------------------------------------------------------ round trips
@pytest.mark.parametrize("side", ["motor", "joint"])
def test_recorded_then_joint_side_is_identity(side):
    d = Drive(**{**COUPLED, "side": side})
    joint_side = random_series(d.joints, seed=2)
    log = d.to_recorded_side(joint_side)
    back = d.to_joint_side(log)
    for field in ("position", "velocity", "effort"):
        np.testing.assert_allclose(getattr(back, field), getattr(joint_side, field), rtol=1e-12, atol=1e-13)
    again = d.to_recorded_side(back)
    for field in ("position", "velocity", "effort"):
        np.testing.assert_allclose(getattr(again, field), getattr(log, field), rtol=1e-12, atol=1e-12)
    assert len(back.notes) == 2 and "joint side to a" in back.notes[0]


def test_recorded_side_values_of_a_coupled_drive():
    d = Drive(**COUPLED)
    q = np.array([[0.5, -1.0, 2.0]])
    js = JointSeries([0.0], list(d.joints), q, [[1.0, 2.0, 3.0]], source="mem")
    log = d.to_recorded_side(js)
    qr = q[0] - COUPLED["position_offset"]
    # q_m = R·(q − offset): motor a = 10·qa − 3·qb, motor c = 5·qa + 5·qc
    np.testing.assert_allclose(log.position[0], [10 * qr[0] - 3 * qr[1], -20 * qr[1], 5 * qr[0] + 5 * qr[2]])
    # τ = Rᵀ·(scale·e) recovers the joint torques
    np.testing.assert_allclose((log.effort * COUPLED["effort_scale"]) @ d.R, js.effort, rtol=1e-14)
    assert log.velocity is None


def test_joint_columns_named_as_the_drive_are_reordered_and_log_names_kept():
    d = Drive(**COUPLED)
    s = random_series(d.joints, seed=3)
    shuffled = s.select(["c", "a", "b"])
    np.testing.assert_array_equal(d.to_joint_side(shuffled).effort, d.to_joint_side(s).effort)
    log_named = JointSeries(s.t, ["J1", "J2", "J3"], s.position, s.effort, s.velocity, source="mem")
    out = d.to_joint_side(log_named)
    assert out.joints == ["J1", "J2", "J3"]
    np.testing.assert_array_equal(out.position, d.to_joint_side(s).position)


@pytest.mark.parametrize("joints, fragment", [(["a", "b"], "coupling term(s) between the joints [('c', 'a')]"),
                                              (["a", "b", "x"], "extra ['x'] (data joints the drive does not list"),
                                              (["a", "b", "x"], "; missing ['c'] (drive joints the data lack)")])
def test_data_joints_that_do_not_fit_the_drive(joints, fragment):
    s = random_series(joints)
    with pytest.raises(InputError) as e:
        Drive(**COUPLED).to_joint_side(s)
    assert "mem" in str(e.value) and fragment in str(e.value)


def test_a_log_of_some_of_the_drives_joints_is_converted_by_those():
    """A drive may describe more joints than the log holds: each joint converted as the whole
    drive converts it, when no coupling links it with a joint the log lacks."""
    d = Drive(**{**COUPLED, "coupling": [[0, 1, -3.0]]})  # a and b coupled, c alone
    whole = d.to_joint_side(random_series(["a", "b", "c"], seed=5))
    part = d.to_joint_side(random_series(["a", "b", "c"], seed=5).select(["c"]))
    assert part.joints == ["c"]
    np.testing.assert_array_equal(part.position[:, 0], whole.position[:, 2])
    np.testing.assert_array_equal(part.effort[:, 0], whole.effort[:, 2])
    pair = d.to_joint_side(random_series(["a", "b", "c"], seed=5).select(["b", "a"]))
    np.testing.assert_allclose(pair.effort, whole.effort[:, :2], rtol=1e-14)
    with pytest.raises(InputError, match=r"^mem: drive 'coupled': coupling term\(s\) between the joints "
                                         r"\[\('a', 'b'\)\]"):
        d.to_joint_side(random_series(["a", "b", "c"], seed=5).select(["a"]))


def test_to_dict_round_trips_through_dict_yaml_and_json(tmp_path):
    d = Drive(**COUPLED)
    assert drive_from_dict(d.to_dict()) == d
    (tmp_path / "coupled.yaml").write_text(yaml.safe_dump(d.to_dict()))
    assert load_drive(tmp_path / "coupled.yaml") == d
    write_json(tmp_path / "r.json", {"drive": d.to_dict()})
    assert drive_from_dict(read_json(tmp_path / "r.json")["drive"]) == d
    tx40 = load_drive("tx40")
    assert drive_from_dict(tx40.to_dict()) == tx40


def test_defaults_and_yaml_number_forms(tmp_path):
    # YAML 1.1 reads 1e-3 (no dot) as a string: accepted as a number.
    (tmp_path / "arm.yaml").write_text("joints: [j1, j2]\neffort_scale: [1e-3, 2.5e-3]\n")
    d = load_drive(tmp_path / "arm.yaml")
    assert d.name == "arm" and d.side == "joint" and d.friction_on == "joint"
    assert d.gear_ratio == (1.0, 1.0) and d.effort_scale == (1e-3, 2.5e-3) and d.coupling == ()
    np.testing.assert_array_equal(d.R, np.eye(2))
    s = random_series(d.joints, seed=4)
    out = d.to_joint_side(s)
    np.testing.assert_array_equal(out.position, s.position)
    np.testing.assert_allclose(out.effort, s.effort * [1e-3, 2.5e-3], rtol=1e-15)


# ----------------------------------------------------------------------------- errors
BASE = "joints: [a, b, c]\n"


@pytest.mark.parametrize("text, fragments", [
    (BASE + "gear_ratios: [1, 2, 3]\n", ["unknown key(s) ['gear_ratios']", "known keys: name, joints"]),
    ("side: motor\n", ["required key(s) ['joints']"]),
    ("joints: []\n", ["key 'joints'", "non-empty list"]),
    ("joints: [a, a]\n", ["key 'joints' repeats ['a']"]),
    (BASE + "gear_ratio: [1, 2]\n", ["key 'gear_ratio' has 2 values for 3 joints"]),
    (BASE + "gear_ratio: 32\n", ["key 'gear_ratio' must be a list of 3 numbers"]),
    (BASE + "gear_ratio: [1, 0, 3]\n", ["key 'gear_ratio'", "joint 'b' is zero"]),
    (BASE + "effort_scale: [1, amps, 3]\n", ["key 'effort_scale'", "'amps' of joint 'b' is not a finite number"]),
    (BASE + "position_offset: [0, .nan, 0]\n", ["key 'position_offset'", "joint 'b'"]),
    (BASE + "coupling: [[3, 0, 1.0]]\n", ["key 'coupling'", "[3, 0, 1.0]", "outside 0…2"]),
    (BASE + "coupling: [[1, 1, 2.0]]\n", ["key 'coupling'", "on the diagonal"]),
    (BASE + "coupling: [[1, 2]]\n", ["key 'coupling'", "not [motor, joint, ratio]"]),
    (BASE + "coupling: [[1.5, 2, 1]]\n", ["key 'coupling'", "integer indices"]),
    (BASE + "coupling: [[1, 2, 0]]\n", ["key 'coupling'", "zero ratio"]),
    (BASE + "coupling: [[1, 2, 1], [1, 2, 3]]\n", ["key 'coupling'", "given twice"]),
    (BASE + "coupling: [[0, 1, 1], [1, 0, 1]]\n", ["'gear_ratio' and 'coupling'", "singular"]),
    (BASE + "side: motors\n", ["key 'side' is 'motors'", "choose one of joint, motor"]),
    (BASE + "friction_on: rotor\n", ["key 'friction_on' is 'rotor'"]),
    ("joints: [a,\n", ["not valid YAML at line"]),
    ("- a\n- b\n", ["not a drive model", "mapping"]),
    # near zero or near singular: refused in one line
    (BASE + "gear_ratio: [1, 1e-4, 3]\n", ["key 'gear_ratio': value of joint 'b' is 0.0001, near zero (below 0.001 in "
                                           "magnitude): motor angle = gear_ratio × joint angle would vanish",
                                           "a negative value is allowed: it reverses the direction"]),
    (BASE + "effort_scale: [1, 1e-12, 3]\n", ["key 'effort_scale': value of joint 'b' is 1e-12, near zero",
                                             "torque = effort_scale × recorded effort would vanish"]),
    (BASE + "coupling: [[1, 2, 1e-12]]\n", ["key 'coupling': term [1, 2, 1e-12] has a zero ratio",
                                            "leave the term out"]),
    # motors 0 and 1 turn with joints 0 and 1 at ratios 1 : 1 and 1 : 0.999999: nearly one motor
    (BASE + "coupling: [[0, 1, 1], [1, 0, 0.999999]]\n", ["keys 'gear_ratio' and 'coupling' give a singular or "
                                                          "near-singular motor←joint matrix (condition number of "
                                                          "diag(gear_ratio)⁻¹·R 4e+06, above 1e+06)"]),
])
def test_drive_yaml_errors_name_file_and_key(tmp_path, text, fragments):
    path = tmp_path / "bad_drive.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as e:
        load_drive(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(path))
    for f in fragments:
        assert f in msg


def test_unknown_drive_name_lists_bundled_drives():
    with pytest.raises(InputError) as e:
        load_drive("tx41")
    assert "tx41: no such drive file" in str(e.value) and "bundled: tx40" in str(e.value)


def test_a_drive_listing_fewer_joints_than_the_log_names_the_extra_ones_and_the_way_out():
    """The log has a joint the drive does not list: the message names it (it said "missing []"), and
    its advice, followed (the log without it), converts the rest."""
    d = Drive(joints=["a", "b"], effort_scale=[2.0, 3.0], name="two")
    s = random_series(["a", "b", "x"])
    with pytest.raises(InputError) as e:
        d.to_joint_side(s)
    assert str(e.value) == ("mem: the data joints ['a', 'b', 'x'] do not match drive 'two' joints ['a', 'b']: extra "
                            "['x'] (data joints the drive does not list: add them to its 'joints' and per-joint lists, "
                            "or leave them out of the data: --joints a,b)")
    out = d.to_joint_side(s.select(["a", "b"]))
    np.testing.assert_array_equal(out.effort, s.effort[:, :2] * [2.0, 3.0])


def test_negative_ratios_and_scales_reverse_a_direction():
    """A negative gear ratio is a motor turning against its joint (the TX40's −48); a negative effort
    scale an effort logged against the joint axis (what the effort-sign check writes)."""
    s = random_series(["a", "b"], seed=7)
    flipped = Drive(joints=["a", "b"], side="motor", gear_ratio=[-2.0, 4.0], effort_scale=[1.0, -1.0]).to_joint_side(s)
    np.testing.assert_allclose(flipped.position, s.position / [-2.0, 4.0], rtol=1e-15)
    np.testing.assert_allclose(flipped.effort, s.effort * [-2.0, -4.0], rtol=1e-15)
