"""A ROS domain of a process's own: reserved through a lock file, held by the children that inherit it."""

from __future__ import annotations

import subprocess
import sys

import pytest

from frictionid_core.errors import FrictionIdError
from frictionid_ros.runtime import reserve_domain, ros_domain


def test_a_domain_is_reserved_once_until_every_holder_let_it_go(tmp_path, monkeypatch):
    monkeypatch.setattr(ros_domain, "LOCK_DIR", tmp_path)  # not the lock files of the test runs of this host
    monkeypatch.setattr(ros_domain, "DOMAIN_IDS", range(7, 9))
    first, second = reserve_domain(), reserve_domain()
    assert {first.id, second.id} == {7, 8}
    with pytest.raises(FrictionIdError, match="no free ROS domain: every id 7..8 is held by another process"):
        reserve_domain()
    child = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE,
                             pass_fds=(first.fd,))  # as a node started on the domain
    try:
        first.release()
        with pytest.raises(FrictionIdError):
            reserve_domain()  # the child still holds it
    finally:
        child.communicate(timeout=60)
    third = reserve_domain()
    assert third.id == first.id and first.fd == -1
    for lease in (second, third):
        lease.release()
    again = [reserve_domain(), reserve_domain()]
    assert sorted(lease.id for lease in again) == [7, 8]
    for lease in again:
        lease.release()
