"""Friction health across a fleet: many robots × many logs identified in parallel, each parameter tracked
with its σ, and an alarm when one drifts, at a stated false-alarm rate (``frictionid fleet``; docs/fleet.md).

One module per concern: ``config`` (the fleet file), ``jobs`` (one log: its key, its fit in a worker),
``backends`` (a local process pool or a Dask cluster, failures retried once), ``store`` (the checksummed
results store, shared with the EMPS study), ``drift`` (baseline and CUSUM), ``dashboard`` (index.html),
``run`` (a fleet run and its files) and ``synthetic`` (fleets for tests and the demo).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("open_backend",), "frictionid_core.fleet.backends"),
    **dict.fromkeys(("FleetConfig", "read_fleet"), "frictionid_core.fleet.config"),
    **dict.fromkeys(("FleetRun", "OUTPUT_FILES", "per_log_cost", "run_fleet"), "frictionid_core.fleet.run"),
    **dict.fromkeys(("latest_by_key", "RecordStore"), "frictionid_core.fleet.store"),
    **dict.fromkeys(("Broken", "Drift", "synthesize_fleet"), "frictionid_core.fleet.synthetic"),
}

__all__ = ["Broken", "Drift", "FleetConfig", "FleetRun", "OUTPUT_FILES", "RecordStore", "latest_by_key",
           "open_backend", "per_log_cost", "read_fleet", "run_fleet", "synthesize_fleet"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
