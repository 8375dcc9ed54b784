"""Pieces shared by the HTML reports (:mod:`frictionid_core.emps.report`,
:mod:`frictionid_core.reports.result_report`): the page style, tables, PNG bytes and the
friction-vs-velocity axes."""

from __future__ import annotations

import html
import io

import numpy as np

MAX_PLOT_POINTS = 10_000  # points drawn per scatter or trace
REPORT_FILES = ("report.json", "report.html")  # what a report writes into its folder, beside its PNG figures
VELOCITY_BINS = 60  # equal-count velocity bins of the friction plot


PAGE_STYLE = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
              "table{border-collapse:collapse;margin:1em 0;font-size:0.9em}td,th{border:1px solid #bbb;padding:3px 8px;"
              "text-align:right}th{background:#eee}img{max-width:100%}")


def html_table(head: list[str], rows: list[list]) -> str:
    """An HTML table; floats with 6 significant digits."""
    fmt = lambda v: f"{v:.6g}" if isinstance(v, float) else html.escape(str(v))
    return ("<table><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr>"
            + "".join("<tr>" + "".join(f"<td>{fmt(v)}</td>" for v in r) + "</tr>" for r in rows) + "</table>")


def png_bytes(fig) -> bytes:
    """A matplotlib figure as PNG bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    return buf.getvalue()


def friction_axes(ax, velocity: np.ndarray, measured: np.ndarray, friction, params: np.ndarray, units: tuple,
                  measured_label: str) -> None:
    """Friction vs velocity on ``ax``: the measured scatter, its velocity-binned means (equal-count
    bins) and the identified ``friction`` law (a FrictionModel) with ``params``."""
    step = max(1, velocity.size // MAX_PLOT_POINTS)
    ax.plot(velocity[::step], measured[::step], ".", ms=1.5, alpha=0.3, color="0.6", label=measured_label)
    edges = np.quantile(velocity, np.linspace(0.0, 1.0, VELOCITY_BINS + 1))
    idx = np.clip(np.digitize(velocity, edges) - 1, 0, VELOCITY_BINS - 1)
    count = np.bincount(idx, minlength=VELOCITY_BINS)
    filled = count > 0
    centres = np.bincount(idx, velocity, VELOCITY_BINS)[filled] / count[filled]
    means = np.bincount(idx, measured, VELOCITY_BINS)[filled] / count[filled]
    ax.plot(centres, means, "o", ms=4, color="C0", label="measured, binned by velocity")
    vv = np.linspace(velocity.min(), velocity.max(), 800)
    law, sliding = friction.static_equivalent(params)  # a dynamic law: its sliding limit
    ax.plot(vv, law.torque(sliding, vv), "C3", lw=1.8,
            label=f"identified {friction.label}" + (" (sliding limit)" if friction.is_dynamic else ""))
    ax.set(xlabel=f"velocity ({units[1]})", ylabel=f"friction ({units[0]})")
    ax.legend(fontsize=8)
