"""CSV time series: a header row, then one sample per line.

Columns: ``time`` (or ``t``, s), then per joint ``<joint>.position``, ``<joint>.effort`` and
optionally ``<joint>.velocity``. A single joint may use bare ``position``/``effort``/``velocity``
(joint name ``joint``).

Other delimited text files are read through a layout (:mod:`frictionid_core.io.layout`); both
use :func:`read_table`.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.timeseries import JointSeries

# Appended to the errors of a CSV that is not in this format.
LAYOUT_HINT = "; a CSV in another format (no header, other column names, time in ms…) needs --layout FILE"


def load_csv(path: Path) -> JointSeries:
    """Load a CSV file written in the layout above."""
    try:
        cols, data = read_table(path, header=True, delimiter=",")
    except InputError as exc:
        raise InputError(f"{exc}{LAYOUT_HINT}") from None
    tcol = next((c for c in ("time", "t") if c in cols), None)
    if tcol is None:
        raise InputError(f"{path}: no 'time' column; columns are {cols}{LAYOUT_HINT}")
    by_name = {c: data[:, i] for i, c in enumerate(cols)}
    fields = {}
    for c in cols:
        joint, _, field = c.rpartition(".")
        if field in ("position", "effort", "velocity"):
            fields.setdefault(joint or "joint", {})[field] = by_name[c]
    if not fields:
        raise InputError(f"{path}: no '<joint>.position' / '<joint>.effort' columns; columns are {cols}{LAYOUT_HINT}")
    joints = list(fields)
    for j in joints:
        for need in ("position", "effort"):
            if need not in fields[j]:
                raise InputError(f"{path}: joint '{j}' has no '{need}' column{LAYOUT_HINT}")
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


def detect_delimiter(line: str) -> str:
    """The delimiter of a data line: ``;`` if it has one (``,`` may then be a decimal mark), else
    ``,``, else a tab, else ``" "`` (any run of whitespace)."""
    return next((d for d in (";", ",", "\t") if d in line), " ")


def read_table(path: Path, *, header: bool, delimiter: str | None = None) -> tuple[list[str] | None, np.ndarray]:
    """Column names (``header``: the first line names the columns, else None) and the numbers
    (rows, columns) of a delimited text file.

    ``delimiter``: ``,``, ``;``, a tab or ``" "`` (any whitespace); None detects it from the first
    data line (:func:`detect_delimiter`). Blank lines and ``#`` comments are skipped. A cell that is
    not a number gives an InputError naming the file, line (from 1) and column (from 0).
    """
    try:
        with open(path, encoding="utf-8-sig") as fh, warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": reported below
            head = fh.readline() if header else ""
            start = fh.tell()
            delimiter = delimiter or detect_delimiter(_first_data_line(fh) or head)
            fh.seek(start)
            data = np.loadtxt(fh, delimiter=_numpy_delimiter(delimiter), ndmin=2)
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a readable numeric CSV ({exc})") from None
    except ValueError:
        raise _first_bad_cell(path, header, delimiter) from None
    except OSError as exc:
        raise InputError(f"{path}: not a readable numeric CSV ({exc.strerror or exc})") from None
    if data.shape[0] == 0:
        raise InputError(f"{path}: no samples" + (" below the header" if header else ""))
    if not header:
        return None, data
    names = _cells(head, delimiter)
    if len(names) != data.shape[1]:
        raise InputError(f"{path}: header has {len(names)} columns but rows have {data.shape[1]}")
    return names, data


def _numpy_delimiter(delimiter: str) -> str | None:
    return None if delimiter == " " else delimiter


def _cells(line: str, delimiter: str) -> list[str]:
    """The stripped (and unquoted) cells of one line."""
    return [c.strip().strip('"').strip() for c in line.strip().split(_numpy_delimiter(delimiter))]


def _first_data_line(fh) -> str:
    """The next line with data (readline, not iteration: the caller seeks back)."""
    while line := fh.readline():
        if line.split("#", 1)[0].strip():
            return line
    return ""


def _first_bad_cell(path: Path, header: bool, delimiter: str) -> InputError:
    """The error for the first cell numpy could not read (error path only: a Python scan)."""
    with open(path, encoding="utf-8-sig") as fh:
        lines = enumerate(fh, start=1)
        names = _cells(next(lines, (0, ""))[1], delimiter) if header else []
        first = None
        for lineno, line in lines:
            text = line.split("#", 1)[0]
            if not text.strip():
                continue
            cells = _cells(text, delimiter)
            if first is None:
                first = (lineno, len(cells))
            elif len(cells) != first[1]:
                return InputError(f"{path}: not a readable numeric CSV: line {lineno} has {len(cells)} columns, "
                                  f"line {first[0]} has {first[1]} (delimiter {delimiter!r})")
            for col, cell in enumerate(cells):
                try:
                    float(cell)
                except ValueError:
                    label = f" ('{names[col]}')" if col < len(names) else ""
                    what = "empty cell" if not cell else f"{cell!r} is not a number"
                    return InputError(f"{path}: not a readable numeric CSV: line {lineno}, column {col}{label}: "
                                      f"{what} (delimiter {delimiter!r})")
    return InputError(f"{path}: not a readable numeric CSV (delimiter {delimiter!r})")
