"""The fleet's dashboard, ``DIR/index.html``: a fleet overview table, the alarms, the logs that failed,
and per robot and joint a figure of each watched parameter over time (``DIR/plots/``, linked).

Each figure shows the identified values with their ±σ band, the baseline (its logs shaded, its
expected value, ±3 spreads around it) and the first alarm, marked at its log.
"""

from __future__ import annotations

import html
import re
from datetime import datetime
from pathlib import Path

import numpy as np

from frictionid_core.reports import PAGE_STYLE, html_table, png_bytes

PLOTS = "plots"


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text) or "_"


def _overview(run, config) -> list[list]:
    """One row per robot: logs fitted and failed, the time span, alarms, status."""
    rows = []
    for robot in config.robots:
        fitted = [r for r in run.records if r["robot"] == robot.name]
        failed = [f for f in run.failed if f["robot"] == robot.name]
        alarms = [a for a in run.alarms if a["robot"] == robot.name]
        tests = [t for t in run.series if t.robot == robot.name]
        untested = sorted({t.note for t in tests if t.note})
        if alarms:
            status = "ALARM"
        elif untested and all(t.expected is None for t in tests):
            status = "; ".join(untested)
        else:
            status = "ok"
        span = f"{fitted[0]['start_time'][:10]} … {fitted[-1]['start_time'][:10]}" if fitted else "—"
        first = ", ".join(f"{a['joint']}/{a['parameter']} {a['direction']} at {a['first_log']}" for a in alarms)
        rows.append([robot.name, len(fitted), len(failed), span, len(alarms), first or "—", status])
    return rows


def _figure(tests: list, path: Path) -> None:
    """The watched parameters of one robot and joint over time (module doc), as a PNG at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(tests), 1, figsize=(9, 2.6 * len(tests)), squeeze=False, sharex=True)
    for ax, test in zip(axes[:, 0], tests):
        when = [datetime.fromisoformat(s) for s in test.start_times]
        values, sigmas = test.values, np.where(np.isfinite(test.sigmas), test.sigmas, 0.0)
        ax.fill_between(when, values - sigmas, values + sigmas, color="C0", alpha=0.25, lw=0, label="±σ")
        ax.plot(when, values, "o-", ms=3, lw=1, color="C0", label=test.parameter)
        b = min(test.baseline_logs, len(when))
        if b:
            ax.axvspan(when[0], when[b - 1], color="0.85", alpha=0.5, lw=0, label=f"baseline ({b} logs)")
        if test.expected is not None:
            ax.plot(when, test.expected, color="k", lw=1, label="baseline value")
            ax.fill_between(when, test.expected - 3 * test.spread, test.expected + 3 * test.spread, color="k",
                            alpha=0.07, lw=0, label="±3 spreads")
        if test.alarm is not None:
            k = test.alarm
            ax.axvline(when[k], color="C3", lw=1.2)
            ax.plot([when[k]], [values[k]], "o", ms=9, mfc="none", mec="C3", mew=2, label="first alarm")
        ax.set_ylabel(test.parameter)
        ax.set_title(f"{test.robot} · {test.joint or '(robot)'} · {test.parameter}"
                     + (f" — {test.note}" if test.note else ""), fontsize=9)
        ax.legend(fontsize=7, loc="best")
    fig.autofmt_xdate()
    path.write_bytes(png_bytes(fig))
    plt.close(fig)


def write_dashboard(run, config) -> Path:
    """Write ``index.html`` and its figures in ``run.out_dir``; returns the page's path."""
    from frictionid_core.files import write_text

    plots = run.out_dir / PLOTS
    plots.mkdir(parents=True, exist_ok=True)
    esc = html.escape
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>frictionid fleet</title>"
             f"<style>{PAGE_STYLE}</style></head><body>",
             f"<h1>Friction health of the fleet</h1><p>{esc(str(config.path))}: {run.logs} logs of "
             f"{len(config.robots)} robots; {run.fitted_now} fitted in this run, {run.skipped} found fitted, "
             f"{len(run.failed)} failed; {len(run.alarms)} alarms. Drift test: baseline of the first "
             f"{config.baseline_logs} logs, two-sided CUSUM (reference {config.alarm.reference:g} spreads), "
             f"false-alarm rate {config.alarm.false_alarm_rate:g} per robot, watched parameter and log.</p>"]
    if run.set_aside:
        parts.append("<p><b>Damaged store records set aside and recomputed:</b><br>"
                     + "<br>".join(esc(m) for m in run.set_aside) + "</p>")
    parts += ["<h2>Fleet</h2>",
              html_table(["robot", "logs fitted", "failed", "first … last log", "alarms", "first alarms", "status"],
                         _overview(run, config))]
    if run.alarms:
        parts += ["<h2>Alarms</h2>",
                  html_table(["robot", "joint", "parameter", "first log", "start time", "baseline", "value", "z",
                              "direction"],
                             [[a["robot"], a["joint"], a["parameter"], a["first_log"], a["start_time"], a["baseline"],
                               a["value"], a["z"], a["direction"]] for a in run.alarms])]
    if run.failed:
        parts += ["<h2>Logs that could not be fitted</h2>",
                  html_table(["robot", "log", "attempts", "error"],
                             [[f["robot"], f["log"], f["attempts"], f["error"]] for f in run.failed])]
    used: set[str] = set()
    for robot in config.robots:
        tests = [t for t in run.series if t.robot == robot.name]
        if not tests:
            continue
        parts.append(f"<h2 id='{esc(_slug(robot.name))}'>{esc(robot.name)}</h2>")
        for joint in dict.fromkeys(t.joint for t in tests):
            mine = [t for t in tests if t.joint == joint]
            name = f"{_slug(robot.name)}__{_slug(joint or 'robot')}"
            while name in used:
                name += "_"
            used.add(name)
            _figure(mine, plots / f"{name}.png")
            parts.append(f"<h3>{esc(joint or '(robot)')}</h3><img src='{PLOTS}/{esc(name)}.png' "
                         f"alt='{esc(robot.name)} {esc(joint)}'>")
    parts.append("</body></html>")
    return write_text(run.out_dir / "index.html", "\n".join(parts) + "\n")
