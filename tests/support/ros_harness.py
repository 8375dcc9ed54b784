"""Shared by the ROS tests: the node as a subprocess and an rclpy client in the test process,
on a ROS domain of their own (DOMAIN, reserved for the session: no other test run or
``frictionid loop`` on this host takes it; discovery on this host only)."""

from __future__ import annotations

import itertools
import os
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    import rclpy
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray
    from frictionid_interfaces.action import Identify as IdentifyAction
    from frictionid_interfaces.msg import IdentifiedParameters
    from frictionid_interfaces.srv import Identify
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    from std_srvs.srv import Trigger

    from frictionid_ros.runtime.action_client import ActionClient

from frictionid_ros.runtime import DomainLease, reserve_domain
from support.waiting import wait_until

ROOT = Path(__file__).resolve().parents[2]
NS = 1_000_000_000
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2000, reliability=ReliabilityPolicy.RELIABLE)
FEED_LAG = 1000  # joint states a replay runs ahead of the node at most: half the nodes' qos_depth
LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"  # the rclpy contexts of this process too
_LEASES: dict[int, DomainLease] = {}


def close_spinning(ctx, executor, thread: threading.Thread, nodes, timeout: float = 60.0) -> None:
    """Shut ``executor`` down and wait for its spin ``thread`` to leave, then destroy ``nodes`` and shut
    ``ctx`` down; they stay alive when the thread has not left within ``timeout`` s (asserted): a thread
    spinning on destroyed nodes would use their freed handles."""
    executor.shutdown(timeout_sec=timeout)
    thread.join(timeout)
    assert not thread.is_alive(), f"the spin thread did not leave within {timeout:g} s"
    for node in nodes:
        node.destroy_node()
    rclpy.shutdown(context=ctx)


def private_domain() -> int:
    """A ROS domain of this test run's own, held until the run ends (and by the nodes started on it,
    :class:`NodeProcess`, as long as they live: a node left behind keeps its domain from the next run)."""
    lease = reserve_domain()
    _LEASES[lease.id] = lease
    return lease.id


DOMAIN = private_domain()


def node_env(domain: int) -> dict:
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    src = [str(ROOT / "frictionid_core" / "src"), str(ROOT / "frictionid_ros")]
    env["PYTHONPATH"] = os.pathsep.join(src + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    env.pop("_ROS_WHEELS_BOOTSTRAP_COMPLETE", None)  # let the child bootstrap its own library path
    return env


_STARTED: list[NodeProcess] = []  # every node this run started: stop_leftover_nodes ends those a failure left


def stop_leftover_nodes() -> None:
    """Stop every node started so far that still runs (SIGTERM, then SIGKILL after 10 s): a fixture
    that failed before its teardown must not leave a node answering the next module's requests on
    the same domain, nor a process the run's caller waits for."""
    for node in _STARTED:
        if node.alive():
            node.proc.terminate()
            try:
                node.proc.wait(10)
            except subprocess.TimeoutExpired:
                node.proc.kill()
                node.proc.wait(5)
    _STARTED.clear()


class NodeProcess:
    """``python -m frictionid_ros.node`` as a subprocess, output in files."""

    def __init__(self, workdir: Path, args: list[str], tag: str, domain: int = DOMAIN):
        self.out = workdir / f"node-{tag}.out"
        self.err = workdir / f"node-{tag}.err"
        with open(self.out, "w") as out, open(self.err, "w") as err:
            lease = _LEASES.get(domain)
            self.proc = subprocess.Popen([sys.executable, "-m", "frictionid_ros.node", *args], env=node_env(domain),
                                         stdout=out, stderr=err, cwd=workdir, pass_fds=(lease.fd,) if lease else ())
        _STARTED.append(self)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, sig=signal.SIGTERM, timeout: float = 30.0) -> int:
        if self.alive():
            self.proc.send_signal(sig)
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)
            raise AssertionError(f"node did not stop within {timeout} s after {sig!r}") from None

    def stderr(self) -> str:
        return self.err.read_text()


def start_node(workdir: Path, ros: Ros, params: Path, tag: str, *args: str, domain: int = DOMAIN) -> NodeProcess:
    """``frictionid_node --params-file params *args`` on ``domain``, once it offers ``~/identify``
    (at once with ``--lifecycle``: an unconfigured node offers nothing yet)."""
    proc = NodeProcess(workdir, ["--params-file", str(params), *args], tag, domain)
    if "--lifecycle" not in args:
        try:
            ros.wait_service(proc)
        except BaseException:
            proc.stop()
            raise
    return proc


class Ros:
    """rclpy in the test process: one client node on ``domain`` spun by a MultiThreadedExecutor thread."""

    def __init__(self, domain: int = DOMAIN):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("frictionid_test_client", context=self.ctx)
        self.executor = MultiThreadedExecutor(num_threads=3, context=self.ctx)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self.errors = []
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()
        self._clients = {}
        self._action = None
        self.lock = threading.Lock()
        self.ff, self.ff_state, self.params, self.diag = [], [], [], {}
        self._probes = itertools.count()  # assert_alive's probe stamps, one µs apart
        self.node.create_subscription(Float64MultiArray, "/frictionid/friction_torque",
                                      lambda m: self._add(self.ff, m), RELIABLE)
        self.ff_state_at = {}  # header stamp [ns] → index in ff_state
        self.node.create_subscription(JointState, "/frictionid/friction_torque_state", self._on_ff_state, RELIABLE)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, RELIABLE)
        self.js = self.node.create_publisher(JointState, "/joint_states", RELIABLE)

    def _spin(self):
        """Spin until closed; an exception in one callback must not stop every later one."""
        while not self._stop.is_set():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception as exc:
                if self._stop.is_set() or not self.ctx.ok():
                    return
                self.errors.append(exc)

    def _add(self, lst, m):
        with self.lock:
            lst.append(m)

    def _on_ff_state(self, m):
        with self.lock:
            self.ff_state_at[m.header.stamp.sec * NS + m.header.stamp.nanosec] = len(self.ff_state)
            self.ff_state.append(m)

    def _on_diag(self, arr):
        """Keep each status with the time the node made it, on this process's monotonic clock (the
        header stamp is the node's system time): a message that waited in a queue is not fresh."""
        made = time.monotonic() - max(0.0, time.time() - (arr.header.stamp.sec + arr.header.stamp.nanosec * 1e-9))
        with self.lock:
            for s in arr.status:
                self.diag[s.name] = ({kv.key: kv.value for kv in s.values}, s, made)

    def close(self):
        self._stop.set()
        close_spinning(self.ctx, self.executor, self.thread, [self.node])

    def call(self, srv_type, name: str, req, timeout: float = 60.0):
        """call_async + wait with a timeout: a test never hangs on a dead node."""
        cli = self._clients.get(name)
        if cli is None:
            cli = self._clients[name] = self.node.create_client(srv_type, name)
        assert cli.wait_for_service(timeout_sec=60.0), f"service {name} not available"
        return self.wait(cli.call_async(req), timeout, name)

    @staticmethod
    def wait(future, timeout: float, what: str = "request"):
        """The result of ``future``, done within ``timeout`` s."""
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        assert done.wait(timeout), f"{what}: no answer within {timeout} s"
        return future.result()

    def wait_service(self, proc: NodeProcess, name: str = "/frictionid/identify", srv_type=Identify,
                     timeout: float = 120.0) -> None:
        """Wait until the node ``proc`` offers service ``name``."""
        cli = self.node.create_client(srv_type, name)
        deadline = time.monotonic() + timeout
        while not cli.wait_for_service(timeout_sec=0.2):
            assert proc.alive(), f"node exited with {proc.proc.returncode}:\n{proc.stderr()}"
            assert time.monotonic() < deadline, f"service {name} did not appear"

    def send_goal(self, feedback: list | None = None, **fields):
        """Send an ``~/identify`` action goal; returns its (accepted) goal handle. Feedback messages
        are appended to ``feedback``."""
        if self._action is None:
            self._action = ActionClient(self.node, IdentifyAction, "/frictionid/identify")
        assert self._action.wait_for_server(timeout_sec=60.0), "action ~/identify not available"
        on_feedback = None if feedback is None else (lambda m: self._add(feedback, m.feedback))
        handle = self.wait(self._action.send_goal_async(IdentifyAction.Goal(**fields), feedback_callback=on_feedback),
                           30.0, "send_goal")
        assert handle.accepted
        return handle

    def identify(self, timeout: float = 120.0, **fields):
        return self.call(Identify, "/frictionid/identify", Identify.Request(**fields), timeout)

    def reset(self):
        res = self.call(Trigger, "/frictionid/reset", Trigger.Request())
        assert res.success, res.message

    def diag_value(self, key: str, status: str = "frictionid: joint buffer", newer_than: float = 0.0,
                   timeout: float = 30.0) -> str:
        """Value ``key`` of the /diagnostics status ``status`` made after ``newer_than`` [s, monotonic]."""
        def fresh():
            with self.lock:
                entry = self.diag.get(status)
            return entry if entry and entry[2] > newer_than else None

        return wait_until(fresh, f"/diagnostics status '{status}'", timeout)[0][key]

    def received(self, status: str = "frictionid: joint buffer", key: str = "received") -> int:
        """Joint states (``key``: or efforts) the node has taken in so far (from a fresh /diagnostics)."""
        return int(self.diag_value(key, status, newer_than=time.monotonic()))

    def wait_received(self, n: int, timeout: float = 60.0, status: str = "frictionid: joint buffer",
                      key: str = "received") -> int:
        """Wait until the node's diagnostics report ``n`` joint states (``key``: or efforts) received."""
        got = [-1]

        def enough():
            got[0] = self.received(status, key)
            return got[0] >= n

        try:
            wait_until(enough, f"'{key}' = {n} in the node's diagnostics", timeout, period=0.0)
        except AssertionError as exc:
            raise AssertionError(f"{exc} (got {got[0]})") from None
        return got[0]

    def feed(self, stream, rate: float) -> dict:
        """Replay ``stream`` (``frictionid_ros.replay.load_stream``) into the node at ``rate`` × real
        time, reliable, flow-controlled: publishing waits while the node is more than FEED_LAG joint
        states behind (a node starved of CPU by other processes drains its keep-last history slower
        than the bag's rate and would lose what overflows it). Returns the replay's stats; the node
        has every joint state on return."""
        from frictionid_ros import replay

        before = self.received()
        share = float(np.mean(np.asarray(stream.topic_index) == 0))  # joint states among the messages
        taken = [before]

        def pause(sent: int) -> None:
            if share * sent - (taken[0] - before) <= FEED_LAG:
                return

            def caught_up() -> bool:
                taken[0] = self.received()
                return share * sent - (taken[0] - before) <= FEED_LAG / 2

            wait_until(caught_up, f"the node taking in the replay ({taken[0] - before} of {sent})", 60.0,
                       period=0.0)

        stats = replay.publish_stream(self.node, stream, rate=rate, qos=RELIABLE, wait_subscribers=60.0,
                                      ack_timeout=60.0, pause=pause)
        assert stats["subscribers"] >= 1, "the node did not subscribe to the replayed topic"
        self.wait_received(before + int(round(share * stats["sent"])))
        return stats

    def publish_states(self, t_ns, position, velocity=None, effort=None, names=("emps",), rate_hz: float = 4000.0,
                       wait: bool = False):
        """Publish JointStates row by row at ``rate_hz`` (stamps t_ns [ns]); ``wait``: until the node has them."""
        before = self.received() if wait else 0
        msg = JointState(name=list(names))
        period = 1.0 / rate_hz
        t0 = time.monotonic()
        for k in range(len(t_ns)):
            msg.header.stamp = Time(sec=int(t_ns[k]) // NS, nanosec=int(t_ns[k]) % NS)
            msg.position = [] if position is None else np.atleast_1d(position[k]).tolist()
            msg.velocity = [] if velocity is None else np.atleast_1d(velocity[k]).tolist()
            msg.effort = [] if effort is None else np.atleast_1d(effort[k]).tolist()
            self.js.publish(msg)
            delay = t0 + (k + 1) * period - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        if wait:
            self.wait_received(before + len(t_ns))

    def feedforward_for(self, stamp_ns: int, timeout: float = 30.0) -> JointState:
        """The friction_torque_state published for the joint state stamped ``stamp_ns``."""
        def found():
            with self.lock:
                i = self.ff_state_at.get(stamp_ns)
                return None if i is None else self.ff_state[i]

        return wait_until(found, f"feed-forward for the joint state stamped {stamp_ns}", timeout, period=0.01)

    def torques(self, n: int) -> list[list[float]]:
        """The last ``n`` friction_torque messages' data, oldest first (each topic keeps its own order)."""
        with self.lock:
            return [list(m.data) for m in self.ff[-n:]]

    def probe(self, stamp_ns: int, velocity: float, timeout: float = 30.0) -> JointState:
        """Publish the joint state of joint ``emps`` at ``velocity`` stamped ``stamp_ns`` and return its
        feed-forward. While none is answered, the probe is sent again every 0.25 s, one ns later each
        time (a fresh node may not have matched this publisher yet): the answer waited for is the one
        of the last probe sent, so that no probe is still on its way into the node's buffer after this."""
        sent = [stamp_ns]
        send = lambda: self.publish_states([sent[-1]], [[0.0]], [[velocity]], [[0.0]])
        send()
        last = time.monotonic()

        def answered():
            nonlocal last
            with self.lock:
                if sent[-1] in self.ff_state_at:
                    return self.ff_state[self.ff_state_at[sent[-1]]]
                any_answered = any(s in self.ff_state_at for s in sent)
            if not any_answered and time.monotonic() - last > 0.25:  # matched once answered: no loss after it
                sent.append(sent[-1] + 1)
                send()
                last = time.monotonic()
            return None

        return wait_until(answered, f"feed-forward for the probe stamped {sent[-1]}", timeout, period=0.01)

    def latched_parameters(self, timeout: float = 30.0) -> IdentifiedParameters:
        """A late subscriber of ~/parameters (transient local): the message it receives."""
        got = []
        # kept until the end (destroying a subscription the executor may be serving is racy)
        self.node.create_subscription(IdentifiedParameters, "/frictionid/parameters", got.append, LATCHED)
        wait_until(lambda: got, "~/parameters for a late subscriber (transient local)", timeout)
        return got[-1]

    def assert_alive(self, proc: NodeProcess):
        """Still running and still publishing: a fresh joint state yields a feed-forward. Stamped
        5000 s + a few µs (outside the windows the tests name); none is on its way any more when this
        returns (a ``~/reset`` after it leaves no probe in the buffer)."""
        assert proc.alive(), proc.stderr()
        try:
            self.probe(5_000 * NS + next(self._probes) * 1_000, 0.05)
        except AssertionError as exc:
            with self.lock:
                seen = (len(self.ff_state), self.ff_state[-1].header.stamp if self.ff_state else None,
                        {k: v[0] for k, v in self.diag.items()})
            raise AssertionError(f"{exc}; client saw {seen}; node stderr:\n{proc.stderr()[-3000:]}") from None


@pytest.fixture(scope="module")
def ros():
    """The rclpy client of a test module, on DOMAIN (also the ROS_DOMAIN_ID meanwhile)."""
    old = os.environ.get("ROS_DOMAIN_ID")
    os.environ["ROS_DOMAIN_ID"] = str(DOMAIN)  # also passed to rclpy.init explicitly
    r = Ros()
    yield r
    stop_leftover_nodes()  # the module's own fixtures stopped theirs before this teardown
    r.close()
    if old is None:
        os.environ.pop("ROS_DOMAIN_ID", None)
    else:
        os.environ["ROS_DOMAIN_ID"] = old
