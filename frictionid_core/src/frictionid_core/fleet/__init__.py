"""Friction health across a fleet: many robots × many logs identified in parallel, each parameter tracked
with its σ, and an alarm when one drifts, at a stated false-alarm rate (``frictionid fleet``; docs/fleet.md).

One module per concern: ``config`` (the fleet file), ``jobs`` (one log: its key, its fit in a worker),
``backends`` (a local process pool or a Dask cluster, failures retried once), ``store`` (the checksummed
results store, shared with the EMPS study), ``drift`` (baseline and CUSUM), ``dashboard`` (index.html),
``run`` (a fleet run and its files) and ``synthetic`` (fleets for tests and the demo). Each name is
loaded from its module on first use (PEP 562).
"""

from frictionid_core import _lazy

_LAZY = {
    "FleetConfig": "frictionid_core.fleet.config",
    "read_fleet": "frictionid_core.fleet.config",
    "FleetRun": "frictionid_core.fleet.run",
    "run_fleet": "frictionid_core.fleet.run",
    "RecordStore": "frictionid_core.fleet.store",
    "open_backend": "frictionid_core.fleet.backends",
    "synthesize_fleet": "frictionid_core.fleet.synthetic",
    "Drift": "frictionid_core.fleet.synthetic",
    "Broken": "frictionid_core.fleet.synthetic",
}

__all__ = ["Broken", "Drift", "FleetConfig", "FleetRun", "RecordStore", "open_backend", "read_fleet", "run_fleet",
           "synthesize_fleet"]

__getattr__, __dir__ = _lazy.lazy_names(__name__, _LAZY)
