"""The ``frictionid`` command line on small synthetic data (the EMPS runs are in test_emps_ls)."""

from __future__ import annotations

import io
import json
from contextlib import redirect_stdout

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.cli._common import print_table
from frictionid_core.io import save_csv, write_joint_state_bag
from frictionid_core.timeseries import JointSeries

TRUE = {"M": 95.0, "Fv": 200.0, "Fc": 20.0, "offset": -3.0}


@pytest.fixture
def csv_file(tmp_path, synthetic):
    path = tmp_path / "run.csv"
    save_csv(synthetic(**TRUE), path)
    return path


def two_joint_friction_series() -> JointSeries:
    """Friction-only data of two joints: τ_j = Fv_j·q̇_j + Fc_j·sign(q̇_j) + offset_j."""
    n = 3000
    t = np.arange(n) * 1e-3
    w = 2 * np.pi * np.array([0.8, 1.3])
    amp = np.array([0.2, 0.1])
    q = amp / w * np.sin(np.outer(t, w))
    qd = amp * np.cos(np.outer(t, w))
    eff = qd * [5.0, 2.0] + np.sign(qd) * [1.5, 0.7] + [0.2, -0.1]
    return JointSeries(t, ["j1", "j2"], q, eff, source="two")


def test_identify_writes_json(csv_file, tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["identify", str(csv_file), "--system", "emps", "--friction", "coulomb", "--solver", "ls",
                 "--json", str(out)]) == 0
    assert capsys.readouterr().err == ""
    r = json.loads(out.read_text())
    for key in ("system", "friction", "asymmetric", "solver", "source", "params", "std", "metrics"):
        assert key in r, key
    assert (r["system"], r["friction"], r["asymmetric"], r["solver"]) == ("emps", "coulomb", False, "ls")
    assert r["joint_map"] == {}  # always present: validate rebuilds the system from system + joint_map
    assert r["source"] == str(csv_file)
    assert set(r["params"]) == set(TRUE) == set(r["std"])
    for key in ("relerr_pct", "r2", "rmse", "cond"):
        assert isinstance(r["metrics"][key], float) and np.isfinite(r["metrics"][key]), key
    # Noise-free data: parameters recovered (see test_emps_ls for the error budget).
    for k in ("M", "Fv", "Fc"):
        assert r["params"][k] == pytest.approx(TRUE[k], rel=0.01), k
    assert r["metrics"]["relerr_pct"] < 2.0 and r["metrics"]["r2"] > 0.999
    assert all(s > 0 for s in r["std"].values())
    assert not list(tmp_path.glob("*.tmp"))  # written through a temporary file, renamed


def test_identify_without_json_writes_nothing(csv_file, tmp_path):
    before = set(tmp_path.iterdir())
    assert main(["identify", str(csv_file)]) == 0
    assert set(tmp_path.iterdir()) == before


def test_print_table_contains_parameters_and_metrics():
    result = {"system": "emps", "friction": "coulomb", "asymmetric": True, "solver": "ls", "source": "x.csv",
              "params": {"M": 95.1, "Fv_pos": 166.7, "Fc_neg": 20.6}, "std": {"M": 0.1085},
              "std_robust": {"M": 0.31, "Fv_pos": float("nan")}, "metrics": {"relerr_pct": 3.11, "r2": float("nan")}}
    buf = io.StringIO()
    print_table(result, out=buf)
    text = buf.getvalue()
    assert "(asymmetric)" in text and "solver ls" in text and "source: x.csv" in text
    lines = text.splitlines()
    row = {ln.split()[0]: ln.split()[1:] for ln in lines if ln.split() and ln.split()[0] in result["params"]}
    assert row == {"M": ["95.1", "0.1085", "0.31"], "Fv_pos": ["166.7", "—", "—"], "Fc_neg": ["20.6", "—", "—"]}
    assert "σ calibrated" in text
    assert "relerr_pct 3.11" in text and "r2 —" in text


def test_identify_prints_table_on_current_stdout(csv_file):
    # The table must go to whatever sys.stdout is when the command runs (redirect_stdout,
    # pytest's capsys, an embedding application), not to the stream of import time.
    buf = io.StringIO()
    with redirect_stdout(buf):
        assert main(["identify", str(csv_file)]) == 0
    text = buf.getvalue()
    for name in ("parameter", "M", "Fv", "Fc", "offset", "relerr_pct"):
        assert name in text, name


def test_identify_asymmetric_json_has_no_offset(csv_file, tmp_path):
    out = tmp_path / "r.json"
    assert main(["identify", str(csv_file), "--asymmetric", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["asymmetric"] is True
    assert list(r["params"]) == ["M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"]


def test_validate_writes_metrics(csv_file, tmp_path, synthetic, capsys):
    params = tmp_path / "p.json"
    assert main(["identify", str(csv_file), "--json", str(params)]) == 0
    # Other data from the same system: another realisation of 0.5 N measurement noise.
    # (Not another duration: trim_end = 0 in the EMPS protocol, so data that end in motion
    # get large one-sided-difference errors at the last samples.)
    s = synthetic(**TRUE)
    s.effort = s.effort + 0.5 * np.random.default_rng(7).standard_normal(s.effort.shape)
    other = tmp_path / "other.csv"
    save_csv(s, other)
    capsys.readouterr()
    out = tmp_path / "v.json"
    assert main(["validate", str(other), "--params", str(params), "--json", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "cross-test" in stdout and "relerr_pct" in stdout
    v = json.loads(out.read_text())
    assert v["source"] == str(other) and v["params_file"] == str(params)
    assert (v["system"], v["friction"], v["asymmetric"]) == ("emps", "coulomb", False)
    for key in ("relerr_pct", "r2", "rmse"):
        assert np.isfinite(v["metrics"][key]), key
    # Same system, same parameters: the cross-test error is about the fit error (1.4 %).
    assert v["metrics"]["relerr_pct"] < 2.0


def test_validate_of_wrong_parameters_is_worse(csv_file, tmp_path):
    params = tmp_path / "p.json"
    assert main(["identify", str(csv_file), "--json", str(params)]) == 0
    good = tmp_path / "good.json"
    assert main(["validate", str(csv_file), "--params", str(params), "--json", str(good)]) == 0
    r = json.loads(params.read_text())
    r["params"]["Fv"] *= 1.5
    params.write_text(json.dumps(r))
    bad = tmp_path / "bad.json"
    assert main(["validate", str(csv_file), "--params", str(params), "--json", str(bad)]) == 0
    assert (json.loads(bad.read_text())["metrics"]["relerr_pct"]
            > 5 * json.loads(good.read_text())["metrics"]["relerr_pct"])


def test_validate_reproduces_the_identification_metrics(csv_file, tmp_path):
    params = tmp_path / "p.json"
    assert main(["identify", str(csv_file), "--json", str(params)]) == 0
    out = tmp_path / "v.json"
    assert main(["validate", str(csv_file), "--params", str(params), "--json", str(out)]) == 0
    r, v = json.loads(params.read_text()), json.loads(out.read_text())
    assert v["metrics"]["relerr_pct"] == pytest.approx(r["metrics"]["relerr_pct"], rel=1e-12)


def _residual_table(path):
    """(header, source names, numbers) of a ``--residuals`` file."""
    import csv

    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], [r[0] for r in rows[1:]], np.array([[float(v) for v in r[1:]] for r in rows[1:]])


def test_validate_residuals_hold_the_rows_the_metrics_compare(tmp_path):
    # two sources of two joints, the second shorter: every instant is written under its source, t on its
    # own clock, and the used rows give back the JSON's relative errors (overall and per joint)
    series = two_joint_friction_series()
    series.effort = series.effort + 0.02 * np.random.default_rng(3).standard_normal(series.effort.shape)
    first = write_joint_state_bag(tmp_path / "a", series)
    second = write_joint_state_bag(tmp_path / "b", series.window(0.0, 2.0))
    params, out, res = tmp_path / "r.json", tmp_path / "v.json", tmp_path / "res.csv"
    assert main(["identify", str(first), "--system", "friction-only", "--json", str(params)]) == 0
    r = json.loads(params.read_text())
    r["params"]["j1/Fv"] *= 1.2  # an error to find in the residuals
    params.write_text(json.dumps(r))
    assert main(["validate", str(first), str(second), "--params", str(params), "--json", str(out),
                 "--residuals", str(res)]) == 0
    header, sources, table = _residual_table(res)
    assert header == ["source", "t", "j1.effort", "j1.predicted", "j1.used", "j2.effort", "j2.predicted", "j2.used"]
    v = json.loads(out.read_text())
    names = v["source"]  # as the JSON names them (a bag's with its topic)
    assert names[0].startswith(str(first)) and names[1].startswith(str(second))
    assert sources[0] == names[0] and sources[-1] == names[1] and set(sources) == set(names)
    t = table[:, 0]
    for name, duration in zip(names, (3.0, 2.0)):
        mine = t[[s == name for s in sources]]
        assert np.all(np.diff(mine) > 0) and 0.0 < mine[0] < 0.5 < duration - 0.5 < mine[-1] < duration
    metrics = v["metrics"]
    used = table[:, [3, 6]] > 0.5
    effort, predicted = table[:, [1, 4]], table[:, [2, 5]]
    assert used.sum() == metrics["samples"]
    whole = 100 * np.linalg.norm((effort - predicted)[used]) / np.linalg.norm(effort[used])
    assert whole == pytest.approx(metrics["relerr_pct"], rel=1e-8)
    for k, joint in enumerate(("j1", "j2")):
        e, p = effort[used[:, k], k], predicted[used[:, k], k]
        assert 100 * np.linalg.norm(e - p) / np.linalg.norm(e) == pytest.approx(
            metrics["per_joint"][joint]["relerr_pct"], rel=1e-8)
    assert metrics["per_joint"]["j1"]["relerr_pct"] > 2 * metrics["per_joint"]["j2"]["relerr_pct"]  # 6.7 vs 2.3


def test_validate_refuses_residuals_over_its_own_input(csv_file, tmp_path, capsys):
    params = tmp_path / "p.json"
    assert main(["identify", str(csv_file), "--json", str(params)]) == 0
    before = params.read_bytes()
    assert main(["validate", str(csv_file), "--params", str(params), "--residuals", str(params)]) == 2
    assert "--residuals" in capsys.readouterr().err and params.read_bytes() == before


def test_two_joints_friction_only_from_bag(tmp_path):
    bag = write_joint_state_bag(tmp_path / "b", two_joint_friction_series())
    out = tmp_path / "r.json"
    assert main(["identify", str(bag), "--system", "friction-only", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["joints"] == ["j1", "j2"]
    assert list(r["params"]) == ["j1/Fv", "j1/Fc", "j2/Fv", "j2/Fc", "j1/offset", "j2/offset"]
    expected = {"j1/Fv": 5.0, "j1/Fc": 1.5, "j2/Fv": 2.0, "j2/Fc": 0.7}
    for k, v in expected.items():
        assert r["params"][k] == pytest.approx(v, rel=0.005), k  # noise-free: 0.03 % in practice


def test_joints_option_selects_one_joint(tmp_path):
    bag = write_joint_state_bag(tmp_path / "b", two_joint_friction_series())
    out = tmp_path / "r.json"
    assert main(["identify", str(bag), "--system", "friction-only", "--joints", " j2 ", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["joints"] == ["j2"]
    assert r["params"]["Fv"] == pytest.approx(2.0, rel=0.005)
    assert r["params"]["Fc"] == pytest.approx(0.7, rel=0.005)


def test_effort_topic_option(tmp_path):
    s = two_joint_friction_series()
    bag = write_joint_state_bag(tmp_path / "b", s, topic="/effort_src",
                                extra_topics={"/joint_states": ("position", s.position)})
    out = tmp_path / "r.json"
    assert main(["identify", str(bag), "--system", "friction-only", "--effort-topic", "/effort_src",
                 "--json", str(out)]) == 0
    assert json.loads(out.read_text())["params"]["j1/Fc"] == pytest.approx(1.5, rel=0.005)


def test_argparse_rejects_unknown_friction_model(csv_file, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["identify", str(csv_file), "--friction", "dahl"])
    assert exc.value.code == 2
    assert "dahl" in capsys.readouterr().err


# ------------------------------------------------------------------- help and plugins
HEAVY = ("numpy", "scipy", "numba", "pinocchio", "rosbags", "rclpy", "matplotlib")
# The --friction choices come from the friction registry, a numpy module (~0.1 s to import).
NEEDS_NUMPY = {"identify", "synth"}


def _help_imports(*argv: str) -> tuple[str, list[str]]:
    """Run ``frictionid ARGV`` in a fresh interpreter; its stdout and the heavy packages it imported."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    src = Path(__file__).resolve().parents[3]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(src / "frictionid_core" / "src"),
                                                       str(src / "frictionid_ros"), os.environ.get("PYTHONPATH", "")]))
    code = ("import sys; from frictionid_core.cli import main\n"
            "try:\n    main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
            f"print('IMPORTED', *sorted(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code, *argv], env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    text, _, imported = out.stdout.rpartition("IMPORTED")
    return text, imported.split()


@pytest.mark.parametrize("argv", [["--help"], ["identify", "--help"], ["validate", "--help"],
                                  ["simulate", "--help"], ["study", "--help"], ["synth", "--help"],
                                  ["replay", "--help"]])
def test_help_imports_no_numerical_or_ros_package(argv):
    """--help builds the parser only: none of scipy, numba, Pinocchio, rosbags, rclpy, matplotlib is
    imported, and numpy only by the commands whose --friction choices come from the friction registry."""
    text, imported = _help_imports(*argv)
    assert "usage: frictionid" in text
    assert imported == (["numpy"] if argv[0] in NEEDS_NUMPY else []), imported


def test_top_level_help_lists_core_and_plugin_commands():
    from importlib.metadata import entry_points

    from frictionid_core.cli import COMMANDS

    text, _ = _help_imports("--help")
    plugins = [ep.name for ep in entry_points(group="frictionid.commands")]
    for name in [*COMMANDS, *plugins]:
        assert f"\n    {name} " in text, name
    assert "identify friction (and rigid-body) parameters" in text


def test_command_help_shows_its_options():
    text, _ = _help_imports("identify", "--help")
    assert "--friction {coulomb,threlfall,tustin,stribeck,lugre,gms,auto}" in text and "--solver {ls,lm," in text


def test_unknown_command_is_an_argparse_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["identfy", "x"])
    assert exc.value.code == 2
    assert "invalid choice: 'identfy'" in capsys.readouterr().err


def test_build_parser_gives_handlers_of_the_named_commands_only():
    from frictionid_core.cli import build_parser

    parser, handlers = build_parser(["validate"])
    assert list(handlers) == ["validate"]
    args = parser.parse_args(["validate", "run.csv", "--params", "p.json", "--joints", "a, b"])
    assert args.source == ["run.csv"] and str(args.params) == "p.json" and args.joints == "a, b"
    with pytest.raises(SystemExit):  # identify's options were not built
        parser.parse_args(["identify", "run.csv", "--solver", "de"])
