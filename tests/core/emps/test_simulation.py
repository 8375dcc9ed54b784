"""EMPS closed-loop simulation (docs/reference.md#emps-simulation) on the bundled bags.

Reference figures: docs/reference.md#emps-idim-ls parameters; thesis Table 6.12 (benchmark clock);
docs/reference.md#emps-simulation (true clock); benchmark script (velocity 0.229 %, acceleration 8.60 %, force 5.85 %).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from frictionid_core.cli import build_parser
from frictionid_core.emps.simulation import (
    METRIC_KEYS,
    EmpsData,
    EmpsSimulator,
    load_emps,
    simulate_emps,
    simulate_identification,
)
from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.timeseries import JointSeries

BAGS = Path(__file__).resolve().parents[3] / "bags"
REF = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "offset": -3.1648}
REF_ASYM = {"M": 95.1540, "Fv_pos": 166.7061, "Fc_pos": 20.1440, "Fv_neg": 240.4236, "Fc_neg": 20.6277}
# t(10) − t(9) of the MAT files; the bags' stamps are rounded to 1 ns, which moves it by 4e-11 s
TEC = {"estimation": 9.99983961121758e-4, "validation": 1.0000080189889668e-3}


@pytest.fixture(scope="module")
def runs():
    return {"estimation": load_emps(BAGS / "emps_estimation"), "validation": load_emps(BAGS / "emps_validation")}


def test_bag_signals(runs):
    est, val = runs["estimation"], runs["validation"]
    assert est.pulses is None and val.pulses is not None
    assert set(np.unique(val.pulses)) == {0.0, 5.0}
    assert est.qg.size == est.t.size == 24841
    assert (est.gtau, est.kp, est.kv) == pytest.approx((35.15065188248547, 160.18, 243.45))


def test_benchmark_clock_reference(runs):
    """Benchmark clock, reference parameters, period from the bag stamps."""
    est = simulate_emps(runs["estimation"], REF, clock="benchmark").metrics
    val = simulate_emps(runs["validation"], REF, clock="benchmark").metrics
    assert est["position_relerr_pct"] == pytest.approx(0.01375, abs=3e-4)
    assert val["position_relerr_pct"] == pytest.approx(0.0080, abs=3e-4)
    assert est["velocity_relerr_pct"] == pytest.approx(0.229, rel=0.1)
    assert est["acceleration_relerr_pct"] == pytest.approx(8.60, rel=0.1)
    assert est["force_relerr_pct"] == pytest.approx(5.85, rel=0.1)


@pytest.mark.parametrize("params, asym, expected", [
    (REF, False, {"estimation": 0.013752, "validation": 0.0080248}),
    (REF_ASYM, True, {"estimation": 0.013769, "validation": 0.0079575}),
])
def test_benchmark_clock_reproduces_thesis(runs, params, asym, expected):
    """With the MAT files' tec the bags give the thesis' Table 6.12 to its printed digits (±1e-6 %)."""
    for run, value in expected.items():
        m = simulate_emps(runs[run], params, "coulomb", asym, clock="benchmark", tec=TEC[run]).metrics
        assert m["position_relerr_pct"] == pytest.approx(value, abs=1e-6), run


def test_true_clock_reference(runs):
    est = simulate_emps(runs["estimation"], REF).metrics
    val = simulate_emps(runs["validation"], REF, clock="true").metrics
    assert est["position_relerr_pct"] == pytest.approx(0.0017, abs=2e-4)
    assert val["position_relerr_pct"] == pytest.approx(0.0027, abs=2e-4)


def test_population_of_identical_sets_equals_single(runs):
    sim = EmpsSimulator(runs["validation"], "coulomb", clock="benchmark")
    one = sim.simulate(REF)
    many = sim.simulate(np.repeat(sim.as_array(REF), 20, axis=0))
    for name in ("q", "velocity", "acceleration", "voltage", "force"):
        assert np.array_equal(getattr(many, name), np.broadcast_to(getattr(one, name), (20, one.t.size))), name
    for key in METRIC_KEYS:
        assert np.all(many.metrics[key] == one.metrics[key])


@pytest.mark.parametrize("friction, asym",
                         [("coulomb", False), ("coulomb", True), ("tustin", False), ("stribeck", True)])
def test_population_members_equal_individual_runs(runs, friction, asym):
    sim = EmpsSimulator(runs["validation"], friction, asym)
    base = {"M": 95.0, "Fv": 200.0, "Fc": 20.0, "Fs": 25.0, "vs": 0.005, "delta": 1.5, "offset": -3.0}
    x = np.array([base[n.removesuffix("_pos").removesuffix("_neg")] for n in sim.names])
    rng = np.random.default_rng(3)
    pop = x * (1.0 + 0.2 * rng.uniform(-1, 1, (17, x.size)))  # 17: several chunks, a ragged one
    pop[5, 0] = 1e-3  # a mass this small makes the loop unstable: NaN for that member only
    batch = sim.simulate(pop)
    cost = sim.position_cost(pop)
    assert np.isnan(batch.q[5, -1]) and np.isnan(cost[5])
    for i in (0, 4, 6, 16):
        alone = sim.simulate(pop[i])
        assert np.array_equal(batch.q[i], alone.q)
        assert np.array_equal(batch.force[i], alone.force)
        for key in METRIC_KEYS:
            assert batch.metrics[key][i] == alone.metrics[key]
        assert sim.position_relerr(pop[i : i + 1])[0] == pytest.approx(alone.metrics["position_relerr_pct"], rel=1e-12)
    assert np.all(np.isfinite(np.delete(cost, 5)))


def test_coulomb_fast_path_equals_general_path(runs):
    """Coulomb (no dip) runs the kernel's select-only loop; Tustin with Fs = Fc is the same friction
    through the dip path."""
    coulomb = simulate_emps(runs["estimation"], REF, clock="benchmark")
    tustin = simulate_emps(runs["estimation"], dict(REF, Fs=REF["Fc"], vs=0.01), "tustin", clock="benchmark")
    np.testing.assert_allclose(tustin.q, coulomb.q, rtol=0, atol=1e-15)


def test_result_shapes_and_names(runs):
    sim = EmpsSimulator(runs["estimation"], "stribeck", True, substeps=2)
    assert sim.names == ("M", "Fv_pos", "Fc_pos", "Fs_pos", "vs_pos", "delta_pos",
                         "Fv_neg", "Fc_neg", "Fs_neg", "vs_neg", "delta_neg")
    r = sim.simulate(np.tile([95.0, 170, 20, 22, 0.005, 1.5, 240, 20, 22, 0.005, 1.5], (3, 1)))
    assert r.q.shape == r.force.shape == (3, runs["estimation"].t.size)
    assert all(r.metrics[k].shape == (3,) for k in METRIC_KEYS)
    assert sim.position_residuals(r.params[0]).shape == (runs["estimation"].t.size - 49,)
    with pytest.raises(FrictionIdError, match="takes 11 parameters"):
        sim.simulate(np.ones(4))
    with pytest.raises(FrictionIdError, match="missing"):
        sim.simulate({"M": 95.0})
    with pytest.raises(FrictionIdError, match="unknown clock"):
        EmpsSimulator(runs["estimation"], clock="wall")


def test_series_without_reference_is_rejected():
    t = np.arange(100) * 1e-3
    series = JointSeries(t, ["emps"], np.zeros(100), np.zeros(100), meta={"gtau": 35.0, "kp": 160.0, "kv": 243.0})
    with pytest.raises(InputError, match="qg"):
        EmpsData.from_series(series)


@pytest.mark.slow
def test_identify_result_and_cli(runs, tmp_path, capsys):
    result = {"system": "emps", "friction": "coulomb", "asymmetric": False, "params": REF}
    sim = simulate_identification(runs["estimation"], result, clock="benchmark")
    assert sim.metrics["position_relerr_pct"] == pytest.approx(0.01375, abs=3e-4)

    parser, handlers = build_parser(["simulate"])
    handler = handlers["simulate"]
    params = tmp_path / "r.json"
    params.write_text(json.dumps(result))
    out = tmp_path / "s.json"
    args = parser.parse_args(["simulate", "emps", "--params", str(params), "--data", str(BAGS / "emps_validation"),
                              "--clock", "benchmark", "--json", str(out)])
    assert handler(args) == 0
    printed = capsys.readouterr().out
    assert "clock benchmark" in printed and "position" in printed
    saved = json.loads(out.read_text())
    assert saved["metrics"]["clock"] == "benchmark"
    assert set(METRIC_KEYS) <= set(saved["metrics"])
    assert saved["metrics"]["position_relerr_pct"] == pytest.approx(0.0080, abs=3e-4)
    args = parser.parse_args(["simulate", "emps", "--params", str(params), "--data", str(BAGS / "emps_validation")])
    assert handler(args) == 0 and "clock true" in capsys.readouterr().out
