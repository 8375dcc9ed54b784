"""One log of the fleet: its job (what a worker needs), its key (content hash) and its fit (run in a worker).

A job names its log by absolute path, or carries the log's bytes when the workers cannot see the
coordinator's files (:func:`with_content`). Its key is the SHA-256 of the log's content and of
everything that decides its fit (robot, request, reading options, covariates), so a log already
fitted is recognised whatever its name, and a changed log or setting is fitted anew.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import resource
import tempfile
import time
import warnings
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.fleet.store import canonical

HASH_BLOCK = 1 << 20
_EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)
EPOCH_FLOOR_S = 1e9  # a CSV time column above this (2001-09-09) holds absolute stamps (s since the epoch)


@dataclass(frozen=True)
class LogJob:
    """What a worker needs to fit one log.

    Attributes:
        robot, log: the robot's name and the log's name in the outputs.
        source: the log's absolute path (a file, or a rosbag2 directory).
        request: the identify request's fields (:meth:`IdentifyRequest.to_dict`).
        load: keyword arguments of :func:`frictionid_core.io.load`.
        covariates: {name: {"topic", "field"} | {"column"}} to average over the log.
        content: {path relative to the source's parent: bytes} of the log's files, when the workers
            cannot read ``source``; None otherwise.
    """

    robot: str
    log: str
    source: str
    request: dict
    load: dict
    covariates: dict
    content: dict[str, bytes] | None = None


def source_files(source: str | Path) -> list[Path]:
    """The files of a log: itself, or every file under a rosbag2 directory (sorted)."""
    path = Path(source)
    if path.is_dir():
        return sorted(p for p in path.rglob("*") if p.is_file())
    return [path]


def content_hash(source: str | Path) -> str:
    """SHA-256 of a log's bytes (a directory: of each file's relative path and bytes, in order)."""
    path = Path(source)
    digest = hashlib.sha256()
    try:
        for file in source_files(path):
            if path.is_dir():
                digest.update(file.relative_to(path).as_posix().encode() + b"\0")
            with open(file, "rb") as fh:
                while block := fh.read(HASH_BLOCK):
                    digest.update(block)
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return digest.hexdigest()


def job_key(job: LogJob, content: str) -> str:
    """The key of ``job``'s fit: SHA-256 of its log's ``content`` hash and of its settings."""
    load = {k: (dataclasses.asdict(v) if dataclasses.is_dataclass(v) else v) for k, v in job.load.items()}
    settings = canonical({"robot": job.robot, "request": job.request, "load": load, "covariates": job.covariates})
    return hashlib.sha256(f"{content}|{settings}".encode()).hexdigest()


def with_content(job: LogJob) -> LogJob:
    """``job`` carrying its log's bytes (for workers that cannot read its path)."""
    path = Path(job.source)
    files = {f.relative_to(path.parent).as_posix(): f.read_bytes() for f in source_files(path)}
    return dataclasses.replace(job, content=files)


# ------------------------------------------------------------------------ in the worker
def fit_log(job: LogJob) -> dict:
    """Load, time-stamp and identify one log; the fleet record of it (plain JSON values).

    The record holds ``rows`` [[joint, parameter, value, σ], …] (a parameter without a joint prefix
    belongs to the only joint, or to none: ""), ``start_ns`` and ``start_time`` (the log's first stamp,
    or the file's modification time when the log has no absolute time: ``start_from``), the covariates'
    means, the warnings, and the cost: ``wall_s``, ``cpu_s``, ``rss_mb`` (the worker's peak)."""
    if job.content is None:
        return _fit(job, job.source)
    with tempfile.TemporaryDirectory(prefix="frictionid-log-") as folder:
        for name, data in job.content.items():
            target = Path(folder) / name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        return _fit(job, str(Path(folder) / Path(job.source).name))


def _fit(job: LogJob, source: str) -> dict:
    from frictionid_core.identification import IdentifyRequest, identify
    from frictionid_core.io import load

    wall0, cpu0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        extras = {name: (c["topic"], c["field"]) for name, c in job.covariates.items() if "topic" in c}
        series = load(source, extras=extras or None, **job.load)
        start_ns, start_from = _start_ns(source, series, job.load.get("topic"))
        covariates = _covariate_means(job, source, series)
        request = IdentifyRequest.from_dict(job.request, where=f"robot '{job.robot}': request field")
        result = identify(series, request)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return {"robot": job.robot, "log": job.log, "start_ns": start_ns, "start_time": iso_time(start_ns),
            "start_from": start_from, "joints": list(result.joints), "rows": parameter_rows(result),
            "covariates": covariates, "samples": len(series),
            "warnings": list(dict.fromkeys(str(w.message) for w in caught if issubclass(w.category, UserWarning))),
            "wall_s": time.perf_counter() - wall0, "cpu_s": time.process_time() - cpu0,
            "rss_mb": usage.ru_maxrss / 1024.0, "pid": os.getpid()}


def parameter_rows(result) -> list[list]:
    """[[joint, parameter, value, σ], …] of an IdentifyResult, in its parameter order."""
    rows = []
    for name, value in result.params.items():
        owner, sep, base = name.rpartition("/")
        if not sep:
            owner = result.joints[0] if len(result.joints) == 1 else ""
        sigma = result.std.get(name, math.nan)
        rows.append([owner, base, float(value), float(sigma) if sigma is not None else math.nan])
    return rows


def iso_time(ns: int) -> str:
    """ISO 8601 UTC time of ``ns`` nanoseconds since the epoch, to the microsecond."""
    return (_EPOCH + timedelta(microseconds=ns // 1000)).isoformat(timespec="microseconds")


def _start_ns(source: str, series, topic: str | None) -> tuple[int, str]:
    """The log's first stamp (ns since the epoch) and where it came from: ``stamp`` (a bag's first
    message, a CSV's absolute time column) or ``mtime`` (the file's modification time)."""
    from frictionid_core.io import BAG_SUFFIXES, first_bag_stamp

    path = Path(source)
    if path.is_dir() or path.suffix.lower() in BAG_SUFFIXES:
        return first_bag_stamp(path, topic), "stamp"
    if len(series) and series.t[0] >= EPOCH_FLOOR_S:
        return int(round(float(series.t[0]) * 1e9)), "stamp"
    return path.stat().st_mtime_ns, "mtime"


def _covariate_means(job: LogJob, source: str, series) -> dict[str, dict[str, float]]:
    """{covariate: {joint: mean over the log}} (one value for every joint: key "*")."""
    import numpy as np

    out = {}
    for name, spec in job.covariates.items():
        if "topic" in spec:
            values = np.asarray(series.extras[name], dtype=float)
        else:
            values = _csv_column(Path(source), spec["column"], name)
        values = values.reshape(len(values), -1)
        means = np.nanmean(values, axis=0)
        if means.size == 1:
            out[name] = {"*": float(means[0])}
        elif means.size == len(series.joints):
            out[name] = {j: float(m) for j, m in zip(series.joints, means)}
        else:
            raise InputError(f"{source}: covariate '{name}' has {means.size} columns for the {len(series.joints)} "
                             f"joints {list(series.joints)}: give one column, or one per joint")
    return out


def _csv_column(path: Path, column: str, name: str):
    """The numbers of the column named ``column`` of a CSV log."""
    from frictionid_core.io import read_table

    def pick(names, ncols):
        if not names or column not in names:
            raise InputError(f"{path}: covariate '{name}': no column '{column}' (columns: {names})")
        return [names.index(column)]

    return read_table(path, header=True, delimiter=",", columns=pick).data[:, 0]


def warm_up(requests: tuple[dict, ...]) -> None:
    """Load (or compile) the numba kernels of ``requests`` once in this worker, so that its first log
    costs its own time: a small synthetic log identified with each distinct friction law and solver
    (system friction-only, the solver's smallest budget)."""
    import numpy as np

    from frictionid_core.friction import get_model
    from frictionid_core.identification import IdentifyRequest, budget_field, identify
    from frictionid_core.timeseries import JointSeries

    t = np.arange(4000) / 500.0
    q = 0.5 * np.sin(2 * np.pi * 0.4 * t) + 0.2 * np.sin(2 * np.pi * 1.1 * t)
    qd = 0.5 * 2 * np.pi * 0.4 * np.cos(2 * np.pi * 0.4 * t) + 0.2 * 2 * np.pi * 1.1 * np.cos(2 * np.pi * 1.1 * t)
    noise = np.random.default_rng(0).standard_normal(t.size)
    seen = set()
    for request in requests:
        friction, asymmetric, solver = request["friction"], request["asymmetric"], dict(request["solver"])
        if (friction, asymmetric, solver["method"]) in seen:
            continue
        seen.add((friction, asymmetric, solver["method"]))
        model = get_model(friction, asymmetric)
        typical = {"Fv": 1.0, "Fc": 1.0, "Fs": 1.5, "vs": 0.05, "v0": 0.05, "delta": 2.0}
        params = np.array([typical.get(name.rpartition("_")[0] or name, 1.0) for name in model.names])
        effort = model.torque(params, qd) + 0.01 * noise
        if solver["method"] != "ls":
            solver[budget_field(solver["method"])] = 2
        try:
            identify(JointSeries(t, ["warm"], q, effort, source="warm-up"),
                     IdentifyRequest(system="friction-only", friction=friction, asymmetric=asymmetric, solver=solver))
        except FrictionIdError:  # this small log does not suit the solver: the first real log compiles instead
            continue
