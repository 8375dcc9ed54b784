"""The scripts of examples/ run as a user runs them (a subprocess, an output folder) and print
the documented figures."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
# EMPS reference IDIM-LS on the estimation bag (docs/reference.md#emps-reference-results), to
# the printed digits; the cross-test on the validation bag gives 5.9824 %.
EMPS = {"M": 95.1089, "Fv": 203.503, "Fc": 20.3935, "offset": -3.16481}


def run_example(name: str, *args) -> str:
    proc = subprocess.run([sys.executable, str(EXAMPLES / name), *map(str, args)], capture_output=True,
                          text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.mark.slow
def test_identify_from_bag_prints_the_reference_parameters(tmp_path):
    stdout = run_example("identify_from_bag.py", tmp_path)
    path = tmp_path / "emps_coulomb.json"
    printed = dict(re.findall(r"^(\w+)\s+(-?[\d.]+)\s+±", stdout, re.M))
    assert {k: float(v) for k, v in printed.items()} == EMPS
    assert "relative error 4.08336 %, condition number 25.9883" in stdout
    saved = json.loads(path.read_text())
    assert {k: round(v, 6 - len(str(int(abs(v))))) for k, v in saved["params"].items()} == EMPS
    assert saved["system"] == "emps" and saved["friction"] == "coulomb" and saved["joints"] == ["emps"]


@pytest.mark.slow
def test_validate_and_plot_prints_the_cross_test_and_saves_the_figure(tmp_path):
    import matplotlib.image

    stdout = run_example("validate_and_plot.py", tmp_path)
    assert "estimation 4.0834 %, validation 5.9824 %" in stdout
    image = matplotlib.image.imread(tmp_path / "validation_force.png")
    assert image.shape[:2] == (500, 800)  # 8 × 5 in at 100 dpi
    assert image[..., :3].std() > 0.05  # not a blank canvas


def _node_feedforward(result_file: Path, joints: list[str], eps: float, v: np.ndarray) -> np.ndarray:
    """The ROS node's feed-forward (frictionid_ros.feedforward, no rclpy) at one velocity per joint."""
    from frictionid_ros.inputs import FeedForward
    from frictionid_ros.store import read_results

    ff = FeedForward(joints, eps)
    assert ff.set_params(read_results(result_file).per_joint) == []
    return ff.torque(v)


def _printed_table(stdout: str) -> np.ndarray:
    rows = [line.split() for line in stdout.splitlines() if re.match(r"^\s+-?[\d.]", line)]
    return np.array(rows, dtype=float)


def test_feedforward_torque_matches_the_node(emps_estimation, tmp_path):
    from frictionid_core import IdentifyRequest, identify

    path = tmp_path / "emps_coulomb.json"  # what 'frictionid identify --json' writes
    path.write_text(json.dumps(identify(emps_estimation, IdentifyRequest(system="emps", friction="coulomb")).to_dict()))
    stdout = run_example("feedforward_torque.py", path, tmp_path, "--eps", "0.01")
    table = _printed_table(stdout)
    v = np.array([-0.2, -0.05, -0.01, 0.0, 0.01, 0.05, 0.2])  # the script's default velocities
    np.testing.assert_array_equal(table[:, 0], v)
    p = json.loads(path.read_text())["params"]
    expected = p["Fv"] * v + p["Fc"] * np.tanh(v / 0.01)  # no offset, no mass: friction only
    np.testing.assert_allclose(table[:, 1], expected, rtol=1e-5)  # 6 printed digits
    node = np.array([_node_feedforward(path, ["emps"], 0.01, np.array([x]))[0] for x in v])
    csv = np.loadtxt(tmp_path / "feedforward.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(csv[:, 1], node, rtol=1e-9)


def test_feedforward_torque_of_a_two_joint_asymmetric_result(tmp_path):
    # A several-joint result names its friction parameters '<joint>/<name>' and has shared
    # rigid-body parameters without prefix (as 'frictionid identify --system tx40' writes).
    names = ("Fv", "Fc", "Fs", "vs", "delta")
    params = {"ZZ": 1.5}
    for j, scale in (("joint_1", 1.0), ("joint_2", 2.0)):
        for side, f in (("pos", 1.0), ("neg", 0.8)):
            values = (7.9 * scale * f, 6.9 * scale * f, 9.0 * scale * f, 0.025 * scale, 2.0)
            params.update({f"{j}/{n}_{side}": x for n, x in zip(names, values)})
    result = {"system": "tx40", "friction": "stribeck", "asymmetric": True, "solver": "lm", "source": "hand-made",
              "joints": ["joint_1", "joint_2"], "params": params, "std": {}, "metrics": {}, "wall_s": 0.0}
    path = tmp_path / "two_joints.json"
    path.write_text(json.dumps(result))
    velocities = [-0.3, -0.02, 0.0, 0.02, 0.3]
    stdout = run_example("feedforward_torque.py", path, "--eps", "0.005",
                         f"--velocities={','.join(map(str, velocities))}")
    table = _printed_table(stdout)
    assert table.shape == (5, 3)
    node = np.array([_node_feedforward(path, ["joint_1", "joint_2"], 0.005, np.array([v, v])) for v in velocities])
    np.testing.assert_allclose(table[:, 1:], node, rtol=1e-5)
    assert table[0, 1] < 0 < table[-1, 1] and abs(table[0, 1]) < abs(table[-1, 1])  # v < 0 branch 0.8×
