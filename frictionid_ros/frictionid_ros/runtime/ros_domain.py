"""A ROS domain id of this process's own on this host (no ROS import).

Processes that would otherwise meet on one domain by chance (two test runs at once, a test run and
``frictionid loop``, a node left behind by an interrupted run) each hold an exclusive ``flock`` on
the lock file of their domain (``<tmp>/frictionid-ros-domain-<id>.lock``). The lock lasts while a
descriptor of that file is open, here or in a child that inherited it (``pass_fds=(lease.fd,)``),
and ends with them, crash included: nothing is left to clean up.
"""

from __future__ import annotations

import os
import random
import tempfile
from dataclasses import dataclass
from pathlib import Path

from frictionid_core import FrictionIdError

HIGHEST_DOMAIN = 232  # Fast DDS: a higher domain's ports overflow (it ends the process when a node is made)
DOMAIN_IDS = range(1, 201)  # 0 is every other ROS process's default
LOCK_DIR = Path(tempfile.gettempdir())


@dataclass
class DomainLease:
    """The ROS domain ``id``, reserved while the lock file descriptor ``fd`` is open (-1: released)."""

    id: int
    fd: int

    def release(self) -> None:
        """Let other processes take the domain (children that inherited ``fd`` still hold it)."""
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def lock_file(domain: int) -> Path:
    """The lock file of ``domain``."""
    return LOCK_DIR / f"frictionid-ros-domain-{domain}.lock"


def _open(path: Path) -> int | None:
    """A descriptor of ``path``, created if missing; None if it cannot be opened (another user's)."""
    try:
        return os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        pass
    except PermissionError:
        return None
    try:
        return os.open(path, os.O_RDONLY | os.O_CREAT, 0o666)
    except PermissionError:
        return None


def check_domain_id(environ=os.environ) -> None:
    """FrictionIdError when ``ROS_DOMAIN_ID`` in ``environ`` is a domain Fast DDS cannot open (above
    HIGHEST_DOMAIN): Fast DDS would end the process with status 1 when its first node is made."""
    value = environ.get("ROS_DOMAIN_ID", "").strip()
    if value.isdigit() and int(value) > HIGHEST_DOMAIN:
        raise FrictionIdError(f"ROS_DOMAIN_ID {value} is above {HIGHEST_DOMAIN}, the highest domain Fast DDS opens "
                              f"ports for: choose 0..101 or 215..{HIGHEST_DOMAIN} (clear of Linux's ephemeral ports)")


def reserve_domain() -> DomainLease:
    """A domain id of DOMAIN_IDS, tried in random order, that no other process holds."""
    import fcntl

    for domain in random.sample(DOMAIN_IDS, len(DOMAIN_IDS)):
        fd = _open(lock_file(domain))
        if fd is None:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        return DomainLease(domain, fd)
    raise FrictionIdError(f"no free ROS domain: every id {DOMAIN_IDS.start}..{DOMAIN_IDS.stop - 1} is held by "
                          f"another process (lock files {LOCK_DIR}/frictionid-ros-domain-*.lock)")
