"""A ROS domain of a process's own: reserved through a lock file, held by the children that inherit it."""

from __future__ import annotations

import os
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


def test_a_domain_fast_dds_cannot_open_is_one_line_before_rclpy_starts(tmp_path):
    """Fast DDS ends a process whose ROS_DOMAIN_ID is above 232 with status 1 when its first node is made;
    the node refuses such a domain first, in one line, with status 2."""
    check = ros_domain.check_domain_id
    for fine in ("0", "232", " 17 ", "x"):  # "x": not an integer, rclpy's own one-line error
        check({"ROS_DOMAIN_ID": fine})
    check({})
    with pytest.raises(FrictionIdError, match=r"^ROS_DOMAIN_ID 233 is above 232, .*0\.\.101 or 215\.\.232"):
        check({"ROS_DOMAIN_ID": "233"})
    env = dict(os.environ, ROS_DOMAIN_ID="250")
    out = subprocess.run([sys.executable, "-m", "frictionid_ros.node"], env=env, cwd=tmp_path, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 2, out.stderr
    assert out.stderr.strip().splitlines() == [
        "frictionid_node: error: ROS_DOMAIN_ID 250 is above 232, the highest domain Fast DDS opens ports for: "
        "choose 0..101 or 215..232 (clear of Linux's ephemeral ports)"]
