"""One call for every source: :func:`load` picks the reader by the file's suffix (MAT, CSV with or
without a layout, rosbag2 MCAP/sqlite3, ROS 1 bag) and checks the series it returns."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from frictionid_core.errors import InputError
from frictionid_core.io.checks import check_series
from frictionid_core.timeseries import JointSeries

if TYPE_CHECKING:
    from frictionid_core.io.layout import Layout

BAG_SUFFIXES = (".mcap", ".db3", ".bag")


def load(
    source: str | Path,
    *,
    topic: str | None = None,
    joints: list[str] | None = None,
    effort_topic: str | None = None,
    strict_time: bool = False,
    extras: dict[str, tuple[str, str]] | None = None,
    layout: str | Path | Layout | None = None,
    strict_rows: bool = False,
) -> JointSeries:
    """Load joint measurements from a MAT (EMPS), CSV, rosbag2 (MCAP/sqlite3) or ROS 1 bag.

    Args:
        source: file or rosbag2 directory.
        topic: JointState topic of a bag (default: /joint_states, else the only JointState topic).
        joints: joint names to keep, in this order (default: all).
        effort_topic: separate effort topic of a bag (JointState or Float64MultiArray);
            default: the JointState's effort field.
        strict_time: fail on duplicated or out-of-order stamps instead of repairing them.
        extras: bags only: {name: (topic, field)} side JointState signals kept in ``series.extras``.
        layout: a CSV (or other delimited text file) not in frictionid's own format: a
            :class:`~frictionid_core.io.layout.Layout` or its YAML file (see that module).
        strict_rows: refuse a broken row (of a text file: malformed, not numeric or truncated; of
            any source: a value NaN, inf or beyond any measurement, a stamp off the log's time
            line) instead of skipping broken rows with a warning.

    Raises:
        InputError: naming the file, topic, joint or field at fault.
    """
    path = Path(source)
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    suffix = path.suffix.lower()
    lines = None  # the file line of each sample (a text file), for messages
    if layout is not None:
        from frictionid_core.io.layout import Layout, load_layout, read_layout_log

        if path.is_dir() or suffix == ".mat" or suffix in BAG_SUFFIXES:
            raise InputError(f"{path}: a layout applies to CSV and other delimited text files, not to "
                             f"{'a directory' if path.is_dir() else repr(suffix)}")
        series, lines = read_layout_log(path, layout if isinstance(layout, Layout) else load_layout(layout),
                                        strict_rows=strict_rows)
    elif suffix == ".mat":
        from frictionid_core.io.mat import load_emps_mat

        series = load_emps_mat(path)
    elif suffix == ".csv":
        from frictionid_core.io.csv import read_csv

        series, lines = read_csv(path, strict_rows=strict_rows)
    elif path.is_dir() or suffix in BAG_SUFFIXES:
        from frictionid_core.io.bag import load_bag

        series = load_bag(path, topic=topic, effort_topic=effort_topic, extras=extras)
    else:
        raise InputError(f"{path}: unknown format '{suffix}'; expected .mat, .csv, .mcap, .db3, .bag or a rosbag2 "
                         "directory")
    if joints:
        series = series.select(joints)
    return check_series(series, strict_time=strict_time, strict_rows=strict_rows, lines=lines)
