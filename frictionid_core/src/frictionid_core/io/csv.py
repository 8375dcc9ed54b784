"""CSV time series: a header row, then one sample per line.

Columns: ``time`` (or ``t``, s), then per joint ``<joint>.position``, ``<joint>.effort`` and
optionally ``<joint>.velocity``. A single joint may use bare ``position``/``effort``/``velocity``
(joint name ``joint``).

Other delimited text files are read through a layout (:mod:`frictionid_core.io.layout`); both
use :func:`read_table`: blocks of lines into float64 arrays of the columns used only, broken rows
skipped with a warning (or refused), absurd sizes refused early.
"""

from __future__ import annotations

import os
import warnings
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.timeseries import JointSeries

# Appended to the errors of a CSV that is not in this format.
LAYOUT_HINT = "; a CSV in another format (no header, other column names, time in ms…) needs --layout FILE"
FIELDS = ("position", "effort", "velocity")

MAX_LINE_CHARS = 1 << 20  # a longer line is not a row of a log
MAX_COLUMNS = 10_000  # cells of a row
MAX_VALUES = 50_000_000  # rows × columns used (0.4 GB as float64): a longer log is refused
ESTIMATE_MARGIN = 1.1  # a size estimated from the first lines refuses a log this far above MAX_VALUES
BLOCK_BYTES = 1 << 23  # read at a time
PROBE_LINES = 1000  # first data lines that decide the delimiter and (without a header) the column count
JUDGED_ROWS = 1000  # from this many rows read, broken rows outnumbering good ones refuse the file


def load_csv(path: Path, *, strict_rows: bool = False) -> JointSeries:
    """Load a CSV file written in the layout above (``strict_rows``: see :func:`read_table`)."""
    return read_csv(path, strict_rows=strict_rows)[0]


def read_csv(path: Path, *, strict_rows: bool = False) -> tuple[JointSeries, np.ndarray]:
    """(the series of :func:`load_csv`, the file line of each of its samples)."""
    joints: dict[str, dict[str, int]] = {}

    def used(names: list[str], ncols: int) -> list[int]:
        tcol = next((c for c in ("time", "t") if c in names), None)
        if tcol is None:
            raise InputError(f"{path}: no 'time' column; columns are {names}{LAYOUT_HINT}")
        for i, c in enumerate(names):
            joint, _, field = c.rpartition(".")
            if field in FIELDS:
                joints.setdefault(joint or "joint", {})[field] = i
        if not joints:
            raise InputError(f"{path}: no '<joint>.position' / '<joint>.effort' columns; columns are {names}"
                             f"{LAYOUT_HINT}")
        for j, have in joints.items():
            for need in ("position", "effort"):
                if need not in have:
                    raise InputError(f"{path}: joint '{j}' has no '{need}' column{LAYOUT_HINT}")
        return [names.index(tcol)] + [i for have in joints.values() for i in have.values()]

    table = read_table(path, header=True, delimiter=",", columns=used, strict_rows=strict_rows, hint=LAYOUT_HINT)
    at = {column: k for k, column in enumerate(table.columns)}
    names = list(joints)

    def stack(field: str) -> np.ndarray:
        return table.data[:, [at[joints[j][field]] for j in names]]

    velocity = stack("velocity") if all("velocity" in joints[j] for j in names) else None
    return JointSeries(t=table.data[:, 0], joints=names, position=stack("position"), effort=stack("effort"),
                       velocity=velocity, source=str(path), notes=list(table.notes)), table.lines


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


@dataclass
class Table:
    """The numbers of a delimited text file (see :func:`read_table`).

    Attributes:
        names: the header's column names, or None without a header.
        columns: the file's column (0-based) of each column of ``data``.
        data: (good rows, len(columns)) float64, in file order.
        rows: data rows in the file, broken ones included (blank and ``#`` comment lines are not rows).
        skipped: (B,) the 0-based data-row numbers of the broken rows skipped, increasing.
        notes: what was skipped (one note, or none).
        lines: (good rows,) the file line (1-based) of each row of ``data``.
    """

    names: list[str] | None
    columns: list[int]
    data: np.ndarray
    rows: int
    skipped: np.ndarray
    notes: list[str]
    lines: np.ndarray | None = None

    def row_numbers(self) -> np.ndarray:
        """(len(data),) the 0-based data-row number of each row of ``data``."""
        return np.delete(np.arange(self.rows), self.skipped)


def read_table(path: Path, *, header: bool, delimiter: str | None = None,
               columns: Callable[[list[str] | None, int], list[int]] | None = None,
               strict_rows: bool = False, hint: str = "") -> Table:
    """The numbers of a delimited text file, read in blocks, of the columns asked for only.

    Args:
        path: the file.
        header: the first line names the columns.
        delimiter: ``,``, ``;``, a tab or ``" "`` (any whitespace); None: the one most of the first
            data lines have (:func:`detect_delimiter`).
        columns: ``columns(names, ncols)`` → the 0-based columns to keep (``names``: the header's,
            or None); it may raise InputError. Default: every column.
        strict_rows: refuse the first broken row instead of skipping broken rows.
        hint: appended to the errors that say the file is not in the expected format.

    Blank lines and ``#`` comments are skipped. A row is broken when it has another number of
    cells than the header (without a header: than most of the first rows) or a kept cell that is
    not a number; broken rows are skipped with a note (also a UserWarning) giving their count and
    the first one's line. InputError naming the file (and line) for a header naming a column
    twice, a broken row under ``strict_rows``, more broken rows than good ones, a line longer than
    MAX_LINE_CHARS, more than MAX_COLUMNS columns or MAX_VALUES values kept, and no good row.
    """
    try:
        fh = open(path, "rb")
    except OSError as exc:
        raise InputError(f"{path}: not a readable numeric CSV ({exc.strerror or exc})") from None
    with fh:
        size = os.fstat(fh.fileno()).st_size
        blocks = _blocks(fh, path)
        start, lines = next(blocks, (1, []))
        if not lines:
            raise InputError(f"{path}: no samples (empty file)")
        head = ""
        if header:
            head, lines, start = lines[0], lines[1:], start + 1
        probe = _data_lines(lines)
        if delimiter is None:
            votes = Counter(map(detect_delimiter, probe))
            delimiter = votes.most_common(1)[0][0] if votes else detect_delimiter(head)
        names = _cells(head, delimiter) if header else None
        counted = _column_count(probe, delimiter)
        if names is not None:
            ncols = len(names)
            repeated = [c for c in dict.fromkeys(names) if names.count(c) > 1]
            if repeated:
                raise InputError(f"{path}: column name(s) {repeated} appear more than once in the header: which "
                                 "column is meant is ambiguous")
            if counted is not None and counted[1] and counted[0] != ncols:
                raise InputError(f"{path}: header has {ncols} columns but rows have {counted[0]}{hint}")
        elif counted is None:
            raise InputError(f"{path}: no samples")
        else:
            ncols = counted[0]
        if ncols > MAX_COLUMNS:
            raise InputError(f"{path}: {ncols:,} columns, more than the {MAX_COLUMNS:,} a log may have")
        keep = list(range(ncols)) if columns is None else list(columns(names, ncols))
        rows = _Rows(path, delimiter, ncols, keep, names, strict_rows, hint)
        estimate = _estimated_rows(size, lines)
        rows.check_size(estimate, estimated=True)
        out = np.empty((min(estimate + estimate // 8 + 1024, MAX_VALUES // max(len(keep), 1) + 1), len(keep)))
        n = 0
        for first, block in _chain((start, lines), blocks):
            values = rows.parse(block, first)
            if n + len(values) > out.shape[0]:
                rows.check_size(n + len(values))
                grown = np.empty((max(2 * out.shape[0], n + len(values)), len(keep)))
                grown[:n] = out[:n]
                out = grown
            out[n: n + len(values)] = values
            n += len(values)
    if n == 0:
        if rows.broken:
            raise rows.error(f"{path}: not a readable numeric CSV: all {rows.broken:,} rows are broken")
        raise InputError(f"{path}: no samples" + (" below the header" if header else ""))
    rows.judge(final=True)
    out.resize((n, len(keep)), refcheck=False)  # the array's only reference: shrinks in place
    notes = [rows.note()] if rows.broken else []
    for note in notes:
        warnings.warn(note, UserWarning, stacklevel=2)
    lines = np.concatenate(rows.lines) if rows.lines else np.empty(0, dtype=np.int64)
    return Table(names, keep, out, rows.rows, np.asarray(rows.skipped, dtype=np.int64), notes, lines)


class _Rows:
    """Parses blocks of lines into the kept columns, counting and remembering the broken rows."""

    def __init__(self, path: Path, delimiter: str, ncols: int, keep: list[int], names: list[str] | None,
                 strict: bool, hint: str):
        self.path, self.delimiter, self.ncols, self.keep, self.names = path, delimiter, ncols, keep, names
        self.strict, self.hint = strict, hint
        self.split = None if delimiter == " " else delimiter
        self.rows = 0  # data rows read, broken ones included
        self.broken = 0
        self.skipped: list[int] = []
        self.lines: list[np.ndarray] = []  # the file line of each good row, block by block
        self.first: tuple[int, str] | None = None  # (line, what is wrong) of the first broken row

    def check_size(self, rows: int, estimated: bool = False) -> None:
        """InputError when ``rows`` × the kept columns exceed MAX_VALUES (estimated: ESTIMATE_MARGIN × it)."""
        if rows * len(self.keep) <= (ESTIMATE_MARGIN if estimated else 1.0) * MAX_VALUES:
            return
        what = f"about {rows:,} rows (estimated from its size)" if estimated else f"more than {rows:,} rows"
        raise InputError(f"{self.path}: {what} × {len(self.keep)} columns used: more than the {MAX_VALUES:,} values "
                         f"({MAX_VALUES * 8 / 1e9:.1f} GB as float64) frictionid reads from one log; cut it into "
                         "shorter logs")

    def parse(self, lines: list[str], start: int) -> np.ndarray:
        """The good rows of ``lines`` (the first at line ``start`` of the file), (m, kept columns)."""
        if any("#" in line for line in lines):
            lines = [line.split("#", 1)[0] for line in lines]
        if self.split is None:
            counts, expected = [len(line.split()) for line in lines], self.ncols
        else:
            counts, expected = [line.count(self.split) for line in lines], self.ncols - 1
        good, bad = [], []
        for i, count in enumerate(counts):
            if count == expected and (self.ncols > 1 or lines[i].strip()):
                good.append(i)
            elif count != expected and lines[i].strip():
                bad.append(i)
        values, rejected = _numbers([lines[i] for i in good], self.split, self.keep)
        self.lines.append(start + np.delete(np.asarray(good, dtype=np.int64), rejected))
        if bad or rejected:
            data_lines = np.array(sorted(good + bad))  # blank lines are no rows
            bad = sorted(bad + [good[k] for k in rejected])
            if self.first is None:
                self.first = (start + bad[0], self._why(lines[bad[0]]))
                if self.strict:
                    raise self.error(f"{self.path}: broken row")
            self.broken += len(bad)
            self.skipped.extend((self.rows + np.searchsorted(data_lines, bad)).tolist())
            self.rows += data_lines.size
        else:
            self.rows += len(good)
        self.judge()
        return values

    def judge(self, final: bool = False) -> None:
        """InputError when broken rows outnumber the good ones: a file of another format."""
        if self.broken > self.rows - self.broken and (final or self.rows >= JUDGED_ROWS):
            raise self.error(f"{self.path}: not a readable numeric CSV: {self.broken:,} of the {self.rows:,} rows "
                             "read are broken")

    def error(self, head: str) -> InputError:
        """``head`` with the first broken row: what is wrong with it, where."""
        line, why = self.first
        if self.strict:
            return InputError(f"{head} at line {line}: {why} (delimiter {self.delimiter!r}); without "
                              "--strict-rows broken rows are skipped with a warning")
        return InputError(f"{head}, the first at line {line}: {why} (delimiter {self.delimiter!r}){self.hint}")

    def note(self) -> str:
        line, why = self.first
        return (f"{self.path}: {self.broken:,} broken row(s) skipped (malformed, not numeric or truncated); the "
                f"first at line {line}: {why}")

    def _why(self, line: str) -> str:
        """What is wrong with the broken ``line``."""
        cells = _cells(line, self.delimiter)
        if len(cells) != self.ncols:
            return (f"{len(cells)} cell(s) where {'the header has' if self.names is not None else 'the rows have'} "
                    f"{self.ncols}")
        for col in self.keep:
            if not _is_number(cells[col]):
                label = f" ('{self.names[col]}')" if self.names is not None else ""
                what = "empty cell" if not cells[col] else f"{_shorten(cells[col])!r} is not a number"
                return f"column {col}{label}: {what}"
        return "not numbers"


def _numbers(lines: list[str], split: str | None, keep: list[int]) -> tuple[np.ndarray, list[int]]:
    """(values (m, len(keep)) of the lines numpy reads, indices of the lines it cannot read):
    np.loadtxt on the whole list; on failure on each half, down to the bad lines."""
    if not lines:
        return np.empty((0, len(keep))), []
    try:
        return np.loadtxt(lines, delimiter=split, usecols=keep, ndmin=2, comments=None, quotechar='"'), []
    except ValueError:
        if len(lines) == 1:
            return np.empty((0, len(keep))), [0]
    mid = len(lines) // 2
    a, bad_a = _numbers(lines[:mid], split, keep)
    b, bad_b = _numbers(lines[mid:], split, keep)
    return np.concatenate([a, b]), bad_a + [mid + k for k in bad_b]


def _blocks(fh, path: Path) -> Iterator[tuple[int, list[str]]]:
    """(line number of the first line, lines) of the file, about BLOCK_BYTES at a time; InputError
    for a line longer than MAX_LINE_CHARS. Bytes that are not UTF-8 become U+FFFD (their row is
    then not numeric); a leading byte-order mark is dropped."""
    line, rest, first = 1, b"", True
    while True:
        chunk = fh.read(BLOCK_BYTES)
        data = rest + chunk
        cut = data.rfind(b"\n") + 1 if chunk else len(data)
        body, rest = data[:cut], data[cut:]
        if len(rest) > MAX_LINE_CHARS:
            raise _long_line(path, line + body.count(b"\n"))
        if body:
            text = body.decode("utf-8", errors="replace")
            if first:
                text, first = text.removeprefix("\ufeff"), False
            lines = text.split("\n")
            if lines[-1] == "":
                lines.pop()
            if max(map(len, lines)) > MAX_LINE_CHARS:
                raise _long_line(path, line + next(i for i, s in enumerate(lines) if len(s) > MAX_LINE_CHARS))
            yield line, lines
            line += len(lines)
        if not chunk:
            return


def _long_line(path: Path, line: int) -> InputError:
    return InputError(f"{path}: line {line:,} is longer than {MAX_LINE_CHARS:,} characters: not a row of a log")


def _chain(first, rest):
    yield first
    yield from rest


def _estimated_rows(size: int, lines: list[str]) -> int:
    """Rows of a file of ``size`` bytes that starts with ``lines``."""
    nbytes = sum(len(line) + 1 for line in lines)
    return int(size * len(lines) / nbytes) if nbytes else 0


def _data_lines(lines: list[str]) -> list[str]:
    """The first PROBE_LINES data lines of ``lines`` (comments removed, blank lines left out)."""
    out = []
    for line in lines:
        text = line.split("#", 1)[0]
        if text.strip():
            out.append(text)
            if len(out) == PROBE_LINES:
                break
    return out


def _column_count(lines: list[str], delimiter: str) -> tuple[int, bool] | None:
    """(the most common cell count of ``lines``, True when taken over rows of numbers only):
    over the lines whose cells are all numbers if there are any, else over all; None without lines."""
    cells = [_cells(line, delimiter) for line in lines]
    numeric = [len(c) for c in cells if all(map(_is_number, c))]
    counts = Counter(numeric or [len(c) for c in cells])
    return (counts.most_common(1)[0][0], bool(numeric)) if counts else None


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _shorten(cell: str, width: int = 40) -> str:
    return cell if len(cell) <= width else cell[: width - 1] + "…"


def _cells(line: str, delimiter: str) -> list[str]:
    """The stripped (and unquoted) cells of one line."""
    return [c.strip().strip('"').strip() for c in line.strip().split(None if delimiter == " " else delimiter)]
