"""Ctrl-C and the atomic writer's temporary files: exit 130 with one line, the old file kept, no
temporary file left, orphans of killed processes removed at the next write into their folder."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time

import pytest

from frictionid_core.files import remove_orphans, temporary_name, write_json

HANDSHAKE_S = 120.0  # at most this long for the command to start and open its input (a loaded machine)
REPEAT_S = 3.0  # Ctrl-C pressed again after this long without an exit


def _open_writer(fifo, process) -> int:
    """Open ``fifo`` for writing once ``process`` has opened it for reading (the open fails with
    ENXIO before); the process then waits in its read."""
    deadline = time.monotonic() + HANDSHAKE_S
    while True:
        try:
            return os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as exc:
            if exc.errno != errno.ENXIO or process.poll() is not None or time.monotonic() > deadline:
                raise
        time.sleep(0.01)


def _as_from_a_terminal() -> None:
    """The child's SIGINT as a shell leaves it: default action, not blocked (dispositions and the
    signal mask are inherited across fork and exec)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def test_ctrl_c_exits_130_in_one_line(tmp_path):
    params = tmp_path / "params.json"
    os.mkfifo(params)  # the command blocks reading it: Ctrl-C arrives while it works
    out = tmp_path / "v.json"
    process = subprocess.Popen(
        [sys.executable, "-m", "frictionid_core.cli", "validate", str(tmp_path / "log.csv"), "--params", str(params),
         "--json", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=_as_from_a_terminal)
    try:
        fd = _open_writer(params, process)
        # A Ctrl-C that lands between Python's signal check and the blocking read of the FIFO only
        # sets CPython's flag (the read is not interrupted): as a user would, press it again when
        # nothing happens; the command still ends with one line.
        for _ in range(int(HANDSHAKE_S / REPEAT_S)):
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=REPEAT_S)
                break
            except subprocess.TimeoutExpired:
                continue
        _, err = process.communicate(timeout=HANDSHAKE_S)
        os.close(fd)
    finally:
        process.kill()
    assert (process.returncode, err) == (130, "frictionid: interrupted\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["params.json"]


def test_an_interrupted_write_keeps_the_old_file(tmp_path):
    target = tmp_path / "r.json"
    target.write_text("old")
    os.mkfifo(tmp_path / temporary_name("r.json"))  # opening the temporary file blocks: the write is under way

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, 0.2)
    try:
        with pytest.raises(KeyboardInterrupt):
            write_json(target, {"new": 1})
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]  # the temporary file removed


def test_orphan_temporary_files_are_removed_at_the_next_write(tmp_path):
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True)
    dead = int(done.stdout)  # a process that has exited
    orphans = [tmp_path / temporary_name("r.json", dead), tmp_path / temporary_name("other.json", dead)]
    kept = [tmp_path / temporary_name("r.json", os.getppid()),  # its process is alive
            tmp_path / "notes.tmp", tmp_path / ".x.12ab.tmp", tmp_path / "x.json"]  # not the writer's
    for path in orphans + kept:
        path.write_text("partial")
    write_json(tmp_path / "r.json", {"a": 1})
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in [*kept, tmp_path / "r.json"])
    assert remove_orphans(tmp_path) == []
