"""CPU-bound competing processes: a robot computer is never idle."""

from __future__ import annotations

import subprocess
import sys
import time

CODE = "while True: pass"  # what a competitor runs, at normal scheduling
DESCRIPTION = f"python -c '{CODE}'"


class Competitors:
    """``n`` CPU-bound processes, started and stopped by :meth:`start`/:meth:`stop` or for the
    duration of a ``with`` block."""

    def __init__(self, n: int) -> None:
        self.n, self.procs = n, []

    def start(self) -> Competitors:
        self.procs = [subprocess.Popen([sys.executable, "-c", CODE]) for _ in range(self.n)]
        time.sleep(0.5 if self.n else 0.0)  # running before anything is timed
        return self

    def stop(self) -> None:
        for p in self.procs:
            p.kill()
        for p in self.procs:
            p.wait()

    def __enter__(self) -> Competitors:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
