"""The node's active parameters (no ROS import): :class:`ActiveParameters` holds them and saves them;
every set it is given (an identification, ``~/load``, the ``results_file`` at start, an online
candidate) passes the safety screen first (:class:`~frictionid_ros.store.screen.Screen`,
:func:`frictionid_core.safety.screen_parameters`)."""

from __future__ import annotations

import threading
import time
from dataclasses import replace
from pathlib import Path

from frictionid_core import FrictionIdError
from frictionid_ros.store.results import Results, read_results, request_path, write_results
from frictionid_ros.store.screen import Screen


class ActiveParameters:
    """The node's active parameters, merged per joint over identifications and loads.

    Every set is screened first (``screen``, :class:`Screen`: refused → FrictionIdError, nothing
    changed); every change goes to ``on_change(results)`` (feed-forward, publication) under
    :attr:`lock` and is saved to ``path`` (the ``results_file``); ``log`` reports a failed save
    (``.error``). Requests name files in ``folder`` (default: the folder of ``path``).
    """

    def __init__(self, path: Path, on_change, log, folder: Path | None = None, screen: Screen | None = None):
        self.path = Path(path)
        self.folder = Path(folder) if folder is not None else self.path.parent
        self._on_change = on_change
        self._log = log
        self.screen = screen or Screen()
        self.lock = threading.Lock()
        self.results = Results()

    def file(self, name: str) -> Path:
        """A service request's file (:func:`request_path` in :attr:`folder`); empty: :attr:`path`."""
        return request_path(self.folder, name) if name else self.path

    def restore(self) -> None:
        """Read ``path`` if it exists and the screen accepts it (at start; ``on_change`` is not called)."""
        if self.path.exists():
            try:
                results = read_results(self.path)
                self.screen.check(results)
            except FrictionIdError as exc:
                self._log.error(f"parameters not restored: {self.path}: {exc}")
                return
            self.results = results

    def activate(self, results: Results, save: bool = True) -> str:
        """Merge ``results`` into the active parameters and save them (a set without a payload keeps
        the active one); returns a note for the reply. FrictionIdError (nothing changed) when the
        screen refuses them."""
        self.screen.check(results)
        with self.lock:
            self.results = replace(results, per_joint={**self.results.per_joint, **results.per_joint},
                                   payload=results.payload or self.results.payload)
            self._on_change(self.results)
            if not save:
                return ""
            try:
                return f"; saved to {write_results(self.path, self.results)}"
            except FrictionIdError as exc:
                self._log.error(str(exc))
                return f"; NOT saved: {exc}"

    def save(self, path: Path) -> tuple[bool, str]:
        """Write the active parameters to ``path``: (success, message)."""
        with self.lock:
            results = self.results
        if not results.per_joint:
            return False, "no active parameters to save (identify or load first)"
        try:
            write_results(path, results)
        except FrictionIdError as exc:
            return False, str(exc)
        return True, f"saved parameters of {sorted(results.per_joint)} to {path}"

    def load(self, path: Path) -> tuple[bool, str]:
        """Activate the parameters of ``path`` (saved to :attr:`path` unless it is that file): (success, message)."""
        try:
            loaded = read_results(path)
        except FrictionIdError as exc:
            return False, str(exc)
        if not loaded.per_joint:
            return False, f"{path}: no parameters in the file"
        try:
            note = self.activate(replace(loaded, stamp_ns=loaded.stamp_ns or time.time_ns()),
                                 save=Path(path) != self.path)
        except FrictionIdError as exc:
            return False, f"{path}: not loaded: {exc}; active parameters unchanged"
        return True, f"loaded parameters of {sorted(loaded.per_joint)} from {path}{note}"
