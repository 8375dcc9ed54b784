"""The control of one identification: its cancel, progress and wall-time limit, shared by the node's
threads that run and watch it, whether it runs in the worker process or in a thread (no ROS import)."""

from __future__ import annotations

import math
import threading
import time


class Cancelled(Exception):
    """Raised inside an identification (from its progress hook) to stop it."""


class JobControl:
    """Cancellation and progress of one identification, shared by the threads that run and watch it.

    :meth:`cancel` records the first reason and interrupts the running identification (the worker
    registers how, :meth:`on_cancel`); :meth:`check_wall` cancels it once it has run longer than
    ``wall_s`` [s]. :attr:`progress` is the optimiser's last report (generation, evaluations, best
    cost); :attr:`stopped_at` is set when the identification ended [s, ``time.monotonic``];
    :attr:`overrun`: cancelled by the wall-time limit; :attr:`killed`: its worker child did not
    stop after the cancel (or, overrun, never became ready) and was killed.
    """

    def __init__(self, wall_s: float = math.inf):
        self.t_start = time.monotonic()
        self.wall_s = float(wall_s)
        self.reason = ""
        self.cancelled_at = 0.0
        self.stopped_at = 0.0
        self.overrun = False
        self.killed = False
        self.progress: tuple[int, int, float] = (0, 0, math.inf)
        self._interrupt = None
        self._lock = threading.Lock()

    @property
    def cancelled(self) -> bool:
        return bool(self.reason)

    def cancel(self, reason: str) -> bool:
        """Stop the identification, saying why; False if it was already cancelled."""
        with self._lock:
            if self.reason:
                return False
            self.reason, self.cancelled_at = reason, time.monotonic()
            interrupt = self._interrupt
        if interrupt is not None:
            interrupt()
        return True

    def check_wall(self) -> None:
        """Cancel the identification once it has run longer than :attr:`wall_s`."""
        if not self.reason and time.monotonic() - self.t_start > self.wall_s:
            self.overrun = self.cancel(f"stopped: over the wall-time limit max_wall_s = {self.wall_s:g} s")

    def on_cancel(self, interrupt) -> None:
        """Call ``interrupt()`` on :meth:`cancel` (at once if already cancelled)."""
        with self._lock:
            self._interrupt = interrupt
            now = bool(self.reason)
        if now:
            interrupt()

    def report(self, generation: int, evaluations: int, best_cost: float) -> None:
        """The optimiser's progress hook in this process: record, and stop if cancelled."""
        self.progress = (int(generation), int(evaluations), float(best_cost))
        self.check_wall()
        if self.reason:
            raise Cancelled(self.reason)
