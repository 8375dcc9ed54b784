"""A fleet run: every log of every robot identified (new ones only), its results stored as they arrive,
then the fleet's files written in ``DIR``:

* ``fits.jsonl``: the store, one checksummed record per fit attempt (:mod:`.store`), streamed;
* ``fits.csv``: robot, log, start_time, joint, parameter, value, sigma — one row per parameter of
  each fitted log, robots in the fleet file's order, logs by first stamp;
* ``alarms.json``: the drift alarms (:mod:`.drift`), ``failed.json``: the logs that could not be
  fitted with the error's line, ``index.html``: the dashboard (:mod:`.dashboard`).

A log already fitted (same content and settings: :func:`~.jobs.job_key`) is skipped, as is one that
failed twice; ``refit`` redoes them. The numbers do not depend on the backend: every fit runs alone in
its process with one BLAS and one kernel thread, and the files are written from the store, sorted.
"""

from __future__ import annotations

import csv
import functools
import io
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.fleet.config import FleetConfig
from frictionid_core.fleet.jobs import LogJob, content_hash, fit_log, job_key, warm_up, with_content
from frictionid_core.fleet.store import RecordStore, latest_by_key

STORE_FILE = "fits.jsonl"
FITS_CSV = "fits.csv"
ALARMS_JSON = "alarms.json"
FAILED_JSON = "failed.json"
INDEX_HTML = "index.html"
OUTPUT_FILES = (STORE_FILE, FITS_CSV, ALARMS_JSON, FAILED_JSON, INDEX_HTML)
FITS_HEADER = ("robot", "log", "start_time", "joint", "parameter", "value", "sigma")

# progress(done, total, record): after each attempt of this run; done counts the logs whose last attempt
# this was (fitted, or failed twice), of the total to run.
Progress = Callable[[int, int, dict], None]


@dataclass
class FleetRun:
    """What a run did and found.

    Attributes:
        out_dir: where the files are.
        logs: logs in the fleet file; fitted_now, skipped: fitted in this run, found in the store.
        failed: ``failed.json``'s entries; alarms: ``alarms.json``'s.
        set_aside: one line per store record set aside (damaged) and recomputed.
        series: the drift test of every robot, joint and watched parameter.
        records: the latest record of each log in the fleet file, in ``fits.csv`` order.
        wall_s: the run's wall time.
    """

    out_dir: Path
    logs: int = 0
    fitted_now: int = 0
    skipped: int = 0
    failed: list[dict] = field(default_factory=list)
    alarms: list[dict] = field(default_factory=list)
    set_aside: list[str] = field(default_factory=list)
    series: list = field(default_factory=list)
    records: list[dict] = field(default_factory=list)
    wall_s: float = 0.0


def valid_fit_record(record: dict) -> str | None:
    """None when a store record has the fields and types the fleet reads, else what is wrong."""
    status = record.get("status")
    if status == "failed":
        return None if isinstance(record.get("error"), str) else "a failure without its error line"
    if status != "ok":
        return f"unknown status {status!r}"
    for name, kind in (("robot", str), ("log", str), ("start_time", str), ("start_ns", int), ("rows", list),
                       ("covariates", dict)):
        if not isinstance(record.get(name), kind):
            return f"field '{name}' missing or not a {kind.__name__}"
    for row in record["rows"]:
        if (not isinstance(row, list) or len(row) != 4 or not all(isinstance(v, str) for v in row[:2])
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row[2:])):
            return f"a parameter row is not [joint, parameter, value, sigma]: {row!r}"
    return None


def plan_jobs(config: FleetConfig) -> tuple[list[tuple[str, LogJob]], list[dict]]:
    """([(key, job)] of every log of the fleet file, in its order; [failure] of logs that cannot be read)."""
    jobs, unreadable = [], []
    for robot in config.robots:
        for name, source in robot.logs:
            job = LogJob(robot.name, name, source, robot.request, robot.load, robot.covariates)
            try:
                jobs.append((job_key(job, content_hash(source)), job))
            except FrictionIdError as exc:
                unreadable.append({"robot": robot.name, "log": name, "source": source, "error": str(exc),
                                   "attempts": 0})
    return jobs, unreadable


def run_fleet(config: FleetConfig, out_dir: str | Path, *, workers: int | None = None, scheduler: str | None = None,
              refit: bool = False, memory_mb: float | None = None, progress: Progress | None = None) -> FleetRun:
    """Identify the fleet's new logs, then write its files in ``out_dir`` (module doc).

    Local processes by default (``workers``, default the usable CPUs; each capped at ``memory_mb``),
    or the Dask cluster at ``scheduler`` (tcp://host:port).
    """
    from frictionid_core.fleet.backends import open_backend

    t0 = time.perf_counter()
    out = Path(out_dir).expanduser().absolute()
    run = FleetRun(out)
    jobs, unreadable = plan_jobs(config)
    run.logs = len(jobs) + len(unreadable)
    with RecordStore(out / STORE_FILE, validate=valid_fit_record) as store:
        found = store.check()
        run.set_aside = found.set_aside
        latest = latest_by_key(found.records)
        todo = [(key, job) for key, job in jobs if refit or not _finished(latest.get(key))]
        run.skipped = len(jobs) - len(todo)
        if todo:
            requests = tuple({repr(job.request): job.request for _, job in todo}.values())
            finished = 0

            def on_record(record: dict) -> None:
                nonlocal finished
                store.append(record)
                latest[record["key"]] = record
                finished += _finished(record)
                if progress is not None:
                    progress(finished, len(todo), record)

            with open_backend(workers, scheduler, functools.partial(warm_up, requests), memory_mb) as backend:
                prepare = None if backend.sees(todo[0][1].source) else with_content
                backend.run(fit_log, todo, on_record, prepare=prepare)
            run.fitted_now = sum(1 for key, _ in todo if latest.get(key, {}).get("status") == "ok")
    run.records, run.failed = _outcomes(jobs, latest)
    run.failed = unreadable + run.failed
    from frictionid_core.fleet.drift import alarm_list, fleet_drift

    run.series = fleet_drift(config, run.records)
    run.alarms = alarm_list(run.series)
    write_outputs(run, config)
    run.wall_s = time.perf_counter() - t0
    return run


def _finished(record: dict | None) -> bool:
    """A log needs no new attempt: fitted, or failed twice."""
    return record is not None and (record["status"] == "ok" or record.get("attempt", 1) >= 2)


def _outcomes(jobs: list[tuple[str, LogJob]], latest: dict[str, dict]) -> tuple[list[dict], list[dict]]:
    """(the fitted logs' records, named as in the fleet file now; the failed logs), in the fleet
    file's robot order, logs by first stamp."""
    fitted, failed = [], []
    order = {}
    for key, job in jobs:
        order.setdefault(job.robot, len(order))
        record = latest.get(key)
        if record is None:
            failed.append({"robot": job.robot, "log": job.log, "source": job.source,
                           "error": "not run (the run was interrupted)", "attempts": 0})
        elif record["status"] == "ok":
            fitted.append({**record, "robot": job.robot, "log": job.log, "source": job.source})
        else:
            failed.append({"robot": job.robot, "log": job.log, "source": job.source, "error": record["error"],
                           "attempts": record.get("attempt", 1)})
    fitted.sort(key=lambda r: (order[r["robot"]], r["start_ns"], r["log"]))
    return fitted, failed


# ------------------------------------------------------------------------------------ files
def fits_csv(records: list[dict]) -> str:
    """``fits.csv``'s text: one row per parameter of each record (numbers as Python writes them back exactly)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(FITS_HEADER)
    for r in records:
        for joint, parameter, value, sigma in r["rows"]:
            writer.writerow([r["robot"], r["log"], r["start_time"], joint, parameter, repr(float(value)),
                             repr(float(sigma))])
    return buffer.getvalue()


def write_outputs(run: FleetRun, config: FleetConfig) -> None:
    """Write fits.csv, alarms.json, failed.json and index.html in ``run.out_dir`` (each atomically)."""
    from frictionid_core.files import write_json, write_text
    from frictionid_core.fleet.dashboard import write_dashboard

    write_text(run.out_dir / FITS_CSV, fits_csv(run.records))
    write_json(run.out_dir / ALARMS_JSON, run.alarms)
    write_json(run.out_dir / FAILED_JSON, run.failed)
    write_dashboard(run, config)


def per_log_cost(records: list[dict]) -> dict[str, float]:
    """Median wall and CPU seconds per log and the largest worker peak RSS (MB) of ``records``."""
    if not records:
        return {}
    return {"wall_s": float(np.median([r["wall_s"] for r in records])),
            "cpu_s": float(np.median([r["cpu_s"] for r in records])),
            "rss_mb": float(max(r["rss_mb"] for r in records))}
