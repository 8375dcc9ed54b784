"""Log layouts: where the time, positions, velocities and efforts sit in a CSV of any shape.

A layout is stated in YAML (:func:`load_layout`)::

    header: false                 # true: the first row names the columns (never guessed)
    time: {column: 0, scale: 1.0} # index or header name; scale converts to seconds (ms: 0.001)
    # rate_hz: 5000               # instead of time: evenly spaced samples from t = 0
    joints: [joint_1, ...]
    position: [1, 2, 3]           # 0-based indices or header names, one per joint
    velocity: [7, 8, 9]           # optional
    effort: [13, 14, 15]
    effort_file: other.csv        # optional: efforts in a second file with the same rows, beside the source
    delimiter: ";"                # optional: , ; tab or whitespace (default: detected per file)

Values are taken as recorded (a motor-side log is converted by :mod:`frictionid_core.drive.transmission`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.files import check_keys, joint_names, read_yaml
from frictionid_core.io.csv import read_table
from frictionid_core.timeseries import JointSeries

LAYOUT_KEYS = ("header", "time", "rate_hz", "joints", "position", "velocity", "effort", "effort_file",
               "delimiter")
TIME_KEYS = ("column", "scale")
DELIMITERS = {",": ",", ";": ";", "\t": "\t", "tab": "\t", " ": " ", "whitespace": " "}

Column = int | str


@dataclass(frozen=True)
class Layout:
    """Columns of a delimited text log (validated on creation; see the module doc).

    Attributes:
        joints: joint names, length J.
        position: column of each joint's position (0-based index or header name).
        effort: column of each joint's effort (in ``effort_file`` when given).
        header: the first line names the columns.
        time_column: column of the time stamps (or None with ``rate_hz``).
        time_scale: time unit → s (0.001 for ms).
        rate_hz: sample rate, Hz, of a log without a time column.
        velocity: column of each joint's velocity, or None.
        effort_file: file of the efforts (same rows), relative to the source's folder.
        delimiter: ``,``, ``;``, a tab or ``" "`` (any whitespace); None: detected per file.
        source: the layout file (for messages; not compared).
    """

    joints: tuple[str, ...]
    position: tuple[Column, ...]
    effort: tuple[Column, ...]
    header: bool = False
    time_column: Column | None = None
    time_scale: float = 1.0
    rate_hz: float | None = None
    velocity: tuple[Column, ...] | None = None
    effort_file: str | None = None
    delimiter: str | None = None
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        where = self.source or "layout"
        if not isinstance(self.header, bool):
            raise InputError(f"{where}: key 'header' must be true or false, got {self.header!r}")
        joints = joint_names(self.joints, where)
        if (self.time_column is None) == (self.rate_hz is None):
            raise InputError(f"{where}: give exactly one of 'time' (a time column) and 'rate_hz' "
                             "(evenly spaced samples)")
        if self.time_column is not None:
            self._check_column(self.time_column, "time", where)
        for key in ("time_scale", "rate_hz"):
            value = getattr(self, key)
            if value is not None and (isinstance(value, bool) or not _positive(value)):
                shown = "time: scale" if key == "time_scale" else key
                raise InputError(f"{where}: key '{shown}' must be a number > 0, got {value!r}")
        fixed = {"joints": joints}
        for key in ("position", "effort", "velocity"):
            refs = getattr(self, key)
            if refs is None and key == "velocity":
                continue
            if isinstance(refs, (str, bytes)) or not isinstance(refs, (list, tuple)):
                raise InputError(f"{where}: key '{key}' must be a list of {len(joints)} columns (one per joint), "
                                 f"got {refs!r}")
            if len(refs) != len(joints):
                raise InputError(f"{where}: key '{key}' has {len(refs)} columns for {len(joints)} joints "
                                 f"{list(joints)}")
            for ref in refs:
                self._check_column(ref, key, where)
            fixed[key] = tuple(refs)
        if self.effort_file is not None and not (isinstance(self.effort_file, str) and self.effort_file):
            raise InputError(f"{where}: key 'effort_file' must be a file name, got {self.effort_file!r}")
        if self.delimiter is not None:
            if not isinstance(self.delimiter, str) or self.delimiter not in DELIMITERS:
                raise InputError(f"{where}: key 'delimiter' is {self.delimiter!r}; choose one of "
                                 f"',', ';', tab, whitespace")
            fixed["delimiter"] = DELIMITERS[self.delimiter]
        fixed["time_scale"] = float(self.time_scale)
        if self.rate_hz is not None:
            fixed["rate_hz"] = float(self.rate_hz)
        for key, value in fixed.items():
            object.__setattr__(self, key, value)

    def _check_column(self, ref, key: str, where: str) -> None:
        if isinstance(ref, str) and ref:
            if not self.header:
                raise InputError(f"{where}: key '{key}': column '{ref}' is a name but 'header' is false; "
                                 "give 0-based column indices")
        elif isinstance(ref, bool) or not isinstance(ref, int) or ref < 0:
            raise InputError(f"{where}: key '{key}': column {ref!r} is neither a 0-based index nor a header name")


def layout_from_dict(data: dict, source: str = "") -> Layout:
    """A :class:`Layout` from a mapping of the YAML keys (unknown keys refused); ``source`` names it
    in messages."""
    where = source or "layout"
    check_keys(data, LAYOUT_KEYS, where, required=("joints", "position", "effort"))
    time = data.get("time")
    if time is not None:
        if not isinstance(time, dict):
            raise InputError(f"{where}: key 'time' must be a mapping {{column: …, scale: …}}, got {time!r}")
        check_keys(time, TIME_KEYS, f"{where}: key 'time'", required=("column",))
    return Layout(joints=data["joints"], position=data["position"], effort=data["effort"],
                  header=data.get("header", False), time_column=None if time is None else time["column"],
                  time_scale=1.0 if time is None else time.get("scale", 1.0), rate_hz=data.get("rate_hz"),
                  velocity=data.get("velocity"),
                  effort_file=data.get("effort_file"), delimiter=data.get("delimiter"), source=source)


def load_layout(path: str | Path) -> Layout:
    """The layout in a YAML file."""
    return layout_from_dict(read_yaml(path, "a log layout"), str(Path(path).expanduser()))


def read_with_layout(source: str | Path, layout: Layout, *, strict_rows: bool = False) -> JointSeries:
    """The log in ``source`` (and ``layout.effort_file``) as a :class:`JointSeries`, values as recorded.

    Broken rows are skipped (see :func:`~frictionid_core.io.csv.read_table`; ``strict_rows``
    refuses them); with an effort file, a row broken in either file is left out of both, and
    with ``rate_hz`` the rows keep their times (row number / rate)."""
    return read_layout_log(source, layout, strict_rows=strict_rows)[0]


def read_layout_log(source: str | Path, layout: Layout, *, strict_rows: bool = False
                    ) -> tuple[JointSeries, np.ndarray]:
    """(the series of :func:`read_with_layout`, the line of each of its samples in ``source``)."""
    path = Path(source)
    where = layout.source or "layout"
    own = {"time": [layout.time_column]} if layout.time_column is not None else {}
    own["position"] = list(layout.position)
    if layout.velocity is not None:
        own["velocity"] = list(layout.velocity)
    if not layout.effort_file:
        own["effort"] = list(layout.effort)
    table, at = _read(path, layout, own, where, strict_rows)
    notes = [f"read with layout {where}", *table.notes]
    data, rows, lines = table.data, None, table.lines
    if layout.effort_file:
        epath = path.parent / layout.effort_file
        if not epath.is_file():
            raise InputError(f"{epath}: no such file (key 'effort_file' of {where})")
        etable, eat = _read(epath, layout, {"effort": list(layout.effort)}, where, strict_rows)
        if etable.rows != table.rows:
            raise InputError(f"{epath}: {etable.rows} rows but {path} has {table.rows}; the effort file "
                             f"(key 'effort_file' of {where}) must have the same rows")
        notes += [f"efforts from {epath}", *etable.notes]
        edata = etable.data
        if table.skipped.size or etable.skipped.size:  # the rows good in both files
            rows, in_own, in_effort = np.intersect1d(table.row_numbers(), etable.row_numbers(), assume_unique=True,
                                                     return_indices=True)
            data, edata, lines = data[in_own], edata[in_effort], lines[in_own]
            lost = table.rows - table.skipped.size - rows.size + etable.rows - etable.skipped.size - rows.size
            if lost:
                notes.append(f"{lost} row(s) broken in only one of {path} and {epath} left out of both")
        effort = edata[:, eat["effort"]]
    else:
        effort = data[:, at["effort"]]
    if layout.rate_hz is not None:
        t = (table.row_numbers() if rows is None else rows) / layout.rate_hz
    else:
        t = data[:, at["time"][0]] * layout.time_scale
    velocity = None if layout.velocity is None else data[:, at["velocity"]]
    return JointSeries(t, list(layout.joints), data[:, at["position"]], effort, velocity, source=str(path),
                       notes=notes), lines


def _read(path: Path, layout: Layout, refs: dict[str, list], where: str, strict_rows: bool):
    """(the table of the columns of ``refs`` {layout key: column references} in ``path``, {key:
    positions of its columns in the table's data})."""
    index: dict[str, list[int]] = {}

    def columns(names: list[str] | None, ncols: int) -> list[int]:
        for key, keyed in refs.items():
            index[key] = _indices(keyed, key, path, names, ncols, where)
        return sorted({i for keyed in index.values() for i in keyed})

    table = read_table(path, header=layout.header, delimiter=layout.delimiter, columns=columns,
                       strict_rows=strict_rows)
    position = {column: k for k, column in enumerate(table.columns)}
    return table, {key: [position[i] for i in keyed] for key, keyed in index.items()}


def _indices(refs, key: str, file: Path, names: list[str] | None, ncols: int, where: str) -> list[int]:
    """0-based column indices of ``refs`` (indices or header names) in ``file``."""
    unknown = [r for r in refs if isinstance(r, str) and r not in names]
    if unknown:
        raise InputError(f"{where}: key '{key}': column(s) {unknown} not in the header of {file}; "
                         f"available: {names}")
    out = [names.index(r) if isinstance(r, str) else r for r in refs]
    beyond = [r for r in out if r >= ncols]
    if beyond:
        raise InputError(f"{where}: key '{key}': column index(es) {beyond} out of range: {file} has {ncols} "
                         f"columns (indices 0…{ncols - 1})")
    return out


def _positive(value) -> bool:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return False
    return math.isfinite(x) and x > 0

