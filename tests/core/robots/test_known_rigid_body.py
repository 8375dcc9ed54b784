"""A robot's rigid body known (``--known-rigid-body``: the links held, rotor inertias, friction and
offsets identified), the plausibility of links against the URDF, and the export of a law MuJoCo
does not have. On the bundled synthetic TX40 bag, whose links are the model's own."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from frictionid_core.cli import main
from frictionid_core.consistency.check import PLAUSIBILITY
from frictionid_core.errors import FrictionIdError
from frictionid_core.export.model_files import MATCH_SPEEDS
from frictionid_core.friction import FrictionModel
from frictionid_core.identification import IdentifyRequest, identify, validate
from frictionid_core.io import load
from frictionid_core.robots.tx40 import FRICTION, ROTOR_INERTIA
from frictionid_core.systems import get_system, known_rigid_body, nominal_parameters
from support.data import BAGS

JOINTS = [f"joint_{k}" for k in range(1, 7)]


@pytest.fixture(scope="module")
def tx40_bag():
    return load(BAGS / "tx40_excitation")


@pytest.fixture(scope="module")
def known(tx40_bag):
    """Coulomb ls with the TX40's links held (the bag's truth: its friction is Stribeck)."""
    return identify(tx40_bag, IdentifyRequest(system="tx40", known_rigid_body=True))


def test_known_rigid_body_identifies_the_rotor_inertias(known, tx40_bag):
    """Every rotor inertia within 5 % of the truth (a Coulomb fit of Stribeck friction: joint 3's
    moves between −1.6 and −4.3 % over the cut-offs a rule may reasonably pick); the result in the
    system's base parameters
    (validate rebuilds the ordinary tx40 model from it and finds the fit's own error), the held
    ones listed in ``fixed`` at the model's values, each rotor inertia by its name with its σ."""
    r = known.to_dict()
    for k, j in enumerate(JOINTS):
        assert r["params"][f"{j}.Ia"] == pytest.approx(ROTOR_INERTIA[k], rel=0.05), j
        assert r["std"][f"{j}.Ia"] > 0 and r["std_robust"][f"{j}.Ia"] > 0
    system = get_system("tx40")
    held = known_rigid_body(system)
    nominal = nominal_parameters(system)
    assert set(system.rigid_names) <= set(r["params"]) and "link_torque" not in r["params"]
    assert r["fixed"] == {n: pytest.approx(nominal[n], rel=1e-12) for n in held.held()}
    assert all(r["std"][n] == 0.0 for n in held.held())
    assert validate(tx40_bag, r)["relerr_pct"] == pytest.approx(r["metrics"]["relerr_pct"], rel=1e-9)
    # a base parameter holding one rotor inertia with coefficient c: the rotor's value and σ times c
    for name, row in zip(system.rigid_names, held.rotor_map):
        (k,) = np.flatnonzero(row) if np.count_nonzero(row) == 1 else (None,)
        if k is None:
            continue
        rotor = held.rotor_names[k]
        assert r["params"][name] == pytest.approx(held.links[list(system.rigid_names).index(name)]
                                                  + row[k] * r["params"][rotor], rel=1e-12)
        assert r["std_robust"][name] == pytest.approx(abs(row[k]) * r["std_robust"][rotor], rel=1e-9)
    assert r["request"]["known_rigid_body"] is True


def test_known_rigid_body_is_the_fit_with_every_base_parameter_but_the_rotors_fixed(known, tx40_bag):
    """What the CLI needed 34 --fix flags for: the same fit (the rotor inertias' sign constraint inactive)."""
    held = known_rigid_body(get_system("tx40"))
    nominal = nominal_parameters(get_system("tx40"))
    fixed = identify(tx40_bag, IdentifyRequest(system="tx40", fixed={n: nominal[n] for n in held.held()}))
    for name, value in fixed.params.items():
        assert known.params[name] == pytest.approx(value, rel=1e-7, abs=1e-9), name
    # the two fits subtract the held links' torque in other orders: their costs agree to round-off
    # (1.05e-9 relative on one machine's BLAS, at the code before and after 2-layout folds alike)
    assert known.metrics["cost"] == pytest.approx(fixed.metrics["cost"], rel=1e-8)


def test_known_rigid_body_on_the_command_line(tx40_bag, tmp_path, capsys):
    out = tmp_path / "r.json"
    bag = str(BAGS / "tx40_excitation")
    assert main(["identify", bag, "--system", "tx40", "--known-rigid-body", "--start", "0", "--end", "10",
                 "--json", str(out)]) == 0
    assert json.loads(out.read_text())["request"]["known_rigid_body"] is True
    capsys.readouterr()
    for extra, words in ((["--consistent"], "--known-rigid-body: holds the model's rigid body, which consistent "
                                            "fits; choose one"),
                         (["--system", "joint"], "--known-rigid-body: needs a robot system")):
        argv = ["identify", bag, "--system", "tx40", "--known-rigid-body", *extra]
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("frictionid: error: ") and words in err and "\n" not in err


def test_known_rigid_body_exports_the_model_links_and_the_identified_armature(known, tmp_path, capsys):
    import mujoco

    path = tmp_path / "r.json"
    path.write_text(json.dumps(known.to_dict()))
    assert main(["export", str(path), "--mujoco", str(tmp_path / "m.xml")]) == 0
    capsys.readouterr()
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "m.xml"))
    model = get_system("tx40").robot.model
    for k, j in enumerate(JOINTS):
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        assert m.dof_armature[m.jnt_dofadr[jid]] == pytest.approx(known.params[f"{j}.Ia"], rel=1e-9)
        assert m.body_mass[m.jnt_bodyid[jid]] == pytest.approx(model.model.inertias[k + 1].mass, rel=1e-9)


def test_a_stribeck_fit_exports_the_damping_and_frictionloss_that_match_it(known, tmp_path, capsys):
    """MuJoCo has viscous + Coulomb friction only: the exported damping and frictionloss are the
    bounded least-squares match of the law over the data's speeds (here the TX40's published
    Stribeck law on the result's joints), and the export says how much of the law that loses."""
    r = known.to_dict()
    law = FrictionModel("stribeck")
    r["friction"] = "stribeck"
    for k, j in enumerate(JOINTS):
        r["params"].update({f"{j}/{n}": float(FRICTION[n][k]) for n in law.names})
    path = tmp_path / "r.json"
    path.write_text(json.dumps(r))
    assert main(["export", str(path), "--mujoco", str(tmp_path / "m.xml"), "--urdf", str(tmp_path / "r.urdf")]) == 0
    lines = capsys.readouterr().out.splitlines()
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(tmp_path / "m.xml"))
    urdf = {j.get("name"): j.find("dynamics") for j in ET.parse(tmp_path / "r.urdf").getroot().iter("joint")}
    for k, j in enumerate(JOINTS):
        lo, hi = r["velocity_range"][j]
        v = np.linspace(lo, hi, MATCH_SPEEDS)
        f = law.torque([FRICTION[n][k] for n in law.names], v)
        ref = lsq_linear(np.column_stack([v, np.ones_like(v)]), f, bounds=(0.0, np.inf)).x
        dof = m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)]
        assert m.dof_damping[dof] == pytest.approx(ref[0], rel=1e-6), j
        assert m.dof_frictionloss[dof] == pytest.approx(ref[1], rel=1e-6), j
        assert float(urdf[j].get("damping")) == pytest.approx(m.dof_damping[dof], rel=1e-9)
        assert float(urdf[j].get("friction")) == pytest.approx(m.dof_frictionloss[dof], rel=1e-9)
        loss = 100 * np.sqrt(np.mean((f - ref[0] * v - ref[1]) ** 2)) / np.sqrt(np.mean(f**2))
        line = next(x for x in lines if x.startswith(f"{j}: stribeck friction exported as damping"))
        printed = float(line.split("loses ")[1].split(" %")[0])
        assert printed == pytest.approx(loss, rel=5e-3), (line, loss)  # printed to 3 digits


def test_a_fit_with_absurd_links_is_warned_and_not_exported_unless_forced(known, tx40_bag, tmp_path, capsys):
    """Base parameters no motion of the bag could give (joint 2's first moment ×4): identify names
    the link whose reconstructed mass or centre of mass is far from the URDF's (thresholds in the
    result), export refuses it, --force writes it."""
    system = get_system("tx40")
    free = identify(tx40_bag, IdentifyRequest(system="tx40", window=(0.0, 10.0)))
    assert not free.plausibility["implausible"] and free.plausibility["thresholds"] == PLAUSIBILITY
    assert not any("is implausible against the robot model" in w for w in free.warnings)
    r = free.to_dict()
    moment = next(n for n in system.rigid_names if n.startswith("joint_2.m"))
    r["params"][moment] *= 4.0
    from frictionid_core.identification.plausibility import robot_plausibility

    block = robot_plausibility(r["params"], system, None)
    assert "joint_2" in block["implausible"] or "joint_3" in block["implausible"]
    path = tmp_path / "r.json"
    path.write_text(json.dumps(r))
    assert main(["export", str(path), "--urdf", str(tmp_path / "x.urdf")]) == 2
    err = capsys.readouterr().err
    assert "refused to export an inconsistent or implausible result" in err and "implausible against the model" in err
    assert main(["export", str(path), "--urdf", str(tmp_path / "x.urdf"), "--force"]) == 0
    assert "exporting an inconsistent or implausible result (--force)" in capsys.readouterr().out
    with pytest.raises(FrictionIdError):
        from frictionid_core.export import export_data

        export_data(r, system)


def test_a_rotor_inertia_is_negative_beyond_round_off_only():
    """A reconstruction gives −1e-17 for a rotor inertia of 0: not a problem; −1e-3 kg·m² is one, named."""
    from frictionid_core.consistency import link_plausibility

    info = get_system("tx40").robot
    names = info.model.parameter_names()
    pi = np.array(info.model.parameters(), dtype=float)
    ia = names.index("joint_3.Ia")
    pi[ia] = -1e-17
    assert "joint_3" not in link_plausibility(info, pi, "test")["implausible"]
    pi[ia] = -1e-3
    block = link_plausibility(info, pi, "test")
    assert block["implausible"] == ["joint_3"]
    assert block["links"]["joint_3"]["problems"] == ["rotor inertia -0.001 kg·m² < 0"]
