"""Report of one identification result on any system and source: HTML page, PNG figures, report.json.

``frictionid report RESULT.json SRC [SRC …] --out DIR [--validation SRC …]`` rebuilds the result's
model on each source (:func:`frictionid_core.identification.model_from_result`: its system,
joint map, joints, drive, friction law and pre-processing) and shows, per source and joint, at the
analysis instants (after the result's filtering, trimming and decimation):

* the recorded effort and the model's one-step-ahead prediction over time;
* the residual (recorded − predicted) over time and its histogram;
* friction vs velocity: the identified law over the measured friction, i.e. the recorded effort
  minus the model's rigid-body part and constant offset (scatter and velocity-binned means).

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

from frictionid_core.errors import FrictionIdError
from frictionid_core.jsonfile import write_bytes, write_json, write_text
from frictionid_core.metrics import check_finite, fit_metrics
from frictionid_core.reports.html_page import MAX_PLOT_POINTS, PAGE_STYLE, friction_axes, html_table, png_bytes
from frictionid_core.timeseries import JointSeries

# (effort, velocity) units by system; every other system is rotary.
UNITS = {"emps": ("N", "m/s")}
ROTARY_UNITS = ("N·m", "rad/s")
# Result keys shown as settings (beside system, friction, solver, source and joints).
SETTING_KEYS = ("joint_map", "preprocessing", "drive", "layout", "window", "fixed", "bounds", "varpro")


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
    """

    joint: str
    t: np.ndarray
    velocity: np.ndarray
    recorded: np.ndarray
    predicted: np.ndarray
    friction: np.ndarray
    friction_params: np.ndarray
    excluded: int


def joint_traces(series: JointSeries, result: dict) -> tuple[list[JointTrace], object]:
    """Per joint of ``series``: what the report plots and measures (see :class:`JointTrace`);
    also the model's friction law (a FrictionModel)."""
    from frictionid_core.identification import metric_model, model_from_result

    fitted, x = model_from_result(series, result)
    model = metric_model(fitted)  # the recorded effort at the analysis instants
    obs = model.obs
    no_friction = x.copy()  # rigid-body part + offset: friction levels at zero (shape parameters kept)
    no_friction[[i for i in model.linear_index if model.names[i].rsplit("/", 1)[-1] in model.friction.names]] = 0.0
    predicted, rigid = model.predict(np.vstack([x, no_friction]))
    nd, nj = obs.n_samples, len(obs.joints)
    traces = []
    for j, joint in enumerate(obs.joints):  # the fit rows: joints, or the motors of a motor-side drive
        rows = slice(j * nd, (j + 1) * nd)
        kept = obs.used[rows]
        recorded = obs.y[rows]
        prefix = f"{joint}/" if nj > 1 else ""
        fparams = x[[model.names.index(prefix + n) for n in model.friction.names]]
        traces.append(JointTrace(joint, (obs.t - series.t[0])[kept], obs.velocity[kept, j], recorded[kept],
                                 predicted[rows][kept], (recorded - rigid[rows])[kept], fparams,
                                 int(nd - kept.sum())))
    return traces, model.friction


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
    from frictionid_core.robots.compare import check_result

    check_result(result, result_file or "the result")
    if not sources:
        raise FrictionIdError("the report needs at least one source to show the fit on")
    units = UNITS.get(result["system"], ROTARY_UNITS)
    computed = []  # every source first: nothing is written when one of them fails
    for role, series in sources:
        traces, friction = joint_traces(series, result)
        overall, per_joint = trace_metrics(traces)
        if overall["samples"] > 1:  # else no row to measure on: the page says so
            check_finite(overall, f"the result on {role} source {series.source}")
        computed.append((role, series, traces, friction, overall, per_joint))
    out_dir.mkdir(parents=True, exist_ok=True)
    shown = []
    for k, (role, series, traces, friction, overall, per_joint) in enumerate(computed, 1):
        figures = {}
        for tr in traces:
            if tr.t.size < 2:  # every row slower than the system's min_speed: nothing to draw
                continue
            name = f"{role}{k}_{_slug(tr.joint)}.png"
            title = f"{tr.joint} · {role}: {series.source}"
            write_bytes(out_dir / name, joint_figure(tr, friction, units, title))
            figures[tr.joint] = name
        shown.append({"role": role, "source": series.source, "metrics": overall, "per_joint": per_joint,
                      "figures": figures, "notes": list(series.notes)})
    report = {"result_file": result_file, "units": {"effort": units[0], "velocity": units[1]},
              **{k: result.get(k) for k in ("system", "friction", "asymmetric", "solver", "source", "joints",
                                            "params", "std", "metrics")},
              "warnings": list(result.get("warnings") or []),
              "settings": {k: result[k] for k in SETTING_KEYS if k in result},
              "sources": shown}
    write_json(out_dir / "report.json", report)
    write_text(out_dir / "report.html", _html(report))
    return report


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name) or "joint"


def _html(rep: dict) -> str:
    from frictionid_core.robots.compare import flatten

    esc = lambda v: html.escape(str(v))
    source = ", ".join(rep["source"]) if isinstance(rep["source"], list) else rep["source"]
    head = (f"{rep['system']} · {rep['friction']}{' (asymmetric)' if rep['asymmetric'] else ''} · solver "
            f"{rep['solver']}")
    params = [[n, v, rep["std"].get(n, float("nan")) if rep["std"] else float("nan"),
               100.0 * rep["std"][n] / abs(v) if rep["std"] and n in rep["std"] and v else float("nan")]
              for n, v in rep["params"].items()]
    metric_rows = [[k, v] for k, v in (rep["metrics"] or {}).items() if not isinstance(v, dict)]
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>frictionid report: {esc(head)}</title>"
             f"<style>{PAGE_STYLE}</style></head><body>",
             "<h1>frictionid identification report</h1>",
             f"<p><b>{esc(head)}</b><br>result: <code>{esc(rep['result_file'])}</code>; identified on "
             f"<code>{esc(source)}</code>; joints: {esc(', '.join(rep['joints'] or []))}</p>"]
    if rep["warnings"]:
        parts.append("<h2>Warnings</h2><ul>" + "".join(f"<li>{esc(w)}</li>" for w in rep["warnings"]) + "</ul>")
    parts += ["<h2>Parameters</h2>", html_table(["parameter", "value", "σ", "σ % of |value|"], params),
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
        if s["notes"]:
            parts.append("<ul>" + "".join(f"<li>{esc(n)}</li>" for n in s["notes"]) + "</ul>")
        for joint in s["per_joint"]:
            name = s["figures"].get(joint)
            parts.append(f"<h3>{esc(joint)}</h3>" + (f"<img alt='{esc(joint)}' src='{esc(name)}'>" if name else
                                                     "<p>No row faster than the system's minimum speed.</p>"))
    parts.append("</body></html>")
    return "\n".join(parts)

