"""A fast fixed-seed subset of the randomized accuracy corpus (bench/accuracy.py) through the real CLI.

Four short cases (12 s + 8 s logs at ≤ 200 Hz), each with its labels fixed: a UR5 with Coulomb friction and
white noise, a one-joint system with gravity and Stribeck friction under coloured noise (a CSV + layout),
a Panda in MuJoCo (damping, frictionloss, armature) with quantised encoders written as an MCAP bag, and a
one-joint LuGre system in micro-motions. The bounds are loose against what the product scores today on
these cases (in brackets; the floor of the rows validate compares); the JSON's structure, internal errors
and tracebacks are checked exactly.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench" / "accuracy.py"
CASES = {
    201: "arm=ur5,law=coulomb,noise=white,excitation=fourier,format=csv",
    202: "arm=joint_gravity,law=stribeck,noise=coloured,excitation=plateaus,format=layout",
    203: "arm=panda,law=mujoco,noise=quantised,excitation=fourier,format=mcap",
    204: "arm=joint,law=lugre,noise=white,excitation=micro,format=csv",
}
SUMMARY_KEYS = {"val_within_1.2_floor", "friction_err_median_pct", "friction_err_p90_pct", "coverage_1.96",
                "internal_errors", "tracebacks", "per_class", "val_vs_ls_within_1.05"}
CASE_KEYS = {"sub_seed", "labels", "truth", "commands", "runs", "warnings", "status", "val_relerr_pct", "floor_pct",
             "product_noise_floor_pct", "floor_ratio", "baseline_relerr_pct", "ls_ratio", "params", "coverage",
             "internal_error", "traceback", "reproduce", "floor_pct_baseline_rows", "product_rows"}


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    out = tmp_path_factory.mktemp("accuracy") / "accuracy.json"
    cmd = [sys.executable, str(BENCH), "--quick", "--no-diagnostic", "--workers", "2", "--json", str(out)]
    for seed, labels in CASES.items():
        cmd += ["--case-seed", f"{seed}:{labels}"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    data = json.loads(out.read_text())
    return data, {c["sub_seed"]: c for c in data["cases"]}, proc.stdout


def test_structure(corpus):
    data, cases, stdout = corpus
    assert data["seed"] is None and data["sub_seeds"] == list(CASES)
    summary = data["summary"]
    assert SUMMARY_KEYS <= set(summary)
    dims = {row["dimension"] for row in summary["per_class"]}
    assert {"arm", "law", "noise", "excitation"} <= dims
    for row in summary["per_class"]:
        assert SUMMARY_KEYS - {"per_class"} <= set(row)
    assert summary["bench_errors"] == 0
    for seed, c in cases.items():
        assert CASE_KEYS <= set(c), seed
        assert c["status"] == "ok", (seed, c.get("runs"))
        assert c["reproduce"].startswith(f"python bench/accuracy.py --case-seed {seed}:")
        assert c["runs"]["identify"]["exit_code"] == 0 and c["runs"]["validate"]["exit_code"] == 0
        assert any(cmd.split()[1:2] == ["identify"] for cmd in c["commands"])
        # the floor is taken on the rows validate compares (--residuals), each instant on its own log sample:
        # the product's clock and the log's agree (a bag's from its first message, a CSV's stamps or rate)
        assert c["product_rows"]["max_offset_periods"] <= 0.5, seed
        assert c["floor_pct"] == c["product_rows"]["floor_pct"] > 0, seed
        assert c["ls_ratio_same_rows"] == pytest.approx(c["val_relerr_pct"] / c["product_rows"]["baseline_relerr_pct"])
    assert "dimension" in stdout and "bench errors" in stdout  # the table


def test_no_internal_errors_or_tracebacks(corpus):
    data, cases, _ = corpus
    assert data["summary"]["internal_errors"] == 0
    assert data["summary"]["tracebacks"] == 0
    assert not any(c["internal_error"] or c["traceback"] for c in cases.values())


def test_cli_given_only_what_a_user_must_give(corpus):
    _, cases, _ = corpus
    ur5, joint_g, panda, lugre = (cases[k]["runs"]["identify"]["command"] for k in CASES)
    assert "--system urdf:" in ur5 and "--friction" not in ur5 and "--hold-missing" not in ur5
    assert "--system joint --gravity" in joint_g and "--friction stribeck" in joint_g and "--layout" in joint_g
    assert "--hold-missing" in panda and "--friction" not in panda  # the fingers are not in the log
    assert "--system joint" in lugre and "--gravity" not in lugre and "--friction lugre" in lugre


def test_accuracy_bounds(corpus):
    """Validation within a factor of the noise floor, friction and the one-joint rigid body near the truth."""
    data, cases, _ = corpus
    ur5, joint_g, panda, lugre = (cases[k] for k in CASES)
    # UR5, Coulomb, white noise [ratio to the floor 1.01, to the LS baseline 1.00, friction within 15 %]
    assert ur5["floor_ratio"] < 1.3 and ur5["ls_ratio"] < 1.25
    assert max(ur5["friction_err_pct"]) < 30.0
    assert ur5["coverage"][0] >= 0.6 * ur5["coverage"][1]
    # one joint + gravity at 81 Hz, Stribeck, coloured noise [ratio 4.30; J, Fs within 2 %, g within 11.3 %]:
    # validate keeps the identification's cut-off, the folds' 10 Hz. The dip rule raised it to 16 Hz (ratio
    # 2.2, g within 5 %) while the filter's ringing after each stop stayed in the fit (its ±Fs sharpened the
    # first fit's dip); left out as brief motion, the first fit's dip asks no higher rate — a case the
    # brief rows cost, where a fresh 40-case seed gained (71913: within the floor 0.575 → 0.625).
    # Cross-validating that cut-off with the fit's dip gave 1.95 here but made ten fresh Stribeck cases
    # worse (seed 4711: within the floor 4 → 2, friction median 1.7 → 4.8 %): not taken.
    assert joint_g["floor_ratio"] < 5.0
    for name, bound in (("J", 10.0), ("Fs", 10.0), ("g_sin", 15.0), ("g_cos", 15.0)):
        assert abs(joint_g["params"][name]["err_pct"]) < bound, name
    # Panda in MuJoCo, quantised encoders [ratio 1.01, to the LS baseline 0.99; Fc of joints 1–6 within 7.7 %;
    # 17 % while the bench left MuJoCo's friction loss soft, below its level on light joints]
    assert panda["floor_ratio"] < 1.6 and panda["ls_ratio"] < 1.2
    for k in range(1, 7):
        assert abs(panda["params"][f"panda_joint{k}/Fc"]["err_pct"]) < 15.0, k
    # one joint, LuGre in micro-motions [ratio 1.63; Fv, Fc, Fs, σ0, J within 1.2 %]
    assert lugre["floor_ratio"] < 3.5
    for name in ("Fv", "Fc", "Fs", "sigma0", "J"):
        assert abs(lugre["params"][name]["err_pct"]) < 6.0, name
    # the pooled Coulomb/Stribeck/MuJoCo friction errors [median 1.5 %]
    assert data["summary"]["friction_err_median_pct"] < 8.0


def one_case(tmp_path, sub_seed: int) -> dict:
    """The record of the full-length corpus case ``sub_seed`` (bench/accuracy.py --case-seed)."""
    out = tmp_path / "case.json"
    cmd = [sys.executable, str(BENCH), "--case-seed", str(sub_seed), "--no-diagnostic", "--workers", "1",
           "--json", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(out.read_text())["cases"][0]


def test_a_stop_rings_no_stribeck_friction_into_the_validation(tmp_path):
    """A full-length corpus case (one joint + gravity at 1259 Hz, Stribeck, trapezoid moves with dwells):
    after each stop the 14.7 Hz filter rings, and a lobe of its velocity crosses the min speed for two
    rows — a ±Fs the joint at rest does not have. Left out as brief motion, the cross-test reaches the
    noise floor [1.00 × the floor; 8.4 × with those rows] and the Stribeck parameters the truth."""
    case = one_case(tmp_path, 913802074)
    assert case["labels"]["law"] == "stribeck" and case["labels"]["excitation"] == "trapezoid"
    assert case["floor_ratio"] < 1.2
    for name in ("Fc", "Fs", "vs", "J"):
        assert abs(case["params"][name]["err_pct"]) < 3.0, name


def test_a_lugre_fit_of_micro_motions_starts_where_the_law_predicts_best(tmp_path):
    """A full-length corpus case (one joint at 748 Hz, LuGre, 0.1–3 mrad motions, the effort logged
    reversed, noise 8 % of the torque): the folds' Coulomb model scores 1 Hz best — it smooths away the
    micro-motions it cannot model — and the LuGre fit from there validates at 8.2 × the floor with Fs
    75 × off. The fit from the rule's 8.8 Hz predicts every row of the log better (all rows 9.5 % against
    30 %), so it is taken [1.19 × the floor; every parameter within 6.5 %, each covered by 1.96 σ]."""
    case = one_case(tmp_path, 770775335)
    assert case["labels"]["law"] == "lugre" and case["labels"]["excitation"] == "micro"
    assert case["reversed"]["fixed"]
    assert case["floor_ratio"] < 1.4
    for name in ("Fc", "Fs", "vs", "sigma0", "J"):
        assert abs(case["params"][name]["err_pct"]) < 10.0, name


def test_the_cutoffs_of_a_stribeck_arm_are_judged_with_its_low_speed_friction(tmp_path):
    """A full-length corpus case (a Z1 at 117 Hz, Stribeck friction with dips of 1.7–2.4 × Fc, Fourier motion
    below 0.94 Hz, 13-bit encoders): the folds judged the cut-offs with Coulomb friction alone, whose misfit
    of the dips (9.3 % against a 2.1 % floor) outweighed what a cut-off changes; the shoulder preferred 1 Hz
    alone, and its effort validated at 32 % [17.7 % overall]. With each joint's low-speed curve in the folds'
    model they score 3.1 % at 4.6 Hz [1.11 × the floor; every joint within 12 %], and the joints' own choices
    together (3.7 %) stand only where they predict every row better than the candidate they came from."""
    case = one_case(tmp_path, 1358434431)
    assert case["labels"]["law"] == "stribeck" and case["labels"]["noise"] == "quantised"
    cv = case["preprocessing"]["cross_validation"]
    assert cv["dips"] and min(c["cv_relerr_pct"] for c in cv["candidates"]) < 2.5 * case["floor_pct"]
    composed = cv.get("composed")
    if composed is not None:
        whole = [c for c in cv["candidates"] if c["cutoff_hz"] != composed["cutoff_hz"]]
        best = min(c["cv_relerr_pct"] for c in whole)
        assert composed["taken"] == (cv["cutoff_hz"] == composed["cutoff_hz"])
        assert not composed["taken"] or composed["cv_relerr_pct"] < best + 1e-9
    assert case["floor_ratio"] < 1.2
    assert max(case["val_per_joint"].values()) < 15.0


def test_the_folds_of_a_plateau_log_hold_every_plateau(tmp_path):
    """A full-length corpus case (a UR5 in MuJoCo at 109 Hz, 22 s of constant-velocity plateaus, 12-bit
    encoders): in four pieces of 5.6 s each fold holds other plateaus than the other, its rigid body
    extrapolates (37–52 % at every cut-off, 48 % at 10 Hz where the whole log's fit errs by 8.7 %), and the
    folds chose 21.8 Hz [23 % on the second log, 7.75 × the floor, 3.7 × least squares; Fv, Fc up to 63 %
    off]. In 14 pieces of 1.6 s they predict at 9.4 % at 10 Hz and choose it [5.98 %: 1.95 × the floor,
    0.96 × least squares; every Fv, Fc within 4 %]."""
    case = one_case(tmp_path, 1819355544)
    assert case["labels"]["excitation"] == "plateaus" and case["labels"]["arm"] == "ur5"
    cv = case["preprocessing"]["cross_validation"]
    assert min(c["cv_relerr_pct"] for c in cv["candidates"]) < 15.0
    assert case["ls_ratio"] < 1.05 and case["floor_ratio"] < 2.5
    for name, p in case["params"].items():
        if name.endswith(("/Fv", "/Fc")):
            assert abs(p["err_pct"]) < 8.0, name


def test_the_folds_raise_the_cutoffs_a_noise_bound_set_below_the_motion(tmp_path):
    """A full-length corpus case (a UR5 at 56 Hz, white noise, its elbow only trembling): the rule's noise
    bound put the cut-offs at 3.5–7.8 Hz and the folds could only go lower [validation 3.50 %, 1.71 × least
    squares at 10 Hz; wrist_1 Fv 28 % off]. With the rule's cut-offs raised to the grid's values up to its
    own ceiling (0.2 × the rate) tried too, the folds predict at 4.8 % with every joint at 10 Hz against
    9.3 % at the rule's and take it [2.14 %: 1.05 × least squares, every Fv, Fc within 1.3 %]."""
    case = one_case(tmp_path, 3389453102)
    assert case["labels"]["arm"] == "ur5" and case["labels"]["excitation"] == "trembling"
    cv = case["preprocessing"]["cross_validation"]
    assert min(cv["cutoff_hz"].values()) > max(cv["rule_cutoff_hz"].values())
    assert case["ls_ratio"] < 1.1 and case["floor_ratio"] < 2.0
    for name, p in case["params"].items():
        if name.endswith(("/Fv", "/Fc")):
            assert abs(p["err_pct"]) < 3.0, name


@pytest.mark.long
def test_an_effort_lag_each_half_of_the_log_finds_is_judged_by_the_systems_model(tmp_path):
    """A full-length corpus case (a Panda at 2405 Hz, MuJoCo friction, trapezoid moves, the effort logged
    8.6 ms late, no logged velocity): the motion's regression, short of the arm's coupling, finds 5.9 ms
    in each half of the log and 3.8 ms over the whole; no candidate was offered, the lag stayed, and Fv
    came out up to 17 % off [2.68 % validation against a 1.93 % floor]. The halves' lag is a candidate
    now, and the system's model predicts the effort best shifted by 1.5 × it [8.9 ms: 1.49 %, every Fv
    within 1.2 %]."""
    case = one_case(tmp_path, 3370761006)
    assert case["labels"]["noise"] == "lag" and case["lag"]["said"]
    assert case["floor_ratio"] < 1.2
    for name, p in case["params"].items():
        if name.endswith("/Fv"):
            assert abs(p["err_pct"]) < 3.0, name

