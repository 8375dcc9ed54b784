"""``frictionid compare`` (two or more fits, truth optional) and ``frictionid report`` on any result and source."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.compare import compare_fits
from frictionid_core.errors import FrictionIdError
from frictionid_core.identification import IdentifyRequest, PreprocessingOverrides, identify
from frictionid_core.io import load
from frictionid_core.preprocess import Preprocessing
from support.data import BAGS, EMPS_ESTIMATION, emps_like


def _write(path, data) -> str:
    path.write_text(json.dumps(data))
    return str(path)


# ------------------------------------------------------------------------------ compare
@pytest.fixture(scope="module")
def emps_fits(emps_estimation):
    """EMPS Coulomb by least squares (the demo) and Tustin by lm on the bundled estimation bag."""
    coulomb = identify(emps_estimation, IdentifyRequest(system="emps", friction="coulomb", solver="ls")).to_dict()
    tustin = identify(emps_estimation, IdentifyRequest(system="emps", friction="tustin", solver="lm")).to_dict()
    return coulomb, tustin


def test_compare_two_emps_fits_side_by_side(emps_fits):
    coulomb, tustin = emps_fits
    out = compare_fits([coulomb, tustin], ["coulomb.json", "tustin.json"])
    assert [f["label"] for f in out["fits"]] == ["A", "B"]
    assert [f["file"] for f in out["fits"]] == ["coulomb.json", "tustin.json"]
    for name in ("M", "Fv", "Fc", "offset"):
        row = out["parameters"][name]
        diff = tustin["params"][name] - coulomb["params"][name]
        assert row["values"] == {"A": coulomb["params"][name], "B": tustin["params"][name]}
        assert row["difference"]["B"] == pytest.approx(diff, rel=1e-12)
        assert row["z"]["B"] == pytest.approx(diff / np.hypot(coulomb["std"][name], tustin["std"][name]), rel=1e-12)
    # Tustin's static level and Stribeck velocity exist in B only: no value, no difference for A
    assert out["only_in"] == {"Fs": ["B"], "vs": ["B"]}
    assert out["parameters"]["Fs"]["values"]["A"] is None and out["parameters"]["Fs"]["difference"]["B"] is None
    # the settings that differ, and only those (same system, same data, same pre-processing)
    assert out["settings"]["friction"] == {"A": "coulomb", "B": "tustin"}
    assert out["settings"]["solver"] == {"A": "ls", "B": "lm"}
    assert not any(k.startswith(("system", "source", "preprocessing")) for k in out["settings"])
    # the demo figure, side by side with Tustin's (a better fit: it nests Coulomb)
    relerr = out["metrics"]["relerr_pct"]
    assert round(relerr["A"], 5) == 4.08336
    assert relerr["B"] < relerr["A"]


def test_compare_cli_two_fits_and_their_validation(emps_fits, tmp_path, capsys):
    a, b = _write(tmp_path / "a.json", emps_fits[0]), _write(tmp_path / "b.json", emps_fits[1])
    code = main(["compare", a, b, "--validation", str(BAGS / "emps_validation"), "--json", str(tmp_path / "c.json")])
    text = capsys.readouterr().out
    assert code == 0
    assert f"A: {a} · emps · coulomb · solver ls" in text and f"B: {b} · emps · tustin · solver lm" in text
    assert "Fs: only in B" in text and "friction" in text
    saved = json.loads((tmp_path / "c.json").read_text())
    assert set(saved["parameters"]) == {"M", "Fv", "Fc", "offset", "Fs", "vs"}
    (val,) = saved["validation"]
    # the demo's cross-test figure (README: validate on bags/emps_validation)
    assert round(val["fits"]["A"]["relerr_pct"], 5) == 5.98245
    assert f"relerr_pct A {val['fits']['A']['relerr_pct']:.6g}, B {val['fits']['B']['relerr_pct']:.6g}" in text


def test_compare_per_joint_metrics_and_settings_of_nested_keys():
    """Per-joint metrics (``metrics.per_joint``) and nested settings (pre-processing) are compared key by key."""
    base = {"system": "joint", "friction": "coulomb", "asymmetric": False, "solver": "ls", "joints": ["j1", "j2"],
            "preprocessing": {"cutoff_hz": 12.0, "decimate": 5}}
    a = dict(base, params={"j1/Fc": 1.0, "j2/Fc": 2.0}, std={"j1/Fc": 0.3, "j2/Fc": 0.1},
             metrics={"relerr_pct": 5.0, "per_joint": {"j1": {"relerr_pct": 4.0, "rmse": 0.1, "r2": 0.99},
                                                        "j2": {"relerr_pct": 6.0, "rmse": 0.2, "r2": 0.98}}})
    b = dict(base, preprocessing={"cutoff_hz": 20.0, "decimate": 5}, params={"j1/Fc": 1.4, "j2/Fc": 2.0},
             std={"j1/Fc": 0.4}, metrics={"relerr_pct": 4.0, "per_joint": {"j1": {"relerr_pct": 3.0}}},
             warnings=["j1/Fc: σ > |value|"])
    out = compare_fits([a, b])
    assert out["settings"] == {"preprocessing.cutoff_hz": {"A": 12.0, "B": 20.0}}
    assert out["parameters"]["j1/Fc"]["z"]["B"] == pytest.approx(0.4 / 0.5)  # 0.4 / √(0.3² + 0.4²)
    assert out["parameters"]["j2/Fc"]["z"]["B"] is None  # B has no σ for it
    assert out["per_joint"]["j1"]["relerr_pct"] == {"A": 4.0, "B": 3.0}
    assert out["per_joint"]["j2"]["rmse"] == {"A": 0.2, "B": None}
    assert out["metrics"] == {"relerr_pct": {"A": 5.0, "B": 4.0}}  # per_joint is not a scalar metric
    assert out["fits"][1]["warnings"] == ["j1/Fc: σ > |value|"]


def saved_cov(folder, kind: str = "") -> str:
    hit, n = json.loads((folder / "c.json").read_text())["summary"][f"coverage{kind}"]
    return f"{hit} of {n}"


def test_compare_with_truth_keeps_its_output(tmp_path, capsys):
    """One fit + --truth (+ --validation): the ground-truth table, the summary lines and the noise-floor line
    as before, and the JSON keys parameters / summary / validation."""
    series = load(BAGS / "tx40_j2_excitation", joints=["joint_2"])
    r = _write(tmp_path / "r.json", identify(series, IdentifyRequest(system="tx40-j2")).to_dict())
    truth = str(BAGS / "tx40_truth.json")
    code = main(["compare", r, "--truth", truth, "--validation", str(BAGS / "tx40_j2_validation"),
                 "--json", str(tmp_path / "c.json")])
    lines = capsys.readouterr().out.splitlines()
    assert code == 0
    assert lines[0] == f"{r} vs truth ({truth})"
    assert lines[1] == (f"{'parameter':<22} {'estimate':>12} {'truth':>12} {'error %':>9} {'σ %':>9} {'err/σ':>7}"
                        f" {'robust σ':>10}  determined  1.96σ covers (σ, calibrated)")
    assert [ln.split()[0] for ln in lines[2:8]] == ["ZZ", "MX", "MY", "Fv", "Fc", "offset"]
    assert lines[8].startswith("6 of 6 parameters determined") or " of 6 parameters determined (σ < 1 % " in lines[8]
    assert " of 6 resolvable to 5 % (1.96 σ < 5 % of |truth|)" in lines[9]
    cal = json.loads((tmp_path / "c.json").read_text())["summary"]["coverage_calibrated"]
    assert cal["sigma"] == "std_robust" and f"{cal['covered']} of {cal['identified']}" == saved_cov(tmp_path, "_robust")
    assert lines[10] == ("coverage (identified parameters whose |error| ≤ 1.96 σ; about 95 % when σ is honest): "
                         f"calibrated σ (std_robust) {saved_cov(tmp_path, '_robust')} "
                         f"({100 * cal['share']:.0f} %); white-noise σ (std) {saved_cov(tmp_path)}")
    assert lines[11].startswith(f"validation {BAGS / 'tx40_j2_validation'}: OSA relative error ")
    assert len(lines) == 12
    saved = json.loads((tmp_path / "c.json").read_text())
    assert set(saved) == {"parameters", "summary", "validation"}
    assert set(saved["validation"]) == {"relerr_pct", "floor_relerr_pct", "ratio", "source"}
    # the ratio of the fit's validation error to the true parameters' (the Coulomb fit's 0.9998: the rows it
    # keeps at the folds' 21.5 Hz hold little of the truth's Stribeck dip)
    val = saved["validation"]
    assert val["ratio"] == pytest.approx(val["relerr_pct"] / val["floor_relerr_pct"], rel=1e-9)
    assert 0.95 < val["ratio"] < 1.5


def test_compare_reports_bad_files_in_one_line(emps_fits, tmp_path, capsys):
    a = _write(tmp_path / "a.json", emps_fits[0])
    truth = str(BAGS / "tx40_truth.json")
    tx40_j2 = _write(tmp_path / "j2.json", dict(emps_fits[0], system="tx40-j2", params={"ZZ": 1.0}, std={}))
    cases = [
        ([a], "needs two or more fits, or one fit and --truth"),
        ([a, truth], "a ground truth ('frictionid synth --truth'), not an identification result (compare takes it "
                     "with --truth)"),
        ([a, "--truth", a], "an identification result, not a ground truth"),
        ([a, tx40_j2], "share no parameter"),
        ([a, _write(tmp_path / "junk.json", {"params": {"M": "heavy"}, "system": "emps", "friction": "coulomb",
                                              "asymmetric": False})],
         "junk.json: key 'params.M' must be a number, got 'heavy'"),
        ([a, _write(tmp_path / "list.json", {"results": []})], "not an identification result"),
        ([a, "--truth", truth], "no truth for 'emps_estimation'"),  # the truth's recordings are the TX40 bags
        ([tx40_j2, "--truth", truth, "--bag", "tx40_excitation"], "joint 2 was not the only joint moving"),
        ([_write(tmp_path / "j9.json", dict(emps_fits[0], system="tx40", joints=["joint_9"], params={"x": 1.0})),
          "--truth", truth, "--bag", "tx40_excitation"], "the truth does not describe this result"),
    ]
    for argv, message in cases:
        assert main(["compare", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert message in err and "internal error" not in err and err.count("\n") == 1, (argv, err)


@pytest.fixture(scope="module")
def tx40_validation():
    return load(BAGS / "tx40_validation")


@pytest.fixture(scope="module")
def tx40_fit(tx40_validation):
    """A quick least-squares Coulomb fit of the full TX40 on the bundled validation bag."""
    return identify(tx40_validation, IdentifyRequest(system="tx40", friction="coulomb", solver="ls")).to_dict()


@pytest.mark.slow
def test_compare_two_tx40_fits_with_truth(tx40_validation, tx40_fit, tmp_path, capsys):
    """The TX40 fitted with the position cut-off chosen from its data and with a 25 Hz one (the other
    settings as chosen): the cut-off is the one setting listed; with --truth each fit gets its own
    ground-truth table, consistent with the differences."""
    chosen = Preprocessing.from_dict(tx40_fit["preprocessing"])
    lower = identify(tx40_validation, IdentifyRequest(
        system="tx40", preprocessing=replace(PreprocessingOverrides.from_settings(chosen), cutoff_hz=25.0))).to_dict()
    a, b = _write(tmp_path / "a.json", tx40_fit), _write(tmp_path / "b.json", lower)
    code = main(["compare", a, b, "--truth", str(BAGS / "tx40_truth.json"), "--json", str(tmp_path / "c.json")])
    text = capsys.readouterr().out
    assert code == 0
    saved = json.loads((tmp_path / "c.json").read_text())
    assert list(saved["parameters"]) == list(tx40_fit["params"]) and saved["only_in"] == {}
    per_joint = {f"preprocessing.cutoff_hz.{j}": {"A": fc, "B": 25.0} for j, fc in chosen.cutoff_hz.items()}
    assert saved["settings"] == per_joint
    assert text.count(" vs truth (") == 2 and "preprocessing.cutoff_hz" in text
    truth = saved["truth"]
    for name, row in saved["parameters"].items():
        # B − A is the difference of the two fits' errors against the same truth
        if name in truth["A"]["parameters"]:
            errors = truth["B"]["parameters"][name]["error"] - truth["A"]["parameters"][name]["error"]
            assert row["difference"]["B"] == pytest.approx(errors, rel=1e-9, abs=1e-12), name
    # the viscous friction of the six joints: within 5 % of the truth in both fits
    for label in ("A", "B"):
        for k in range(1, 7):
            assert abs(truth[label]["parameters"][f"joint_{k}/Fv"]["relerr_pct"]) < 5.0, (label, k)


# ------------------------------------------------------------------------------- report
def _png_is_drawn(path) -> bool:
    import matplotlib.image

    pixels = matplotlib.image.imread(str(path))
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and pixels.shape[0] > 300 and float(pixels.std()) > 0.05


def test_report_measured_friction_is_the_identified_law_on_noise_free_data(tmp_path):
    """Recorded effort − rigid-body part − offset is the friction; on noise-free data without decimation
    it lies on the identified law (fit RMSE 0.002 N; within 0.05 N of Fc = 20 N), the model matches
    the recorded effort, and several sources each get their figure and metrics."""
    from frictionid_core.reports.result_report import build_fit_report, joint_traces

    est, val = emps_like(), emps_like(n=2500, joint="emps")
    settings = PreprocessingOverrides(cutoff_hz=100.0, decimate=1, trim_start_s=0.05, trim_end_s=0.05, min_speed=0.0,
                                      metric="recorded")
    result = identify(est, IdentifyRequest(system="emps", preprocessing=settings)).to_dict()
    (trace,), _, friction = joint_traces(val, result)
    law = friction.torque(trace.friction_params, trace.velocity)
    assert np.max(np.abs(trace.friction - law)) < 0.05
    assert trace.t[0] == pytest.approx(50e-3) and trace.excluded == 0
    rep = build_fit_report(result, [("estimation", est), ("validation", val)], tmp_path / "out", "r.json")
    assert [s["role"] for s in rep["sources"]] == ["estimation", "validation"]
    # no decimation, no excluded row: the report's error vs the recorded effort is the fit's own
    assert rep["sources"][0]["metrics"]["relerr_pct"] == pytest.approx(result["metrics"]["relerr_pct"], rel=1e-9)
    assert rep["sources"][1]["per_joint"]["emps"]["relerr_pct"] < 0.01
    for s in rep["sources"]:
        assert _png_is_drawn(tmp_path / "out" / s["figures"]["emps"])
        assert _png_is_drawn(tmp_path / "out" / s["reversal_figures"]["emps"])  # a reversal, every row
        assert s["all_rows"]["samples"] == s["metrics"]["samples"]  # min speed 0: every row is fitted
    page = (tmp_path / "out" / "report.html").read_text()
    assert page.count("<img ") == 4 and "r.json" in page and "Fc" in page


def test_report_rows_left_out_by_the_system_are_not_shown(tmp_path):
    """tx40-j2 leaves out rows slower than its min_speed: the report neither plots nor counts them."""
    from frictionid_core.reports.result_report import joint_traces

    series = load(BAGS / "tx40_j2_validation", joints=["joint_2"])
    result = identify(series, IdentifyRequest(system="tx40-j2", friction="coulomb", solver="ls")).to_dict()
    (trace,), _, _ = joint_traces(series, result)
    assert trace.excluded > 0
    assert np.min(np.abs(trace.velocity)) >= result["preprocessing"]["min_speed"]["joint_2"]
    assert trace.t.size == result["metrics"]["samples"]
    # a source where the joint stands still: no figure, the page says why
    from frictionid_core.reports import build_fit_report
    from frictionid_core.timeseries import JointSeries

    still = JointSeries(series.t, ["joint_2"], np.full_like(series.position, 0.3), series.effort, source="still")
    rep = build_fit_report(result, [("validation", still)], tmp_path)
    assert rep["sources"][0]["figures"] == {} and rep["sources"][0]["per_joint"]["joint_2"]["samples"] == 0
    assert "No row faster than the system's minimum speed" in (tmp_path / "report.html").read_text()


@pytest.mark.slow
def test_report_cli_on_a_robot_bag(tx40_fit, tmp_path, capsys):
    """The TX40 fit on its bag: one PNG per joint (drawn), the page names every joint, report.json has the
    per-joint metrics; the report's overall error (the recorded effort at the analysis instants) is
    the fit's own."""
    r = _write(tmp_path / "r.json", tx40_fit)
    out = tmp_path / "report"
    assert main(["report", r, str(BAGS / "tx40_validation"), "--out", str(out)]) == 0
    assert f"report: {out / 'report.html'}" in capsys.readouterr().out
    saved = json.loads((out / "report.json").read_text())
    (source,) = saved["sources"]
    joints = tx40_fit["joints"]
    assert list(source["figures"]) == joints and list(source["per_joint"]) == joints
    page = (out / "report.html").read_text()
    for joint in joints:
        assert f"<h3>{joint}</h3>" in page
        assert _png_is_drawn(out / source["figures"][joint])
        assert 0.0 < source["per_joint"][joint]["relerr_pct"] < 5.0
    assert source["metrics"]["relerr_pct"] == pytest.approx(tx40_fit["metrics"]["relerr_pct"], rel=1e-9)


def test_report_cli_errors_in_one_line(tmp_path, capsys):
    r = _write(tmp_path / "r.json", {"system": "emps", "friction": "coulomb"})
    cases = [
        (["report", r, str(EMPS_ESTIMATION), "--out", str(tmp_path / "o")], "not an identification result"),
        (["report", r, "--out", str(tmp_path / "o")], "no source to show"),
        (["report", "emps", str(EMPS_ESTIMATION), "--out", str(tmp_path / "o")], "'frictionid report emps' takes"),
        (["report", r, str(EMPS_ESTIMATION), "--study", str(tmp_path), "--out", str(tmp_path / "o")],
         "belong to 'frictionid report emps'"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, (argv, err)


def test_report_refuses_a_result_missing_parameters(emps_estimation, tmp_path):
    from frictionid_core.reports import build_fit_report

    result = identify(emps_estimation, IdentifyRequest(system="emps", friction="coulomb", solver="ls")).to_dict()
    del result["params"]["Fc"]
    with pytest.raises(FrictionIdError, match=r"lacks parameter\(s\) \['Fc'\]"):
        build_fit_report(result, [("estimation", emps_estimation)], tmp_path)
