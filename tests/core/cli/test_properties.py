"""Property-based (hypothesis): whatever layouts, drives, result files and small bags the CLI is
given, it never fails with an internal error, never exits 0 with a non-finite metric and never
changes a file it reads (output paths are drawn among the inputs too).

Deterministic: ``derandomize=True`` and no example database, a fixed number of examples per test.
"""

from __future__ import annotations

import io
import json
import math
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from frictionid_core.cli import main
from frictionid_core.identification import IdentifyRequest, identify
from frictionid_core.io import save_csv, write_joint_state_bag
from frictionid_core.model import FINITE_METRICS
from frictionid_core.timeseries import JointSeries
from support.data import emps_like

EXAMPLES = settings(max_examples=30, derandomize=True, database=None, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
EXIT_CODES = (0, 2, 3)  # success, bad input, consistency not found feasible

# JSON values a hand-edited or corrupted file may hold where another value belongs.
json_values = st.one_of(
    st.none(), st.booleans(), st.integers(-3, 3), st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e300, -1e300, 1e16, -0.0, 5e-324]), st.text(max_size=4), st.lists(st.integers(-2, 2), max_size=3),
    st.dictionaries(st.sampled_from(["a", "M", "start_s", "emps"]), st.one_of(st.integers(-1, 1), st.text(max_size=2)),
                    max_size=2))


# ----------------------------------------------------------------------------- helpers
def run_cli(argv) -> tuple[int, str]:
    """``frictionid argv`` in this process: (exit code, stderr)."""
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, err.getvalue()


def contents(paths) -> dict[str, bytes]:
    """The bytes of every file of ``paths`` (a directory: each file in it)."""
    out = {}
    for path in map(Path, paths):
        for file in sorted(path.rglob("*")) if path.is_dir() else [path]:
            if file.is_file():
                out[str(file)] = file.read_bytes()
    return out


def check_run(argv, inputs, output: Path | None = None) -> int:
    """Run the CLI and assert the properties: an exit code of :data:`EXIT_CODES` without internal
    error; on exit 2 one error line; no input changed; on an error an existing output kept; on
    exit 0 of identify and validate, the written metrics finite. Returns the exit code."""
    before = contents(inputs)
    kept = output.read_bytes() if output is not None and output.is_file() else None
    code, err = run_cli(argv)
    event(f"{argv[0]} exit {code}")
    assert code in EXIT_CODES and "internal error" not in err and "Traceback" not in err, (argv, code, err)
    if code == 2:
        assert sum(line.startswith("frictionid: error: ") for line in err.splitlines()) == 1, (argv, err)
    assert contents(inputs) == before, (argv, err)
    if code != 0 and kept is not None:
        assert output.read_bytes() == kept, (argv, err)
    if code == 0 and argv[0] in ("identify", "validate") and output is not None:  # the commands that measure
        metrics = json.loads(output.read_text())["metrics"]
        assert all(math.isfinite(metrics[key]) for key in FINITE_METRICS), (argv, metrics)
    return code


@pytest.fixture(scope="module")
def emps_files(tmp_path_factory):
    """An EMPS-like log (CSV) and its identification result (JSON)."""
    folder = tmp_path_factory.mktemp("emps")
    series = emps_like()
    save_csv(series, folder / "log.csv")
    result = identify(series, IdentifyRequest(system="emps")).to_dict()
    (folder / "result.json").write_text(json.dumps(result))
    return folder / "log.csv", result


def result_paths(result: dict) -> list[str]:
    """Dotted keys of a result to corrupt: every top-level key and the entries of its blocks."""
    paths = list(result)
    for block in ("params", "std", "metrics", "preprocessing", "window", "request"):
        paths += [f"{block}.{k}" for k in (result.get(block) or {})]
    return paths + ["drive", "standard_parameters", "joint_map.emps", "bounds.M", "metrics.per_joint.emps"]


def corrupted(result: dict, path: str, value, delete: bool) -> dict:
    """A copy of ``result`` with the dotted key ``path`` set to ``value`` (or removed)."""
    out = json.loads(json.dumps(result))
    *parents, last = path.split(".")
    node = out
    for key in parents:
        if not isinstance(node.get(key), dict):
            node[key] = {}
        node = node[key]
    if delete:
        node.pop(last, None)
    else:
        node[last] = value
    return out


# ------------------------------------------------------------------------------- results
@EXAMPLES
@given(data=st.data())
def test_result_files(emps_files, data):
    """A result file with any key corrupted or removed: every command reading results."""
    log, result = emps_files
    path = data.draw(st.sampled_from(result_paths(result)), label="key")
    bad = corrupted(result, path, data.draw(json_values, label="value"), data.draw(st.booleans(), label="delete"))
    command = data.draw(st.sampled_from(["validate", "report", "export", "consistency", "compare"]), label="command")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        fit = tmp / "fit.json"
        fit.write_text(json.dumps(bad))  # NaN and Infinity as Python's JSON extensions
        other = tmp / "other.json"  # compare's second fit
        other.write_text(json.dumps(result))
        inputs = {"validate": [log, fit], "report": [log, fit], "compare": [fit, other]}.get(command, [fit])
        out = data.draw(st.sampled_from([tmp / "out.json", *inputs]), label="output")
        argv = {"validate": ["validate", log, "--params", fit, "--json", out],
                "report": ["report", fit, log, "--out", tmp / "report" if out.name == "out.json" else out],
                "export": ["export", fit, "--yaml", out, "--force"],
                "consistency": ["consistency", fit, "--json", out],
                "compare": ["compare", fit, other, "--json", out]}[command]
        check_run(argv, inputs, out)


# ------------------------------------------------------------------------- layouts, drives
def two_joint_log(scale: float) -> JointSeries:
    """2 s of two joints at 1 kHz: sines, efforts = viscous + Coulomb friction + inertia (× ``scale``)."""
    t = np.arange(2000) * 1e-3
    q = np.column_stack([0.5 * np.sin(2 * np.pi * 0.8 * t), 0.3 * np.sin(2 * np.pi * 1.3 * t + 0.4)])
    qd = np.gradient(q, t, axis=0)
    tau = scale * (2.0 * qd + 0.8 * np.sign(qd) + 0.1 * np.gradient(qd, t, axis=0))
    return JointSeries(t, ["a", "b"], q, tau, source="log")


LAYOUT = {"header": True, "time": {"column": "time", "scale": 1.0}, "joints": ["a", "b"],
          "position": ["a.position", "b.position"], "effort": ["a.effort", "b.effort"]}
DRIVE = {"name": "gear", "joints": ["a", "b"], "side": "motor", "gear_ratio": [10.0, -5.0], "effort_scale": [0.5, 2.0]}


def mutated(base: dict, keys: list[str], values: list) -> dict:
    out = dict(base)
    for key, value in zip(keys, values):
        out[key] = value
    return out


@EXAMPLES
@given(data=st.data())
def test_layouts_and_drives(data):
    """``identify`` of a CSV log read with a layout (keys mutated) and a drive (keys mutated)."""
    from frictionid_core.drive.transmission import DRIVE_KEYS
    from frictionid_core.io.layout import LAYOUT_KEYS

    layout_values = st.one_of(json_values, st.sampled_from(["time", "a.position", "b.effort", 0, 3, [1, 2], ";"]))
    n_layout = data.draw(st.integers(0, 2), label="layout changes")
    layout = mutated(LAYOUT, data.draw(st.lists(st.sampled_from(LAYOUT_KEYS), min_size=n_layout, max_size=n_layout),
                                       label="layout keys"),
                     data.draw(st.lists(layout_values, min_size=n_layout, max_size=n_layout), label="layout values"))
    drive_values = st.one_of(json_values, st.sampled_from([[1.0, 1.0], [0.0, 1.0], [[1, 0], [1, 1]], [[1, 1], [1, 1]],
                                                           "joint", "motor", ["a"]]))
    n_drive = data.draw(st.integers(0, 2), label="drive changes")
    drive = mutated(DRIVE, data.draw(st.lists(st.sampled_from(DRIVE_KEYS), min_size=n_drive, max_size=n_drive),
                                     label="drive keys"),
                    data.draw(st.lists(drive_values, min_size=n_drive, max_size=n_drive), label="drive values"))
    scale = data.draw(st.sampled_from([1.0, 1e6, 1e-12, -1.0, 0.0]), label="effort scale")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        log = tmp / "log.csv"
        save_csv(two_joint_log(scale), log)
        layout_file, drive_file = tmp / "layout.yaml", tmp / "drive.yaml"
        layout_file.write_text(yaml.safe_dump(layout))
        drive_file.write_text(yaml.safe_dump(drive))
        inputs = [log, layout_file, drive_file] if data.draw(st.booleans(), label="with drive") else [log, layout_file]
        out = data.draw(st.sampled_from([tmp / "out.json", *inputs]), label="output")
        argv = ["identify", log, "--layout", layout_file, "--system", "joint", "--json", out]
        if drive_file in inputs:
            argv += ["--drive", drive_file]
        check_run(argv, inputs, out)


# ---------------------------------------------------------------------------------- bags
def bag_series(n: int, joints: int, rate: float, amplitude: float, effort_scale: float, jitter: float,
               seed: int) -> JointSeries:
    """``n`` JointState samples of ``joints`` joints at ``rate`` Hz: sines of ``amplitude`` with a
    little noise, efforts (× ``effort_scale``) leading them; stamps jittered by ``jitter`` periods
    (over 1: some go back)."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(np.full(n, 1.0 / rate) * (1.0 + jitter * rng.uniform(-1.0, 1.0, n)))
    phase = 2 * np.pi * 3.0 * t[:, None] + np.arange(joints)
    q = amplitude * np.sin(phase) + 1e-6 * rng.standard_normal((n, joints))
    tau = effort_scale * (np.cos(phase) + 0.01 * rng.standard_normal((n, joints)))
    return JointSeries(t - t[0] + 1.0, [f"j{k}" for k in range(joints)], q, tau, source="bag")


@EXAMPLES
@given(n=st.sampled_from([3000, 300, 40, 13, 12, 5, 3]), joints=st.integers(1, 2), rate=st.sampled_from([1000.0, 50.0]),
       amplitude=st.sampled_from([1.0, 1e-3, 1e6, 1e-9]), effort_scale=st.sampled_from([1.0, 1e9, 0.0]),
       jitter=st.sampled_from([0.0, 0.3, 2.0]), system=st.sampled_from(["joint", "friction-only", "emps"]),
       seed=st.integers(0, 3), output_is_input=st.booleans())
def test_small_bags(emps_files, n, joints, rate, amplitude, effort_scale, jitter, system, seed, output_is_input):
    """``identify`` a small JointState bag (few samples, tiny or huge values, jittered or
    disordered stamps), then ``validate`` its fit (or, when it failed, an EMPS fit) on it."""
    series = bag_series(n, joints, rate, amplitude, effort_scale, jitter, seed)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        bag = write_joint_state_bag(tmp / "bag", series)
        storage = next(bag.glob("*.mcap"))
        fit = tmp / "fit.json"
        code = check_run(["identify", bag, "--system", system, "--json", storage if output_is_input else fit],
                         [bag], storage if output_is_input else fit)
        if output_is_input or code != 0:
            fit.write_text(json.dumps(emps_files[1]))
        out = fit if output_is_input else tmp / "validation.json"
        check_run(["validate", bag, "--params", fit, "--json", out], [bag, fit], out)
