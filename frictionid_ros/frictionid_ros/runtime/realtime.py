"""Real-time scheduling: the SCHED_FIFO priority of ``frictionid loop --realtime`` and of the node's
``realtime_priority`` parameter (its input/feed-forward thread and the middleware threads that receive
its joint states at that priority, its other threads at SCHED_FIFO 1: :func:`fifo_this_thread`), the
way ros2_control runs its loop.

``auto`` asks for SCHED_FIFO AUTO_PRIORITY and falls back to normal scheduling, said so, when the
OS refuses (no CAP_SYS_NICE, RLIMIT_RTPRIO 0, a container); ``off`` or 0: normal scheduling; 1..99:
that priority (refused: normal scheduling and a warning). Nothing here ever raises for a refusal.
"""

from __future__ import annotations

import os
import subprocess
import threading

from frictionid_core import FrictionIdError

AUTO_PRIORITY = 10  # SCHED_FIFO priority of "auto" (ros2_control's realtime thread default is 50; below it)
# Fast DDS threads that receive the joint states (shared memory and UDP listeners, thread names set by
# Fast DDS): they wake the input thread, so they get its priority too (measured: a competing process
# otherwise delays them by several ms).
RECEIVE_THREADS = ("dds.shm.", "dds.udp.")


def parse_priority(value, what: str = "--realtime") -> int | str:
    """``value`` (auto | off | a priority 0..99, as a string or an int) checked: "auto" or the priority
    (0: off); FrictionIdError naming ``what`` otherwise. Asks nothing of the OS."""
    if isinstance(value, str) and value.strip().lower() in ("auto", "off"):
        return "auto" if value.strip().lower() == "auto" else 0
    try:
        prio = int(value) if not isinstance(value, (bool, float)) else -1
    except (TypeError, ValueError):
        prio = -1
    if not 0 <= prio <= 99:
        raise FrictionIdError(f"{what} must be auto, off or a priority 0..99, got {value!r}")
    return prio


def realtime_priority(value, what: str = "--realtime") -> int:
    """The SCHED_FIFO priority of ``value`` (0: off) for a process started under ``chrt``;
    ``auto``: AUTO_PRIORITY if the OS allows it (tried with ``chrt``), else 0."""
    prio = parse_priority(value, what)
    if prio != "auto":
        return prio
    try:
        allowed = subprocess.run(["chrt", "--fifo", str(AUTO_PRIORITY), "true"], capture_output=True,
                                 timeout=10).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        allowed = False
    return AUTO_PRIORITY if allowed else 0


def fifo_this_thread(requested: int | str, others: bool = False) -> tuple[bool, str]:
    """Put the calling thread (Linux: ``sched_setscheduler(0)`` is per thread) at SCHED_FIFO
    ``requested`` (a :func:`parse_priority` value), the middleware receive threads too, and with
    ``others`` every other thread of the process at SCHED_FIFO 1 (threads they start inherit it): a
    thread holding the GIL is then never preempted by an ordinary process while the feed-forward
    thread waits for it (Python's GIL has no priority inheritance). (granted, a line saying what was
    used): a refusal of the OS leaves normal scheduling and says so; 0 asks nothing."""
    if requested == 0:
        return False, "normal scheduling (SCHED_OTHER; realtime_priority off)"
    prio = AUTO_PRIORITY if requested == "auto" else int(requested)
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(prio))
    except (OSError, AttributeError) as exc:  # EPERM without CAP_SYS_NICE / RLIMIT_RTPRIO; not Linux
        reason = getattr(exc, "strerror", None) or str(exc)
        return False, f"normal scheduling (SCHED_OTHER): SCHED_FIFO {prio} refused by the OS ({reason})"
    raised = fifo_threads(RECEIVE_THREADS, prio)
    line = f"SCHED_FIFO {prio}, and {raised} middleware receive threads ({'*, '.join(RECEIVE_THREADS)}*)"
    if others:
        n = fifo_threads(("",), 1, skip=RECEIVE_THREADS, skip_tid=threading.get_native_id())
        line += f"; {n} other threads SCHED_FIFO 1"
    return True, line


def fifo_threads(prefixes: tuple[str, ...], prio: int, skip: tuple[str, ...] = (), skip_tid: int = 0) -> int:
    """Put this process's threads whose name starts with one of ``prefixes`` at SCHED_FIFO ``prio``;
    how many were (a refusal or a thread gone meanwhile is skipped)."""
    done = 0
    try:
        tasks = os.listdir("/proc/self/task")
    except OSError:
        return 0
    for tid in tasks:
        try:
            with open(f"/proc/self/task/{tid}/comm") as f:
                name = f.read().strip()
            if name.startswith(prefixes) and not (skip and name.startswith(skip)) and int(tid) != skip_tid:
                os.sched_setscheduler(int(tid), os.SCHED_FIFO, os.sched_param(prio))
                done += 1
        except (OSError, ValueError, AttributeError):
            continue
    return done


def schedule_this_thread(requested: int | str, log, others: bool = False) -> str:
    """:func:`fifo_this_thread` and its line logged (``log``: an rclpy logger): info if granted or off or
    ``auto`` fell back, a warning if an explicit priority was refused. Returns the line."""
    granted, line = fifo_this_thread(requested, others)
    if granted or requested in (0, "auto"):
        log.info(f"input/feed-forward thread: {line}")
    else:
        log.warning(f"input/feed-forward thread: {line}")
    return line
