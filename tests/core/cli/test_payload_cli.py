"""``frictionid payload``: the command on CSV logs of a synthetic TX40 with a known payload, its
JSON contract, and its bad input (one line, exit 2)."""

from __future__ import annotations

import json

import pytest

from frictionid_core.cli import main
from frictionid_core.io import save_csv
from support.payload_logs import loaded_logs

CONTRACT = ["link", "mass", "com", "inertia", "sigma", "feasible", "resolved"]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """CSV logs (base, loaded, validation) of the synthetic TX40 and the base result's file."""
    logs = loaded_logs("tx40")
    folder = tmp_path_factory.mktemp("payload")
    paths = {name: folder / f"{name}.csv" for name in ("base", "loaded", "validation")}
    for name, path in paths.items():
        save_csv(getattr(logs, name), path)
    paths["BASE"] = folder / "base.json"
    assert main(["identify", str(paths["base"]), "--system", "tx40", "--json", str(paths["BASE"])]) == 0
    return logs, paths


@pytest.mark.slow
def test_payload_command_writes_the_contract(files, tmp_path, capsys):
    logs, paths = files
    capsys.readouterr()
    out = tmp_path / "p.json"
    assert main(["payload", str(paths["loaded"]), "--base", str(paths["BASE"]), "--end", "8", "--json",
                 str(out)]) == 0
    text = capsys.readouterr().out
    assert "payload on link_6" in text and "mass" in text and "resolved" in text and "per joint" in text
    data = json.loads(out.read_text())
    assert list(data["payload"]) == CONTRACT
    p = data["payload"]
    assert p["link"] == "link_6" and p["feasible"] is True and len(p["resolved"]) == 10
    assert abs(p["mass"] - 2.8) < 0.028 and len(p["com"]) == 3 and [len(r) for r in p["inertia"]] == [3, 3, 3]
    assert set(p["sigma"]) == {"mass", "com", "inertia"} and p["sigma"]["mass"] > 0
    assert set(data["metrics"]["per_joint"]) == set(logs.robot.joints)
    assert data["metrics"]["relerr_pct"] < data["metrics_base"]["relerr_pct"]
    assert data["base"] == str(paths["BASE"]) and data["friction_refit"] is None
    assert data["preprocessing"]["rechosen"]  # the base's data-chosen settings, chosen again here


def test_payload_bad_input_is_one_line(files, tmp_path, capsys):
    _, paths = files
    capsys.readouterr()
    assert main(["payload", str(paths["loaded"]), "--base", str(paths["BASE"]), "--link", "flange"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("frictionid: error: link 'flange' is not a link of tx40")
    assert main(["payload", str(paths["loaded"]), "--base", str(paths["BASE"]), "--json", str(paths["BASE"])]) == 2
    assert "refusing to overwrite" in capsys.readouterr().err
    assert main(["payload", str(paths["loaded"]), "--base", str(tmp_path / "none.json")]) == 2
    assert "none.json" in capsys.readouterr().err
