"""CSV time series: a header row, then one sample per line.

Columns: ``time`` (or ``t``, s), then per joint ``<joint>.position``, ``<joint>.effort`` and
optionally ``<joint>.velocity``. A single joint may use bare ``position``/``effort``/``velocity``
(joint name ``joint``).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.timeseries import JointSeries


def load_csv(path: Path) -> JointSeries:
    """Load a CSV file written in the layout above."""
    try:
        with open(path, encoding="utf-8") as fh, warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": reported below
            header = fh.readline().strip()
            data = np.loadtxt(fh, delimiter=",", ndmin=2)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{path}: not a readable numeric CSV ({exc})") from None
    cols = [c.strip() for c in header.split(",")]
    if data.shape[0] == 0:
        raise InputError(f"{path}: no samples below the header")
    if data.shape[1] != len(cols):
        raise InputError(f"{path}: header has {len(cols)} columns but rows have {data.shape[1]}")
    tcol = next((c for c in ("time", "t") if c in cols), None)
    if tcol is None:
        raise InputError(f"{path}: no 'time' column; columns are {cols}")
    by_name = {c: data[:, i] for i, c in enumerate(cols)}
    fields = {}
    for c in cols:
        joint, _, field = c.rpartition(".")
        if field in ("position", "effort", "velocity"):
            fields.setdefault(joint or "joint", {})[field] = by_name[c]
    if not fields:
        raise InputError(f"{path}: no '<joint>.position' / '<joint>.effort' columns; columns are {cols}")
    joints = list(fields)
    for j in joints:
        for need in ("position", "effort"):
            if need not in fields[j]:
                raise InputError(f"{path}: joint '{j}' has no '{need}' column")
    stack = lambda f: np.column_stack([fields[j][f] for j in joints])  # noqa: E731
    velocity = stack("velocity") if all("velocity" in fields[j] for j in joints) else None
    return JointSeries(t=by_name[tcol], joints=joints, position=stack("position"),
                       effort=stack("effort"), velocity=velocity, source=str(path))


def save_csv(series: JointSeries, path: Path) -> None:
    """Write ``series`` in the layout :func:`load_csv` reads."""
    cols, data = ["time"], [series.t]
    for i, j in enumerate(series.joints):
        cols += [f"{j}.position", f"{j}.effort"]
        data += [series.position[:, i], series.effort[:, i]]
        if series.velocity is not None:
            cols.append(f"{j}.velocity")
            data.append(series.velocity[:, i])
    np.savetxt(path, np.column_stack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
