"""Report of one identification result on any system and source: HTML page, PNG figures, report.json.

``frictionid report RESULT.json SRC [SRC …] --out DIR [--validation SRC …]`` rebuilds the result's
model on each source (:func:`frictionid_core.identification.model_from_result`: its system,
joint map, joints, drive, friction law and pre-processing) and shows, per source and joint, at the
analysis instants (after the result's filtering, trimming and decimation):

* the recorded effort and the model's one-step-ahead prediction over time;
* the residual (recorded − predicted) over time and its histogram;
* friction vs velocity: the identified law over the measured friction, i.e. the recorded effort
  minus the model's rigid-body part and constant offset (scatter and velocity-binned means);
* through a reversal, on every row (standstill and the slow rows too): recorded vs predicted
  effort, and the hysteresis loop of friction vs position (measured, and the model's) — where a
  dynamic law's states show and a static law jumps.

Metrics are taken against the recorded effort on the rows shown; rows the system leaves out
(slower than its ``min_speed``: the sign of the velocity is noise there) are neither shown nor
counted. The page also lists the parameters ± σ, the result's own metrics, its pre-processing,
other settings and warnings. Figures are PNG files beside ``report.html`` (linked, not embedded).
"""

from __future__ import annotations

import html
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from frictionid_core.compare import check_result, flatten
from frictionid_core.errors import FrictionIdError
from frictionid_core.files import write_bytes, write_json, write_text
from frictionid_core.identification import metric_model, model_from_result
from frictionid_core.model import check_finite, fit_metrics
from frictionid_core.reports.html_page import MAX_PLOT_POINTS, PAGE_STYLE, friction_axes, html_table, png_bytes
from frictionid_core.timeseries import JointSeries

# (effort, velocity) units by system; every other system is rotary.
UNITS = {"emps": ("N", "m/s")}
ROTARY_UNITS = ("N·m", "rad/s")
# Result keys shown as settings (beside system, friction, solver, source and joints).
SETTING_KEYS = ("joint_map", "preprocessing", "drive", "layout", "window", "fixed", "bounds", "varpro")
REVERSAL_PLOT_S = 0.5  # the reversal figure shows this either side of the reversal [s]
REVERSAL_SPEED_SHARE = 0.1  # … a reversal reaching this share of the top speed on both sides


@dataclass
class JointTrace:
    """One joint of one source at the analysis instants, on the rows the system keeps.

    Attributes:
        joint: data joint name.
        t: time from the source's first sample, s.
        velocity: the (filtered, decimated) velocity the model uses.
        recorded: recorded effort.
        predicted: the model's prediction.
        friction: measured friction: recorded − rigid-body part − offset.
        friction_params: this joint's friction-law parameters (the law's order).
        excluded: analysis rows left out (slower than the system's min_speed).
        model_friction: the model's friction: predicted − rigid-body part − offset.
    """

    joint: str
    t: np.ndarray
    velocity: np.ndarray
    recorded: np.ndarray
    predicted: np.ndarray
    friction: np.ndarray
    friction_params: np.ndarray
    excluded: int
    model_friction: np.ndarray | None = None


def joint_traces(series: JointSeries, result: dict) -> tuple[list[JointTrace], list[JointTrace], object]:
    """Per joint of ``series``: what the report plots and measures (see :class:`JointTrace`) on the
    rows its system keeps, and on every analysis row; also the model's friction law (a FrictionModel)."""
    fitted, x = model_from_result(series, result)
    model = metric_model(fitted)  # the recorded effort at the analysis instants
    every = model if model.obs.full is None else type(model)(model.obs.full, model.friction, model.offset,
                                                               load_rigid=model.load_rigid)
    return _traces(model, x, series, False), _traces(every, x, series, True), model.friction


def _traces(model, x: np.ndarray, series: JointSeries, every_row: bool) -> list[JointTrace]:
    """The traces of ``model`` (on its metric observation) at ``x``: its moving rows or every row."""
    obs = model.obs
    kinds = {n.removesuffix("_pos").removesuffix("_neg") for n in model.friction.names} | {"Fc_load"}
    no_friction = x.copy()  # rigid-body part + offset: friction levels at zero (shape parameters kept)
    no_friction[[i for i in model.linear_index if model.names[i].rsplit("/", 1)[-1].removesuffix("_pos")
                 .removesuffix("_neg") in kinds]] = 0.0
    predicted, rigid = model.predict(np.vstack([x, no_friction]))
    if model.friction.is_dynamic:  # its states' friction is no column: taken off the rigid-body part
        rigid = rigid - model.state_part(no_friction)
    moving = obs.used if obs.moving is None or every_row else obs.used & obs.moving
    nd, nj = obs.n_samples, len(obs.joints)
    traces = []
    for j, joint in enumerate(obs.joints):  # the fit rows: joints, or the motors of a motor-side drive
        rows = slice(j * nd, (j + 1) * nd)
        kept = moving[rows]
        recorded = obs.y[rows]
        prefix = f"{joint}/" if nj > 1 else ""
        fparams = x[[model.names.index(prefix + n) for n in model.friction.names]]
        traces.append(JointTrace(joint, (obs.t - series.t[0])[kept], obs.velocity[kept, j], recorded[kept],
                                 predicted[rows][kept], (recorded - rigid[rows])[kept], fparams,
                                 int(nd - kept.sum()), (predicted[rows] - rigid[rows])[kept]))
    return traces


def trace_metrics(traces: list[JointTrace]) -> tuple[dict, dict]:
    """(metrics over every joint, {joint: metrics}) against the recorded effort; each with ``samples``."""
    def metrics(recorded, predicted) -> dict:
        if recorded.size < 2:
            return {"samples": int(recorded.size)}
        return dict(fit_metrics(recorded, predicted), samples=int(recorded.size))

    per_joint = {tr.joint: dict(metrics(tr.recorded, tr.predicted), excluded=tr.excluded) for tr in traces}
    overall = metrics(np.concatenate([tr.recorded for tr in traces]), np.concatenate([tr.predicted for tr in traces]))
    return overall, per_joint


def joint_figure(trace: JointTrace, friction, units: tuple, title: str) -> bytes:
    """PNG: recorded vs predicted effort, residual over time, residual histogram, friction vs velocity."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    step = max(1, trace.t.size // MAX_PLOT_POINTS)
    t, residual = trace.t[::step], (trace.recorded - trace.predicted)
    fig = plt.figure(figsize=(10, 8.5))
    grid = fig.add_gridspec(3, 2, height_ratios=(1.2, 0.8, 1.2))
    a_tau = fig.add_subplot(grid[0, :])
    a_res = fig.add_subplot(grid[1, :], sharex=a_tau)
    a_hist, a_fric = fig.add_subplot(grid[2, 0]), fig.add_subplot(grid[2, 1])
    a_tau.plot(t, trace.recorded[::step], lw=0.7, label="recorded effort")
    a_tau.plot(t, trace.predicted[::step], lw=0.7, label="model (one step ahead)")
    a_tau.set(ylabel=f"effort ({units[0]})", title=title)
    a_tau.legend(fontsize=8)
    a_res.plot(t, residual[::step], lw=0.6, color="C3")
    a_res.set(xlabel="time (s)", ylabel=f"residual ({units[0]})")
    a_hist.hist(residual, bins=80, color="C3", alpha=0.8)
    a_hist.set(xlabel=f"residual ({units[0]})", ylabel="rows", title=f"RMS {np.sqrt(np.mean(residual ** 2)):.4g}")
    friction_axes(a_fric, trace.velocity, trace.friction, friction, trace.friction_params, units,
                  "measured (effort − rigid body − offset)")
    fig.tight_layout()
    data = png_bytes(fig)
    plt.close(fig)
    return data


def reversal_span(trace: JointTrace) -> slice | None:
    """The rows within ±REVERSAL_PLOT_S of a reversal of ``trace`` (every row): a sign change of the
    velocity with REVERSAL_SPEED_SHARE of the top speed reached on both sides within that window (not
    the noise of a standstill), the slowest such (the most rows below 5 % of the top speed: where
    pre-sliding shows); None without one."""
    v, t = trace.velocity, trace.t
    top = float(np.max(np.abs(v), initial=0.0))
    flips = np.flatnonzero(np.sign(v[1:]) * np.sign(v[:-1]) < 0) + 1

    def near(k: int) -> np.ndarray:
        return (t >= t[k] - REVERSAL_PLOT_S) & (t <= t[k] + REVERSAL_PLOT_S)

    real = [k for k in flips if min(np.max(np.abs(v[near(k) & (t < t[k])]), initial=0.0),
                                    np.max(np.abs(v[near(k) & (t >= t[k])]), initial=0.0))
            >= REVERSAL_SPEED_SHARE * top]
    if not real or top <= 0.0:
        return None
    slow = np.abs(v) < 0.05 * top
    keep = np.flatnonzero(near(max(real, key=lambda k: int(slow[near(k)].sum()))))
    return slice(int(keep[0]), int(keep[-1]) + 1)


def reversal_figure(trace: JointTrace, units: tuple, title: str) -> bytes | None:
    """PNG of a reversal on every row (:func:`reversal_span`): recorded vs predicted effort over time,
    and friction vs position (travel from the window's start, the velocity integrated): the measured
    friction and the model's. None without a reversal."""
    span = reversal_span(trace)
    if span is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, v = trace.t[span], trace.velocity[span]
    travel = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    fig, (a_t, a_x) = plt.subplots(1, 2, figsize=(10, 4))
    a_t.plot(t, trace.recorded[span], lw=0.8, label="recorded effort")
    a_t.plot(t, trace.predicted[span], lw=0.9, label="model (one step ahead)")
    a_t.set(xlabel="time (s)", ylabel=f"effort ({units[0]})", title=title)
    a_t.legend(fontsize=8)
    a_x.plot(travel, trace.friction[span], ".", ms=2, color="0.6", label="measured friction")
    a_x.plot(travel, trace.model_friction[span], "C3", lw=1.5, label="model friction")
    a_x.set(xlabel=f"position from the window's start ({units[1].split('/')[0]})", ylabel=f"friction ({units[0]})",
            title="hysteresis through the reversal")
    a_x.legend(fontsize=8)
    fig.tight_layout()
    data = png_bytes(fig)
    plt.close(fig)
    return data


# ----------------------------------------------------------------------------- report
def build_fit_report(result: dict, sources: list[tuple[str, JointSeries]], out_dir: Path,
                     result_file: str = "") -> dict:
    """Write ``out_dir/report.html``, one PNG per source and joint and ``out_dir/report.json``.

    Args:
        result: an identification result (``IdentifyResult.to_dict()``).
        sources: (role, series) pairs, role e.g. ``estimation`` or ``validation``; each series
            holds the result's joints.
        result_file: where the result was read from (shown on the page).

    Returns the report.json dict.
    """
    check_result(result, result_file or "the result")
    if not sources:
        raise FrictionIdError("the report needs at least one source to show the fit on")
    units = UNITS.get(result["system"], ROTARY_UNITS)
    computed = []  # every source first: nothing is written when one of them fails
    for role, series in sources:
        traces, every, friction = joint_traces(series, result)
        overall, per_joint = trace_metrics(traces)
        if overall["samples"] > 1:  # else no row to measure on: the page says so
            check_finite(overall, f"the result on {role} source {series.source}")
        all_rows, every_joint = trace_metrics(every)
        computed.append((role, series, traces, friction, overall, per_joint, every, all_rows, every_joint))
    out_dir.mkdir(parents=True, exist_ok=True)
    shown = []
    for k, (role, series, traces, friction, overall, per_joint, every, all_rows, every_joint) in enumerate(
            computed, 1):
        figures, reversals = {}, {}
        for tr, full in zip(traces, every):
            title = f"{tr.joint} · {role}: {series.source}"
            if tr.t.size >= 2:  # else every row slower than the system's min_speed: nothing to draw
                figures[tr.joint] = f"{role}{k}_{_slug(tr.joint)}.png"
                write_bytes(out_dir / figures[tr.joint], joint_figure(tr, friction, units, title))
            png = reversal_figure(full, units, f"{tr.joint}: a reversal, every row")
            if png is not None:
                reversals[tr.joint] = f"{role}{k}_{_slug(tr.joint)}_reversal.png"
                write_bytes(out_dir / reversals[tr.joint], png)
        shown.append({"role": role, "source": series.source, "metrics": overall, "per_joint": per_joint,
                      "all_rows": dict(all_rows, per_joint=every_joint), "figures": figures,
                      "reversal_figures": reversals, "notes": list(series.notes)})
    report = {"result_file": result_file, "units": {"effort": units[0], "velocity": units[1]},
              **{k: result.get(k) for k in ("system", "friction", "asymmetric", "solver", "source", "joints",
                                            "params", "std", "std_robust", "at_bound", "metrics")},
              "warnings": list(result.get("warnings") or []),
              "settings": {k: result[k] for k in SETTING_KEYS if k in result},
              "sources": shown}
    write_json(out_dir / "report.json", report)
    write_text(out_dir / "report.html", _html(report))
    return report


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name) or "joint"


def _html(rep: dict) -> str:
    esc = lambda v: html.escape(str(v))
    source = ", ".join(rep["source"]) if isinstance(rep["source"], list) else rep["source"]
    head = (f"{rep['system']} · {rep['friction']}{' (asymmetric)' if rep['asymmetric'] else ''} · solver "
            f"{rep['solver']}")
    nan = float("nan")
    calibrated, white, at_bound = rep.get("std_robust") or {}, rep["std"] or {}, rep.get("at_bound") or {}
    params = [[n, f"at bound {at_bound[n]:.6g}", "—", "—", "—"] if n in at_bound else
              [n, v, calibrated.get(n, nan), 100.0 * calibrated[n] / abs(v) if n in calibrated and v else nan,
               white.get(n, nan)] for n, v in rep["params"].items()]
    metric_rows = [[k, v] for k, v in (rep["metrics"] or {}).items() if not isinstance(v, dict)]
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>frictionid report: {esc(head)}</title>"
             f"<style>{PAGE_STYLE}</style></head><body>",
             "<h1>frictionid identification report</h1>",
             f"<p><b>{esc(head)}</b><br>result: <code>{esc(rep['result_file'])}</code>; identified on "
             f"<code>{esc(source)}</code>; joints: {esc(', '.join(rep['joints'] or []))}</p>"]
    if rep["warnings"]:
        parts.append("<h2>Warnings</h2><ul>" + "".join(f"<li>{esc(w)}</li>" for w in rep["warnings"]) + "</ul>")
    columns = ["parameter", "value", "σ (calibrated)", "σ % of |value|", "σ (white)"]
    parts += ["<h2>Parameters</h2>", html_table(columns, params),
              "<h2>Metrics of the identification (as stored in the result)</h2>",
              html_table(["metric", "value"], metric_rows)]
    per_joint = (rep["metrics"] or {}).get("per_joint")
    if isinstance(per_joint, dict) and per_joint:
        keys = list(dict.fromkeys(k for m in per_joint.values() for k in m))
        parts.append(html_table(["joint", *keys], [[j, *(m.get(k, "") for k in keys)] for j, m in per_joint.items()]))
    if rep["settings"]:
        parts += ["<h2>Pre-processing and settings</h2>",
                  html_table(["setting", "value"], [[k, v] for k, v in flatten(rep["settings"]).items()])]
    for s in rep["sources"]:
        parts += [f"<h2>{esc(s['role'].capitalize())}: <code>{esc(s['source'])}</code></h2>",
                  "<p>Against the recorded effort at the analysis instants; rows slower than the system's "
                  "minimum speed are excluded.</p>",
                  html_table(["joint", "relerr %", "RMSE " + rep["units"]["effort"], "R²", "rows", "excluded"],
                             [[j, m.get("relerr_pct", ""), m.get("rmse", ""), m.get("r2", ""), m["samples"],
                               m["excluded"]] for j, m in s["per_joint"].items()]
                             + [["all joints", s["metrics"].get("relerr_pct", ""), s["metrics"].get("rmse", ""),
                                 s["metrics"].get("r2", ""), s["metrics"]["samples"], ""]])]
        every = s["all_rows"]
        parts += ["<p>Every row (standstill and reversals too):</p>",
                  html_table(["joint", "relerr %", "RMSE " + rep["units"]["effort"], "R²", "rows"],
                             [[j, m.get("relerr_pct", ""), m.get("rmse", ""), m.get("r2", ""), m["samples"]]
                              for j, m in every["per_joint"].items()]
                             + [["all joints", every.get("relerr_pct", ""), every.get("rmse", ""),
                                 every.get("r2", ""), every["samples"]]])]
        if s["notes"]:
            parts.append("<ul>" + "".join(f"<li>{esc(n)}</li>" for n in s["notes"]) + "</ul>")
        for joint in s["per_joint"]:
            name, reversal = s["figures"].get(joint), s["reversal_figures"].get(joint)
            parts.append(f"<h3>{esc(joint)}</h3>" + (f"<img alt='{esc(joint)}' src='{esc(name)}'>" if name else
                                                     "<p>No row faster than the system's minimum speed.</p>")
                         + (f"<img alt='{esc(joint)} reversal' src='{esc(reversal)}'>" if reversal else ""))
    parts.append("</body></html>")
    return "\n".join(parts)

