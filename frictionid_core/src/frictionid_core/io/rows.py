"""Rows of a log that are no samples: **broken rows** (a value NaN, inf or beyond any measurement, a
time stamp off the log's time line) and **repeated rows** (a sample recorded twice, or republished
under a new stamp by a driver that repeats its last sample). :func:`broken_rows` and
:func:`repeated_rows` find them; :func:`~frictionid_core.io.checks.check_series` drops them with
one warning each, naming how many and where (:class:`Origin`: the file line of a CSV row, else the
sample's index in the log as read).

The time line of a log (:func:`off_the_time_line`): its stamps cut wherever they jump by more than
a gap (SEGMENT_GAP_PERIODS sample periods and SEGMENT_GAP_S), the runs of at least
MAIN_CHAIN_ROWS distinct stamps are the log; a shorter run is off the log's time line when its
stamps are out of order with the runs around it (garbage rows: a stamp of 0, of −0.12, of 47.6 s
in a log at 3048 s) or when it lies before the first or after the last run and further than
ISOLATED_GAPS gaps from it (a stamp from another epoch). Runs of the log that jump back (a clock
set back) and short runs in order between them (a short piece between pauses) are the log's: the
stamp repair and the segments deal with them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.timeseries import SEGMENT_GAP_PERIODS, SEGMENT_GAP_S, JointSeries

# No measured value (s, rad, m, N·m, N and their rates) comes near this; beyond it, squares and sums
# of the fit overflow.
MAX_MAGNITUDE = 1e15
FIELDS = ("position", "effort", "velocity")
MAIN_CHAIN_ROWS = 10  # a run of this many distinct stamps (each within a gap of the one before) is the log
ISOLATED_GAPS = 10  # rows before or after the log further than this many gaps from it are off its time line
RESTAMP_ROWS = 3  # an inner run of at most this many rows off the time line, its values in line: a stamp glitch
LINE_WINDOW = 5  # kept rows either side whose median a row's values are compared with
LINE_FACTOR = 10.0  # a value is out of line beyond this many × its field's sample-to-sample change
LINE_STEP_QUANTILE = 99.0  # … (that change: this percentile of |Δx|, as the spike check's)
# Stale rows: a joint moves into and out of a run of repeated rows in one direction by steps of at
# least STALE_COUNTS × its resolution (its smallest step): slower than a count per sample, a quantised
# position repeats itself (the real WidowX's waist at 0.07 rad/s, 0.46 counts per sample); a log with
# noise on its channels never repeats a row, however slow the joint (a speed floor of 5 % of the top
# speed kept stale rows near reversals, each a step back in time in the acceleration: a simulated
# one-joint log with 11 % stale rows validated at 2.5 × its noise floor, 1.4 × once they were dropped).
STALE_COUNTS = 3
LISTED = 3  # rows named in a message


@dataclass(frozen=True)
class Origin:
    """Where the samples of a series came from, for messages.

    Attributes:
        index: (N,) each sample's row in the log as read (0-based).
        lines: the file line of each row of the log as read (a CSV), or None: a sample is then
            named by its row (a bag's message, a MAT file's sample).
    """

    index: np.ndarray
    lines: np.ndarray | None = None

    @classmethod
    def of(cls, n: int, lines: np.ndarray | None = None) -> Origin:
        """The origin of a log of ``n`` rows as read (``lines``: their file lines)."""
        return cls(np.arange(n), None if lines is None else np.asarray(lines))

    def take(self, index: np.ndarray) -> Origin:
        """The origin of ``series.take(index)``."""
        return Origin(self.index[index], self.lines)

    def name(self, k: int) -> str:
        """Sample ``k`` of the series as a row of the log: ``line L`` or ``sample i``."""
        i = int(self.index[k])
        return f"line {int(self.lines[i])}" if self.lines is not None else f"sample {i}"

    def listing(self, rows: np.ndarray, t: np.ndarray | None = None) -> str:
        """The first LISTED of the samples ``rows`` (with their times ``t[rows]`` in s when given),
        then how many more."""
        shown = [self.name(k) + ("" if t is None else f" ({t[k]:.6g} s)") for k in rows[:LISTED]]
        more = f" and {rows.size - LISTED} more" if rows.size > LISTED else ""
        return ", ".join(shown) + more


# ------------------------------------------------------------------------ broken rows
@dataclass
class BrokenRows:
    """The broken rows of a series (:func:`broken_rows`).

    Attributes:
        values: (N,) rows with a value NaN, inf or beyond ±MAX_MAGNITUDE (stamp or field).
        stamps: (N,) rows, their values good, whose stamps lie off the log's time line.
        restamp: (N,) rows off the time line whose values are in line with the rows around them
            (a glitch of the stamp alone): not broken, their stamps to interpolate.
        first_value: (row, field, joint, value) of the first row in ``values``, or None.
    """

    values: np.ndarray
    stamps: np.ndarray
    restamp: np.ndarray
    first_value: tuple[int, str, str, float] | None

    @property
    def mask(self) -> np.ndarray:
        return self.values | self.stamps

    def details(self, series: JointSeries, origin: Origin) -> str:
        """How many rows are broken, why and where."""
        parts = []
        if self.values.any():
            parts.append(f"{int(self.values.sum())} with a value NaN, inf or beyond ±{MAX_MAGNITUDE:.0e} (the first: "
                         f"{origin.name(self.first_value[0])}, {_value_text(self.first_value)})")
        if self.stamps.any():
            k = int(np.flatnonzero(self.stamps)[0])
            parts.append(f"{int(self.stamps.sum())} with a time stamp off the log's time line (out of order with the "
                         f"rows around it, or isolated from them: the first: {origin.name(k)}, stamp "
                         f"{series.t[k]:.6g} s)")
        return f"{'; '.join(parts)}; at {origin.listing(np.flatnonzero(self.mask))}"

    def note(self, series: JointSeries, origin: Origin) -> str:
        """The warning: how many rows, why, where."""
        return f"{series.source}: {int(self.mask.sum())} broken row(s) skipped (garbage, not samples): " + self.details(
            series, origin)

    def strict_error(self, series: JointSeries, origin: Origin) -> InputError:
        """The error of ``--strict-rows``: the first broken row."""
        k = int(np.flatnonzero(self.mask)[0])
        why = (f"{_value_text(self.first_value)} is not a measured value" if self.values[k]
               else f"its time stamp {series.t[k]:.6g} s is off the log's time line")
        return InputError(f"{series.source}: broken row at {origin.name(k)}: {why}; without --strict-rows broken rows "
                          "are skipped with a warning")


def _value_text(first_value: tuple[int, str, str, float]) -> str:
    _, field, joint, value = first_value
    return f"time stamp {value:.6g}" if field == "time" else f"field '{field}', joint '{joint}': {value:.6g}"


def broken_rows(series: JointSeries, origin: Origin) -> BrokenRows:
    """The broken rows of ``series`` (see the module doc); InputError when they are what the log is
    made of: most stamps not finite or not seconds (a time unit: the layout's ``time: scale``), most
    samples of one field and joint NaN/inf or beyond ±MAX_MAGNITUDE, or more broken rows than good ones."""
    src, t, n = series.source, series.t, len(series)
    finite = np.isfinite(t)
    if 2 * np.count_nonzero(~finite) > n:
        first = int(np.flatnonzero(~finite)[0])
        raise InputError(f"{src}: {n - int(finite.sum())} of {n} time stamps are not finite (the first at "
                         f"{origin.name(first)})")
    typical = float(np.median(np.abs(t[finite])))
    if typical > MAX_MAGNITUDE:
        raise InputError(f"{src}: time stamps around {typical:.3g} s are not seconds; a layout gives the time's unit "
                         "with 'time: {column: …, scale: …}' (1e-9 for ns)")
    values = ~finite | (np.abs(np.where(finite, t, 0.0)) > MAX_MAGNITUDE)
    first_value = None
    if values.any():
        k = int(np.flatnonzero(values)[0])
        first_value = (k, "time", "-", float(t[k]))
    for name in FIELDS:
        arr = getattr(series, name)
        if arr is None:
            continue
        nonfinite = ~np.isfinite(arr)
        huge = np.abs(np.where(nonfinite, 0.0, arr)) > MAX_MAGNITUDE
        for bad, what in ((nonfinite, "NaN/inf samples"),
                          (huge, f"samples beyond ±{MAX_MAGNITUDE:.0e} (not measured values)")):
            counts = bad.sum(axis=0)
            col = int(np.argmax(counts))
            if 2 * counts[col] > n:
                rows = np.flatnonzero(bad[:, col])
                raise InputError(f"{src}: {int(bad.sum())} {what} in field '{name}' (joint '{series.joints[col]}': "
                                 f"{rows.size} of {n}, first at t = {t[rows[0]]:.6g} s)")
        row_bad = (nonfinite | huge).any(axis=1)
        if row_bad.any():
            k = int(np.flatnonzero(row_bad)[0])
            if first_value is None or k < first_value[0]:
                col = int(np.flatnonzero((nonfinite | huge)[k])[0])
                first_value = (k, name, series.joints[col], float(arr[k, col]))
            values |= row_bad
    stamps = np.zeros(n, dtype=bool)
    restamp = np.zeros(n, dtype=bool)
    good = np.flatnonzero(~values)
    off = off_the_time_line(t[good])
    if off.any():
        inner = _inner_short_runs(off)
        candidates = good[inner]
        in_line = _values_in_line(series, good[~off], candidates)
        restamp[candidates[in_line]] = True
        stamps[good[off]] = True
        stamps &= ~restamp
    out = BrokenRows(values, stamps, restamp, first_value)
    broken = int(out.mask.sum())
    if broken > n - broken:
        raise InputError(f"{src}: not a log: {broken} of its {n} rows are broken ({out.details(series, origin)})")
    return out


def off_the_time_line(t: np.ndarray) -> np.ndarray:
    """(N,) True for the stamps ``t`` (finite) off the log's time line (see the module doc)."""
    n = t.size
    off = np.zeros(n, dtype=bool)
    dt = np.diff(t)
    steps = dt[dt > 0]
    if steps.size == 0:
        return off
    gap = max(SEGMENT_GAP_PERIODS * float(np.median(steps)), SEGMENT_GAP_S)
    cuts = np.flatnonzero(np.abs(dt) > gap) + 1
    if cuts.size == 0:
        return off
    edges = np.concatenate(([0], cuts, [n]))
    runs = list(zip(edges[:-1].tolist(), edges[1:].tolist()))
    mains = [k for k, (a, b) in enumerate(runs)
             if b - a >= MAIN_CHAIN_ROWS and np.unique(t[a:b]).size >= MAIN_CHAIN_ROWS]
    if not mains:
        return off
    reach = ISOLATED_GAPS * gap
    upper = t[runs[mains[0]][0]]
    for k in range(mains[0] - 1, -1, -1):  # before the log: in order, leading up to it, not far from it
        a, b = runs[k]
        if t[a:b].max() <= upper and upper - t[a:b].min() <= reach:
            upper = t[a:b].min()
        else:
            off[a:b] = True
    lower = t[runs[mains[-1]][1] - 1]
    for k in range(mains[-1] + 1, len(runs)):  # after the log
        a, b = runs[k]
        if t[a:b].min() >= lower and t[a:b].max() - lower <= reach:
            lower = t[a:b].max()
        else:
            off[a:b] = True
    for p, q in zip(mains[:-1], mains[1:]):  # between two runs of the log
        lo, hi = t[runs[p][1] - 1], t[runs[q][0]]
        for k in range(p + 1, q):
            a, b = runs[k]
            first, last = t[a:b].min(), t[a:b].max()
            if lo <= hi:  # the log goes on forward: in between
                if lo <= first and last <= hi:
                    lo = last
                    continue
            elif first >= lo or last <= hi:  # the clock jumps back there: after the one or before the other
                continue
            off[a:b] = True
    return off


def _inner_short_runs(off: np.ndarray) -> np.ndarray:
    """(N,) True for the rows of runs of ``off`` of at most RESTAMP_ROWS rows with a row not off
    on both sides."""
    out = np.zeros(off.size, dtype=bool)
    padded = np.concatenate(([False], off, [False])).astype(np.int8)
    starts = np.flatnonzero(np.diff(padded) == 1)
    stops = np.flatnonzero(np.diff(padded) == -1)
    for a, b in zip(starts, stops):
        if a > 0 and b < off.size and b - a <= RESTAMP_ROWS:
            out[a:b] = True
    return out


def _values_in_line(series: JointSeries, kept: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """(len(rows),) True for the rows whose every value lies within LINE_FACTOR × its column's
    sample-to-sample change (over the ``kept`` rows) of the median of the LINE_WINDOW kept rows
    on either side."""
    ok = np.ones(rows.size, dtype=bool)
    if rows.size == 0:
        return ok
    at = np.searchsorted(kept, rows)
    around = np.clip(at[:, None] + np.arange(-LINE_WINDOW, LINE_WINDOW)[None, :], 0, kept.size - 1)
    for name in FIELDS:
        arr = getattr(series, name)
        if arr is None:
            continue
        x = arr[kept]
        step = np.abs(np.diff(x, axis=0))
        nonzero = np.where(step > 0, step, np.inf).min(axis=0)
        scale = np.maximum(np.percentile(step, LINE_STEP_QUANTILE, axis=0), np.where(np.isfinite(nonzero), nonzero, 0))
        reference = np.median(x[around], axis=1)  # (rows, J)
        ok &= np.all(np.abs(arr[rows] - reference) <= LINE_FACTOR * scale, axis=1)
    return ok


# ---------------------------------------------------------------------- repeated rows
@dataclass
class RepeatedRows:
    """The repeated rows of a time-sorted series (:func:`repeated_rows`), each (N,) boolean.

    Attributes:
        copies: the stamp and every value of the row before: a sample recorded twice.
        conflicts: the stamp of the row before with other values (the first of a stamp is kept).
        stale: the values of the row before under a new stamp while a joint moves through them.
    """

    copies: np.ndarray
    conflicts: np.ndarray
    stale: np.ndarray

    @property
    def mask(self) -> np.ndarray:
        return self.copies | self.conflicts | self.stale

    def note(self, series: JointSeries, origin: Origin) -> str:
        """The warning: how many, of which kind, where."""
        kinds = [(self.copies, "with the time stamp and values of the row before (recorded twice)"),
                 (self.conflicts, "with the time stamp of the row before but other values (the first kept)"),
                 (self.stale, "stale: the values of the row before under a new time stamp while the joints move (a "
                              "driver republishing its last sample)")]
        parts = [f"{int(mask.sum())} {what}" for mask, what in kinds if mask.any()]
        rows = np.flatnonzero(self.mask)
        return (f"{series.source}: {rows.size} repeated row(s) dropped: {'; '.join(parts)}; at "
                f"{origin.listing(rows, series.t - series.t[0])} from the start")


def repeated_rows(series: JointSeries) -> RepeatedRows:
    """The repeated rows of ``series`` (stamps non-decreasing): copies and conflicts share the stamp
    of the row before; a run of stale rows repeats every value of the row before it (positions,
    velocities, efforts of every joint) under new stamps while some joint moves into and out of
    it in one direction by STALE_COUNTS of its resolution (at rest a noise-free or quantised log
    repeats itself, and a quantised joint creeping slower than a count per sample: those rows are
    kept)."""
    n = len(series)
    values = np.column_stack([a for a in (series.position, series.velocity, series.effort) if a is not None])
    same_stamp = np.concatenate(([False], np.diff(series.t) == 0))
    # a row with the stamp of the row before compares with the first row of that stamp
    first = np.maximum.accumulate(np.where(same_stamp, 0, np.arange(n)))
    copies = same_stamp & np.all(values == values[first], axis=1)
    conflicts = same_stamp & ~copies
    stale = np.zeros(n, dtype=bool)
    kept = np.flatnonzero(~same_stamp)
    repeat = np.flatnonzero(np.all(values[kept][1:] == values[kept][:-1], axis=1)) + 1
    if repeat.size:
        stale[kept[_stale_runs(series.t[kept], series.position[kept], repeat)]] = True
    return RepeatedRows(copies, conflicts, stale)


def _stale_runs(t: np.ndarray, q: np.ndarray, repeat: np.ndarray) -> np.ndarray:
    """The rows of ``repeat`` (rows equal to the row before, of increasing stamps ``t``) in runs
    that a joint of positions ``q`` (N, J) moves into and out of (see :func:`repeated_rows`)."""
    n = t.size
    step = np.abs(np.diff(q, axis=0))
    speed = step / np.diff(t)[:, None]
    top = np.percentile(speed, 99.0, axis=0)
    moving = top > 0
    resolution = np.where(step > 0, step, np.inf).min(axis=0)
    out = []
    breaks = np.flatnonzero(np.diff(repeat) > 1) + 1
    for run in np.split(repeat, breaks):
        a, b = int(run[0]), int(run[-1])  # rows a…b repeat row a − 1
        if a < 2 or b + 1 >= n:
            continue
        step_in, step_out = q[a - 1] - q[a - 2], q[b + 1] - q[b]
        through = ((np.minimum(np.abs(step_in), np.abs(step_out)) >= STALE_COUNTS * resolution)
                   & (np.sign(step_in) == np.sign(step_out)) & moving)
        if through.any():
            out.append(run)
    return np.concatenate(out) if out else np.empty(0, dtype=np.intp)

