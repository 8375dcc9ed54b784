#!/usr/bin/env python
"""A randomized accuracy corpus: the product's CLI with its defaults on simulated logs of drawn truths.

    .venv/bin/python bench/accuracy.py --cases 60 --seed 1 --json bench/results/accuracy.json
    .venv/bin/python bench/accuracy.py --case-seed 123456 --keep /tmp/acc   # one case again, logs kept
    .venv/bin/python bench/accuracy.py --case-seed 7 --set law=lugre --set arm=ur5 --quick

Each case draws from its own sub-seed (printed; ``--case-seed K`` reproduces it alone, ``--quick`` and
``--set`` change it in a stated way): an arm of example-robot-data (UR5, UR10, Panda with its fingers
held, Kinova Jaco2 with three continuous joints, xArm7, Z1 with its gripper held) or a one-joint system
with or without gravity; a friction law (Coulomb + viscous, Stribeck with δ in 0.5–3, LuGre with
pre-sliding, MuJoCo's damping/frictionloss/armature); a rate (50 Hz – 5 kHz, log-uniform); a noise
pathology over white effort noise (coloured noise, quantised encoders, stale repeated rows, jittered
stamps, the effort and velocity channels lagging the position, one effort's sign reversed); an excitation
(Fourier series, trapezoid sweeps, constant-velocity plateaus, micro-motions of 0.1–3 mrad after a Fourier
part, joints left trembling by a few mrad); a log format (frictionid's CSV, a CSV + layout YAML, an MCAP bag).
The truth is simulated without frictionid_core (bench/_accuracy_sim.py): Pinocchio ``rnea`` on the URDF
along the designed motion + the law's friction (LuGre integrated here) + a sensor offset, or MuJoCo
tracking the motion under computed torque + friction feed-forward + PD with per-DOF damping, frictionloss
(its constraint made stiff: the level reached above ~0.01 rad/s) and armature.

Per case the product runs as a user would (``frictionid identify`` on the estimation log with only the
system, layout, ``--hold-missing``, ``--gravity`` and — for the Stribeck and LuGre classes — ``--friction``;
``frictionid validate`` on a separate validation log of the same truth), then:

* ``val_relerr_pct`` (validate's ``relerr_pct``), ``floor_pct`` (the log's effort channel without its
  additive noise against the recorded one, 100·‖y − y_clean‖/‖y‖, at the instants validate compares
  (interpolated between the samples around each; each instant's own sample where validate replaced jittered
  stamps by a uniform clock) — ``validate --residuals``: the product chooses its rows, slow and micro-motion
  ones among them, whose smaller torques have a higher floor — of the excited joints: a trembling joint is
  not fitted, and its effort would set another floor; ``product_rows`` has it with the largest distance
  from an instant to its sample, in periods; ``floor_pct_baseline_rows`` the same on the baseline's rows,
  the floor before 2026-11-29; validate's own ``noise_floor_pct`` beside them) and their ratio;
* ``ls_ratio_same_rows``: the product's error over the baseline's on the product's rows (``product_rows``'
  ``baseline_relerr_pct``: the baseline's prediction at its grid instant nearest each; summary
  ``val_vs_ls_same_rows_within_1.05``);
* ``baseline_relerr_pct``: an independent least-squares fit (Pinocchio's joint torque regressor of every
  body + per joint rotor inertia, viscous, Coulomb and offset columns; positions resampled at the mean
  rate, Butterworth order 4 at 10 Hz (≤ 0.2 × rate) forward-backward, central differences, ≈ 200 Hz rows,
  1 s trimmed, rows slower than 2 % of the joint's 99th-percentile speed left out) validated on the same
  rows (excited joints), and the ratio product / baseline;
* parameter errors against the truth under the result's names (``<joint>/Fv``, ``<joint>/Fc``, … and
  ``<joint>.Ia`` where the result has it; ``Fv``, ``Fc``, ``J``, ``g_sin``, ``g_cos`` for one joint) and
  whether 1.96 σ (``std``; ``std_robust`` too) holds the truth;
* the exit codes, internal errors and tracebacks, the warnings, and whether the product said the lag or
  the reversed effort (and negated the right joint).

Summary: ``val_within_1.2_floor``, ``friction_err_median_pct`` and ``friction_err_p90_pct`` (|error| of Fc
and Fv of every excited joint whose truth is a static law: Coulomb, Stribeck, MuJoCo), ``coverage_1.96``
(the share of the parameters the result gives a calibrated σ, ``std_robust``, whose truth lies within
1.96 σ; ``identified_params`` of them — a parameter held at a bound or not determined has no σ, claims
nothing and is counted in ``unidentified_params``; ``coverage_1.96_white`` the same with ``std``),
``internal_errors``, ``tracebacks``, ``val_vs_ls_within_1.05`` and ``per_class`` rows (arm, law, noise,
excitation, format, rate band). A case the bench itself fails on is ``bench_error``, not counted against
the product. Writes OUT.json and prints a table.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

USER_ENV = dict(os.environ)  # the CLI runs in the user's environment
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # the bench's own work: one thread per worker

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _accuracy_sim as sim  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
_EXE = Path(sys.executable).parent / "frictionid"
FRICTIONID = [str(_EXE)] if _EXE.exists() else [sys.executable, "-m", "frictionid_core.cli"]
Z = 1.96
FLOOR_FACTOR = 1.2
LS_FACTOR = 1.05
STATIC_LAWS = ("coulomb", "stribeck", "mujoco")
DIMENSIONS = ("arm", "law", "noise", "excitation", "format", "rate_band")
LAG_WORDS = re.compile(r"\b(lag|lags|lagging|lagged|delay|delayed|latency|late|time shift|shifted)\b", re.I)
REVERSED_WORDS = re.compile(r"sign opposite|negated|negating|reversed", re.I)  # not "the negative way"


# --------------------------------------------------------------------------------------------- truth
def truth_params(case: sim.Case) -> dict[str, float]:
    """The truth under the result's parameter names."""
    one = case.arm in sim.ONE_JOINT
    out: dict[str, float] = {}
    f = case.friction
    extra = {"stribeck": ("Fs", "vs", "delta"), "lugre": ("Fs", "vs", "sigma0", "sigma1")}.get(case.law, ())
    for k, j in enumerate(case.joints):
        pre = "" if one else f"{j}/"
        for p in ("Fv", "Fc", *extra):
            out[pre + p] = float(f[p][k])
        out[pre + "offset"] = float(case.offset[k])
        if not one:
            out[f"{j}.Ia"] = float(case.armature[k])
    if one:
        out.update({k: float(v) for k, v in case.one_joint.items()})
    return out


def case_truth(case: sim.Case) -> dict:
    return {"joints": case.joints, "params": truth_params(case), "centre": case.centre.tolist(),
            "amplitude": case.amplitude.tolist(), "vmax": case.vmax.tolist(), "amax": case.amax.tolist(),
            "torque_size": case.torque_size.tolist(), "effort_sigma": case.effort_sigma.tolist(),
            "position_sigma": case.position_sigma, "noise_detail": case.noise_detail,
            "log_velocity": case.log_velocity, "trembling_joints": [case.joints[k] for k in case.trembling],
            "duration_s": {"estimation": case.duration_est, "validation": case.duration_val},
            "excite_seeds": list(case.excite_seeds), "noise_seeds": list(case.noise_seeds)}


# --------------------------------------------------------------------------------------------- one case
def _run(cmd: list[str], timeout: float) -> dict:
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=USER_ENV, cwd=ROOT)
        rc, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired as exc:
        rc, err = None, exc.stderr if isinstance(exc.stderr, str) else ""
    wall = time.perf_counter() - t0
    internal = rc not in (0, 2) or "internal error" in err.lower()
    return {"command": " ".join(cmd), "exit_code": rc, "wall_s": round(wall, 2), "timeout": rc is None,
            "internal_error": bool(internal), "traceback": "Traceback" in err,
            "warnings": [ln.split("warning:", 1)[1].strip() for ln in err.splitlines() if "frictionid: warning:" in ln],
            "error": next((ln for ln in err.splitlines() if "error:" in ln), None) if rc else None,
            "stderr_tail": err[-3000:] if (rc or "Traceback" in err) else ""}


def _param_errors(case: sim.Case, result: dict) -> dict:
    truth = truth_params(case)
    params, std, robust = result.get("params", {}), result.get("std", {}), result.get("std_robust") or {}
    rows = {}
    for name, tv in truth.items():
        if name not in params:
            continue
        est = float(params[name])
        s = std.get(name)
        sr = robust.get(name)
        err = est - tv
        rel = 100.0 * err / abs(tv) if abs(tv) > 1e-12 and not name.endswith("offset") else None
        rows[name] = {"truth": tv, "value": est, "std": s, "std_robust": sr, "err_pct": rel, "abs_err": abs(err),
                      "covered": _covers(err, s), "covered_robust": _covers(err, sr)}
    return rows


def _covers(err: float, sigma) -> bool:
    """|err| ≤ 1.96 σ; a parameter without a finite σ (held at a bound: "—") covers only an exact truth."""
    if isinstance(sigma, (int, float)) and math.isfinite(sigma):
        return bool(abs(err) <= Z * float(sigma))
    return bool(abs(err) <= 1e-12)


def _friction_errors(case: sim.Case, rows: dict) -> tuple[list[float], list[str]]:
    """|error| % of Fc and Fv of the excited joints of a static law, and the names missing from the result."""
    if case.law not in STATIC_LAWS:
        return [], []
    one = case.arm in sim.ONE_JOINT
    errs, missing = [], []
    for k, j in enumerate(case.joints):
        if k in case.trembling:
            continue
        for p in ("Fc", "Fv"):
            name = p if one else f"{j}/{p}"
            if name in rows:
                errs.append(abs(rows[name]["err_pct"]))
            else:
                missing.append(name)
    return errs, missing


def _reversal(case: sim.Case, result: dict | None, said: bool) -> dict | None:
    if case.noise != "reversed":
        return None
    joint = case.joints[case.noise_detail["joint"]]
    negated = []
    drive = (result or {}).get("drive") or {}
    if isinstance(drive, dict) and drive.get("effort_scale") is not None:
        names = drive.get("joints") or case.joints
        negated = [n for n, s in zip(names, drive["effort_scale"]) if float(s) < 0]
    return {"joint": joint, "said": said, "negated": negated, "fixed": negated == [joint]}


def run_case(sub_seed: int, overrides: dict, quick: bool, keep: str | None, timeout: float,
             diagnostic: bool = True, identify_args: tuple[str, ...] = ()) -> dict:
    """Draw, simulate, write, run the CLI, compare: one case's record (``status`` says how far it got)."""
    t_start = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix=f"acc_{sub_seed}_"))
    rec: dict = {"sub_seed": sub_seed, "overrides": overrides, "quick": quick,
                 "reproduce": f"python bench/accuracy.py --case-seed {sub_seed}"
                 + (":" + ",".join(f"{k}={v}" for k, v in overrides.items()) if overrides else "")
                 + (" --quick" if quick else "")}
    try:
        case, robot = sim.draw_case(sub_seed, overrides, quick)
        rec["labels"] = case.labels()
        logs, paths = {}, {}
        for i, (name, dur) in enumerate((("estimation", case.duration_est), ("validation", case.duration_val))):
            motion = sim.design_motion(case, case.excite_seeds[i], dur)
            simulate = sim.simulate_mujoco if case.law == "mujoco" else sim.simulate_prescribed
            record = simulate(case, robot, motion, dur)
            logs[name] = sim.corrupt(case, record, case.noise_seeds[i])
            paths[name] = sim.write_log(case, logs[name], tmp, name)
        rec["truth"] = case_truth(case)  # after the simulation: a MuJoCo one-joint truth is read from MuJoCo
        rec["sim_s"] = round(time.perf_counter() - t_start, 2)
        base = sim.baseline(case, robot, logs["estimation"], logs["validation"])
        theta = base.pop("theta")
        rec["baseline"] = base
    except Exception:
        rec.update(status="bench_error", bench_error=traceback.format_exc())
        _cleanup(tmp, keep, sub_seed)
        return rec

    system = ["--system", "joint"] + (["--gravity"] if case.arm == "joint_gravity" else []) \
        if case.arm in sim.ONE_JOINT else ["--system", f"urdf:{sim.urdf_path(case.arm)}"]
    hold = ["--hold-missing"] if robot is not None and robot.held else []
    law = ["--friction", case.law] if case.law in ("stribeck", "lugre") else []
    est_src, est_layout = paths["estimation"]
    val_src, val_layout = paths["validation"]
    rjson, vjson = tmp / "result.json", tmp / "validation.json"
    ident = [*FRICTIONID, "identify", str(est_src), *(["--layout", str(est_layout)] if est_layout else []),
             *system, *hold, *law, *identify_args, "--json", str(rjson)]
    runs = {}
    first = _run(ident, timeout)
    if first["exit_code"] == 2 and "needs a model linear in its parameters" in (first["error"] or ""):
        # the default solver refuses a nonlinear law: the user takes the first solver the error names
        runs["identify_default"] = first
        ident = [*ident[:-2], "--solver", "lm", *ident[-2:]]
        first = _run(ident, timeout)
    runs["identify"] = first
    result = json.loads(rjson.read_text()) if runs["identify"]["exit_code"] == 0 and rjson.exists() else None
    validation = None
    if result is not None:
        val = [*FRICTIONID, "validate", str(val_src), *(["--layout", str(val_layout)] if val_layout else []),
               "--params", str(rjson), "--json", str(vjson)]
        runs["validate"] = _run([*val, "--residuals", str(tmp / "residuals.csv")], timeout)
        if runs["validate"]["exit_code"] == 0 and vjson.exists():
            validation = json.loads(vjson.read_text())
            uniform = any("stamps replaced by a uniform" in w for w in runs["validate"]["warnings"])
            try:
                rec["product_rows"] = sim.product_rows(case, robot, logs["validation"], tmp / "residuals.csv",
                                                       theta, uniform)
            except Exception:  # the bench's own failure: the baseline rows' floor stands in, the record says why
                rec["product_rows"] = {"bench_error": traceback.format_exc()}
        # diagnostic, not a user's command: the same cross-test under the identification's own cut-offs and
        # decimation (validate re-chooses them from the validation log): tells a re-choice from a bad fit
        pre = result.get("preprocessing") or {}
        cut, dec = pre.get("cutoff_hz"), pre.get("decimate")
        if diagnostic and isinstance(cut, dict) and cut and dec:
            kept = ",".join(f"{j}={v:.6g}" for j, v in cut.items())
            diag_json = tmp / "validation_kept_settings.json"
            runs["validate_kept_settings"] = _run([*val[:-2], "--cutoff", kept, "--decimate", str(dec),
                                                   "--json", str(diag_json)], timeout)
            if runs["validate_kept_settings"]["exit_code"] == 0 and diag_json.exists():
                rec["val_kept_settings_pct"] = json.loads(diag_json.read_text())["metrics"].get("relerr_pct")
    user = {k: r for k, r in runs.items() if k != "validate_kept_settings"}
    rec["commands"] = [r["command"] for r in user.values()]
    rec["runs"] = runs
    rec["internal_error"] = any(r["internal_error"] for r in runs.values())
    rec["traceback"] = any(r["traceback"] for r in runs.values())
    warnings = [w for r in user.values() for w in r["warnings"]] + list((result or {}).get("warnings") or [])
    warnings = list(dict.fromkeys(warnings))
    rec["warnings"] = warnings
    text = "\n".join(warnings)
    rec["lag"] = ({"effort_lag_ms": 1e3 * case.noise_detail["effort_lag_s"], "said": bool(LAG_WORDS.search(text))}
                  if case.noise == "lag" else None)
    rec["reversed"] = _reversal(case, result, bool(REVERSED_WORDS.search(text)))
    rec["flags"] = {"noise_dominated_warning": "noise-dominated" in text,
                    "stamps_resampled": "resampled onto a uniform" in text,
                    "effort_sign_warning": bool(REVERSED_WORDS.search(text)),
                    "left_out_joints": len((result or {}).get("no_effort_joints") or [])}
    if result is None:
        rec["status"] = "timeout" if runs["identify"]["timeout"] else "identify_failed"
    elif validation is None:
        rec["status"] = "timeout" if runs["validate"]["timeout"] else "validate_failed"
    else:
        rec["status"] = "ok"
    if result is not None:
        rows = _param_errors(case, result)
        errs, missing = _friction_errors(case, rows)
        rec["params"] = rows
        rec["friction_err_pct"] = errs
        rec["friction_missing"] = missing
        rec["coverage"] = [sum(r["covered"] for r in rows.values()), len(rows)]
        rec["coverage_robust"] = [sum(r["covered_robust"] for r in rows.values()), len(rows)]
        rec["fit_relerr_pct"] = result.get("metrics", {}).get("relerr_pct")
        rec["no_effort_joints"] = result.get("no_effort_joints") or []
        rec["unresolved"] = (result.get("identifiability") or {}).get("unresolved") or []
        pre = result.get("preprocessing") or {}
        rec["preprocessing"] = {k: pre.get(k) for k in ("cutoff_hz", "decimate", "min_speed", "stick_speed",
                                                        "trim_start_s", "trim_end_s", "cross_validation") if k in pre}
        rec["friction_returned"] = result.get("friction")
    if validation is not None:
        m = validation.get("metrics", {})
        rec["val_relerr_pct"] = m.get("relerr_pct")
        rec["product_noise_floor_pct"] = m.get("noise_floor_pct")
        rec["val_samples"] = m.get("samples")
        rec["val_per_joint"] = {j: v.get("relerr_pct") for j, v in (m.get("per_joint") or {}).items()}
        vp = validation.get("preprocessing") or {}
        rec["val_preprocessing"] = {k: vp.get(k) for k in ("cutoff_hz", "decimate", "min_speed", "rechosen", "kept")}
    # the floor of the rows validate compares (its own choice of rows); the baseline's rows' one beside it
    rows_floor = (rec.get("product_rows") or {}).get("floor_pct")
    floor, ls = rows_floor if rows_floor else base["floor_pct"], base["relerr_pct"]
    rec["floor_pct"] = floor
    rec["floor_pct_baseline_rows"] = base["floor_pct"]
    rec["baseline_relerr_pct"] = ls
    v = rec.get("val_relerr_pct")
    rec["floor_ratio"] = v / floor if v is not None and floor > 0 else None
    rec["ls_ratio"] = v / ls if v is not None and ls > 0 else None
    rec["within_floor"] = bool(v is not None and v <= FLOOR_FACTOR * floor)
    rec["within_ls"] = bool(v is not None and v <= LS_FACTOR * ls)
    # the baseline predicting the product's rows: both errors on the same instants
    ls_rows = (rec.get("product_rows") or {}).get("baseline_relerr_pct")
    rec["ls_ratio_same_rows"] = v / ls_rows if v is not None and ls_rows else None
    rec["within_ls_same_rows"] = bool(v is not None and ls_rows and v <= LS_FACTOR * ls_rows)
    vk = rec.get("val_kept_settings_pct")
    rec["within_floor_kept_settings"] = bool(vk is not None and vk <= FLOOR_FACTOR * floor)
    rec["wall_s"] = round(time.perf_counter() - t_start, 2)
    _cleanup(tmp, keep, sub_seed)
    return rec


def _cleanup(tmp: Path, keep: str | None, sub_seed: int) -> None:
    if keep:
        dest = Path(keep) / f"case_{sub_seed}"
        if dest.exists():
            shutil.rmtree(dest)
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(tmp), dest)
    else:
        shutil.rmtree(tmp, ignore_errors=True)


# --------------------------------------------------------------------------------------------- summary
def _sigma_given(sigma) -> bool:
    return isinstance(sigma, (int, float)) and math.isfinite(sigma) and sigma > 0


def _coverage(counted: list[dict], key: str) -> tuple[float | None, int, int]:
    """(share of the parameters given a σ under ``key`` (``std_robust``: the calibrated σ, or
    ``std``) whose truth lies within 1.96 σ, how many were given one, how many were not: held at a
    bound or not determined — no claim, so not counted in the share)."""
    rows = [r for c in counted for r in (c.get("params") or {}).values()]
    given = [r for r in rows if _sigma_given(r.get(key))]
    hits = sum(r["abs_err"] <= Z * r[key] for r in given)
    return (hits / len(given) if given else None), len(given), len(rows) - len(given)


def _figures(cases: list[dict]) -> dict:
    counted = [c for c in cases if c.get("status") != "bench_error"]
    n = len(counted)
    errs = [e for c in counted for e in c.get("friction_err_pct", [])]
    calibrated, identified, unidentified = _coverage(counted, "std_robust")
    frac = lambda key: (sum(bool(c.get(key)) for c in counted) / n) if n else None
    med = lambda xs: float(np.median(xs)) if xs else None
    return {
        "cases": n,
        "val_within_1.2_floor": frac("within_floor"),
        "friction_err_median_pct": med(errs),
        "friction_err_p90_pct": float(np.percentile(errs, 90)) if errs else None,
        "coverage_1.96": calibrated,
        "internal_errors": sum(bool(c.get("internal_error")) for c in counted),
        "tracebacks": sum(bool(c.get("traceback")) for c in counted),
        "val_vs_ls_within_1.05": frac("within_ls"),
        "val_vs_ls_same_rows_within_1.05": frac("within_ls_same_rows"),
        "coverage_1.96_white": _coverage(counted, "std")[0],
        "identified_params": identified,
        "unidentified_params": unidentified,
        "floor_ratio_median": med([c["floor_ratio"] for c in counted if c.get("floor_ratio") is not None]),
        "ls_ratio_median": med([c["ls_ratio"] for c in counted if c.get("ls_ratio") is not None]),
        "product_failures": sum(c.get("status") not in ("ok",) for c in counted),
        "friction_params": len(errs),
        "friction_missing": sum(len(c.get("friction_missing", [])) for c in counted),
        "val_within_1.2_floor_kept_settings": frac("within_floor_kept_settings"),
        "default_solver_refused": sum("identify_default" in c.get("runs", {}) for c in counted),
        "reversed_fixed": _share([c["reversed"]["fixed"] for c in counted if c.get("reversed")]),
        "lag_said": _share([c["lag"]["said"] for c in counted if c.get("lag")]),
    }


def _share(flags: list[bool]) -> float | None:
    return sum(flags) / len(flags) if flags else None


def summarize(cases: list[dict]) -> dict:
    out = _figures(cases)
    out["bench_errors"] = sum(c.get("status") == "bench_error" for c in cases)
    out["statuses"] = {s: sum(c.get("status") == s for c in cases) for s in sorted({c.get("status") for c in cases})}
    rows = []
    for dim in DIMENSIONS:
        values = sorted({c["labels"][dim] for c in cases if "labels" in c})
        for value in values:
            sel = [c for c in cases if c.get("labels", {}).get(dim) == value]
            rows.append({"dimension": dim, "class": value, **_figures(sel)})
    out["per_class"] = rows
    return out


def _fmt(x, spec=".2f", width=7) -> str:
    if x is None:
        return "—".rjust(width)
    return format(x, spec).rjust(width)


def table(summary: dict) -> str:
    head = (f"{'dimension':<10} {'class':<14} {'n':>3} {'≤1.2fl':>7} {'≤1.2fk':>7} {'≤1.05ls':>7} "
            f"{'fl.rat':>7} {'ls.rat':>7} "
            f"{'err50%':>7} {'err90%':>7} {'cov':>6} {'fail':>4} {'int':>3} {'tb':>3}")
    lines = [head, "-" * len(head)]

    def row(dim, cls, f):
        lines.append(f"{dim:<10} {cls:<14} {f['cases']:>3} {_fmt(f['val_within_1.2_floor'])} "
                     f"{_fmt(f['val_within_1.2_floor_kept_settings'])} "
                     f"{_fmt(f['val_vs_ls_within_1.05'])} {_fmt(f['floor_ratio_median'])} {_fmt(f['ls_ratio_median'])} "
                     f"{_fmt(f['friction_err_median_pct'], '.1f')} {_fmt(f['friction_err_p90_pct'], '.1f')} "
                     f"{_fmt(f['coverage_1.96'], '.2f', 6)} {f['product_failures']:>4} {f['internal_errors']:>3} "
                     f"{f['tracebacks']:>3}")

    row("all", "", summary)
    last = None
    for r in summary["per_class"]:
        if r["dimension"] != last and last is not None:
            lines.append("")
        last = r["dimension"]
        row(r["dimension"], str(r["class"]), r)
    lines.append("≤1.2fl: validation within 1.2 × the noise floor; ≤1.2fk: the same with the identification's cut-offs "
                 "and decimation given to validate (a diagnostic); ≤1.05ls: within 1.05 × the LS baseline; fl.rat, "
                 "ls.rat: median ratios; err50/90%: |error| of Fc, Fv (static laws); cov: 1.96 σ (calibrated) "
                 "coverage of the parameters given a σ; fail: product failures; int, tb: internal errors, tracebacks")
    lines.append(f"bench errors (not the product's): {summary['bench_errors']}")
    return "\n".join(lines)


def case_line(c: dict) -> str:
    lab = c.get("labels", {})
    desc = "/".join(str(lab.get(k, "?")) for k in ("arm", "law", "noise", "excitation", "format"))
    rate = lab.get("rate_hz")
    if c.get("status") == "bench_error":
        return f"case {c['sub_seed']}: {desc} BENCH ERROR: {c['bench_error'].strip().splitlines()[-1]}"
    v, fl, ls = c.get("val_relerr_pct"), c.get("floor_pct"), c.get("baseline_relerr_pct")
    errs = c.get("friction_err_pct") or []
    return (f"case {c['sub_seed']}: {desc} {rate:.0f} Hz: {c['status']}, val {_fmt(v, '.2f', 0)} % "
            f"(floor {_fmt(fl, '.2f', 0)}, LS {_fmt(ls, '.2f', 0)}), friction max err "
            f"{_fmt(max(errs) if errs else None, '.1f', 0)} %, {c.get('wall_s', 0):.0f} s")


# --------------------------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=10, help="number of cases drawn from --seed (default 10)")
    ap.add_argument("--seed", type=int, default=None, help="master seed (default: drawn and printed)")
    ap.add_argument("--case-seed", action="append", default=[], metavar="K[:KEY=VALUE,…]",
                    help="run the case of sub-seed K alone (repeatable; labels after a colon as --set gives "
                         "them, for this case only); --cases/--seed are then ignored")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="give a label instead of drawing it: arm, law, noise, excitation, format, rate")
    ap.add_argument("--quick", action="store_true", help="short logs (12 s + 8 s) at ≤ 200 Hz (the test's cases)")
    ap.add_argument("--workers", type=int, default=2, help="cases run in parallel (default 2)")
    ap.add_argument("--keep", default=None, metavar="DIR", help="keep each case's logs and results in DIR/case_K")
    ap.add_argument("--no-diagnostic", action="store_true",
                    help="skip the diagnostic cross-test under the identification's own cut-offs (faster)")
    ap.add_argument("--identify-args", default="", metavar="'ARGS'",
                    help="extra arguments of every identify command (an A/B of a setting on the same cases), "
                         "e.g. '--decimate 1'")
    ap.add_argument("--timeout", type=float, default=1200.0, help="per CLI command, s (default 1200)")
    ap.add_argument("--json", default=None, metavar="OUT", help="write the cases and the summary here")
    ap.add_argument("--pool", nargs="+", default=None, metavar="RUN.json",
                    help="run nothing: summarise the cases of these earlier runs together (with --json: write it)")
    args = ap.parse_args(argv)
    if args.pool:
        runs = [json.loads(Path(p).read_text()) for p in args.pool]
        cases = [c for r in runs for c in r["cases"]]
        summary = summarize(cases)
        what = ", ".join(f"{p} (seed {r.get('seed')}, {len(r['cases'])} cases)" for p, r in zip(args.pool, runs))
        print(f"pooled: {what}")
        print(table(summary))
        if args.json:
            out = {"pooled": list(args.pool), "seeds": [r.get("seed") for r in runs], "summary": summary}
            Path(args.json).write_text(json.dumps(_finite(out), indent=1, default=_jsonable, allow_nan=False))
        return 0
    labels = ("arm", "law", "noise", "excitation", "format", "rate")

    def parse(items: list[str], where: str) -> dict:
        out = {}
        for item in items:
            key, _, value = item.partition("=")
            if key not in labels or not value:
                ap.error(f"{where} {item}: expected KEY=VALUE with KEY one of {', '.join(labels)}")
            out[key] = value
        return out

    overrides = parse(args.set, "--set")
    if args.case_seed:
        seed, sub_seeds, per_case = None, [], []
        for spec in args.case_seed:
            k, _, extra = spec.partition(":")
            try:
                sub_seeds.append(int(k))
            except ValueError:
                ap.error(f"--case-seed {spec}: K must be an integer")
            per_case.append({**overrides, **parse([e for e in extra.split(",") if e], "--case-seed")})
    else:
        seed = args.seed if args.seed is not None else int(np.random.SeedSequence().entropy % 2**31)
        sub_seeds = [int(s) for s in np.random.SeedSequence(seed).generate_state(args.cases)]
        per_case = [overrides] * len(sub_seeds)
    print(f"accuracy corpus: seed {seed}, {len(sub_seeds)} case(s), sub-seeds {sub_seeds}, "
          f"workers {args.workers}{', quick' if args.quick else ''}", flush=True)
    t0 = time.perf_counter()
    cases: list[dict] = [None] * len(sub_seeds)
    with ProcessPoolExecutor(max_workers=max(1, args.workers)) as pool:
        futures = {pool.submit(run_case, s, per_case[i], args.quick, args.keep, args.timeout,
                               not args.no_diagnostic, tuple(shlex.split(args.identify_args))): i
                   for i, s in enumerate(sub_seeds)}
        for fut in as_completed(futures):
            i = futures[fut]
            try:
                cases[i] = fut.result()
            except Exception:
                cases[i] = {"sub_seed": sub_seeds[i], "status": "bench_error", "bench_error": traceback.format_exc()}
            print(case_line(cases[i]), flush=True)
            done = [c for c in cases if c is not None]
            if args.json and len(done) < len(cases):  # what is measured so far survives a stopped run
                _write(args.json, seed, sub_seeds, args, overrides, summarize(done), done, partial=True)
    summary = summarize(cases)
    summary["wall_s"] = round(time.perf_counter() - t0, 1)
    print(table(summary))
    if args.json:
        _write(args.json, seed, sub_seeds, args, overrides, summary, cases, partial=False)
    return 0


def _write(path: str, seed, sub_seeds, args, overrides, summary, cases, partial: bool) -> None:
    out = {"seed": seed, "sub_seeds": sub_seeds, "quick": args.quick, "overrides": overrides,
           "identify_args": args.identify_args, "partial": partial,
           "summary": summary, "cases": cases}
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(path).with_suffix(".part")
    tmp.write_text(json.dumps(_finite(out), indent=1, default=_jsonable, allow_nan=False))
    tmp.replace(path)


def _finite(x):
    """NaN and inf as null (strict JSON)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x


def _jsonable(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(type(x))


if __name__ == "__main__":
    sys.exit(main())
