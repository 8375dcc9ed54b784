"""A payload through the model's other uses: ``export --payload`` (a fixed link in the URDF and the
MuJoCo model, the YAML parameters file carrying it), ``validate --payload`` (and the YAML's own
payload), ``compare`` of two payloads."""

from __future__ import annotations

import json

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.identification import IdentifyRequest, identify, identify_payload, read_payload
from frictionid_core.io import save_csv
from frictionid_core.robots import load_urdf, random_samples, robot_with_payload
from support.payload_logs import loaded_logs


@pytest.fixture(scope="module", params=["tx40", "ur5"])
def exported(request, tmp_path_factory):
    """A consistent base result, the payload on the loaded log, the export with and without it."""
    logs = loaded_logs(request.param)
    folder = tmp_path_factory.mktemp(f"export_{request.param}")
    base = identify(logs.base, IdentifyRequest(system=logs.system, friction="coulomb", consistent=True))
    files = {"BASE": folder / "base.json", "P": folder / "p.json", "validation": folder / "validation.csv"}
    files["BASE"].write_text(json.dumps(base.to_dict()))
    files["P"].write_text(json.dumps(identify_payload(logs.loaded, base).to_dict()))
    save_csv(logs.validation, files["validation"])
    for tag, extra in (("loaded", ["--payload", str(files["P"])]), ("bare", [])):
        out = [folder / f"{tag}.{suffix}" for suffix in ("urdf", "xml", "yaml")]
        assert main(["export", str(files["BASE"]), *extra, "--urdf", str(out[0]), "--mujoco", str(out[1]),
                     "--yaml", str(out[2])]) == 0
        files.update({f"{tag}.urdf": out[0], f"{tag}.xml": out[1], f"{tag}.yaml": out[2]})
    return logs, files


@pytest.mark.slow
def test_export_writes_the_payload_as_a_fixed_link(exported):
    """The exported URDF with the payload is the bare export with the payload fixed to its link
    (Pinocchio's torques to 1e-9); MuJoCo's model has a body 'payload' of its mass, centre of mass
    and inertia; the YAML carries the payload block."""
    import mujoco

    _, files = exported
    payload = read_payload(files["P"]).payload
    loaded, bare = load_urdf(files["loaded.urdf"]), load_urdf(files["bare.urdf"])
    q, qd, qdd = random_samples(bare, 20, seed=5)
    expected = robot_with_payload(bare, payload).inverse_dynamics(q, qd, qdd)
    tau = loaded.inverse_dynamics(q, qd, qdd)
    assert np.max(np.abs(tau - expected)) <= 1e-9 * np.max(np.abs(expected))
    assert np.max(np.abs(tau - bare.inverse_dynamics(q, qd, qdd))) > 1.0
    m = mujoco.MjModel.from_xml_path(str(files["loaded.xml"]))
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "payload")
    assert body > 0 and m.body_mass[body] == pytest.approx(payload.mass, rel=1e-12)
    assert np.allclose(m.body_ipos[body], payload.com, atol=1e-12)
    assert np.sort(m.body_inertia[body]) == pytest.approx(np.linalg.eigvalsh(np.array(payload.inertia)), rel=1e-9)
    assert mujoco.mj_name2id(mujoco.MjModel.from_xml_path(str(files["bare.xml"])), mujoco.mjtObj.mjOBJ_BODY,
                             "payload") == -1
    carried = read_payload(files["loaded.yaml"]).payload
    assert carried == payload


@pytest.mark.slow
def test_validate_with_a_payload_file_or_the_yaml_that_carries_it(exported, tmp_path, capsys):
    """``validate --params BASE --payload P`` and ``validate --params loaded.yaml`` give the same
    metrics on the loaded validation log, far better than the base alone."""
    _, files = exported
    runs = {"payload": ["--params", str(files["BASE"]), "--payload", str(files["P"])],
            "yaml": ["--params", str(files["loaded.yaml"])], "base": ["--params", str(files["BASE"])]}
    metrics = {}
    for name, argv in runs.items():
        out = tmp_path / f"{name}.json"
        assert main(["validate", str(files["validation"]), *argv, "--json", str(out)]) == 0
        metrics[name] = json.loads(out.read_text())
    assert " kg payload on " in capsys.readouterr().out
    assert metrics["payload"]["metrics"]["relerr_pct"] == pytest.approx(metrics["yaml"]["metrics"]["relerr_pct"],
                                                                        rel=1e-9)
    assert metrics["payload"]["payload"]["mass"] == pytest.approx(2.8, rel=0.01)
    assert "payload" not in metrics["base"]
    assert metrics["payload"]["metrics"]["relerr_pct"] < 0.1 * metrics["base"]["metrics"]["relerr_pct"]


def test_compare_shows_two_payloads_side_by_side(exported, tmp_path, capsys):
    """Two payload files: each quantity's values and σ, the difference and its z; a payload file
    with an identification result is refused in one line."""
    _, files = exported
    first = json.loads(files["P"].read_text())
    second = json.loads(files["P"].read_text())
    second["payload"]["mass"] += 0.1
    other = tmp_path / "other.json"
    other.write_text(json.dumps(second))
    out = tmp_path / "c.json"
    capsys.readouterr()
    assert main(["compare", str(files["P"]), str(other), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "A: " in text and "B: " in text and "inertia.yz" in text
    data = json.loads(out.read_text())
    mass = data["quantities"]["mass"]
    assert mass["difference"]["B"] == pytest.approx(0.1)
    sigma = first["payload"]["sigma"]["mass"]
    assert mass["z"]["B"] == pytest.approx(0.1 / np.hypot(sigma, sigma))
    assert [p["link"] for p in data["payloads"]] == [first["payload"]["link"]] * 2
    assert main(["compare", str(files["P"]), str(files["BASE"])]) == 2
    assert "not a payload file" in capsys.readouterr().err


def test_export_refuses_a_payload_the_robot_cannot_hold(exported, tmp_path, capsys):
    """An 80 kg payload file: the YAML is refused by the safety screen (the joint and its limit named)."""
    _, files = exported
    heavy = json.loads(files["P"].read_text())
    heavy["payload"].update(mass=80.0, inertia=[[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    path = tmp_path / "heavy.json"
    path.write_text(json.dumps(heavy))
    capsys.readouterr()
    assert main(["export", str(files["BASE"]), "--payload", str(path), "--yaml", str(tmp_path / "h.yaml")]) == 2
    err = capsys.readouterr().err
    assert "the safety screen refuses them: payload on" in err and "is over the effort limit" in err
    assert not (tmp_path / "h.yaml").exists()
