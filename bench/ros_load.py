"""Load, cancel and fault benchmark of the frictionid ROS 2 node (not a test).

    python bench/ros_load.py                 # 60 s at 1 kHz, 6 joints, every phase (~3 min)
    python bench/ros_load.py --quick         # 20 s of load and 3 cancels (~1 min)
    python bench/ros_load.py --worker-nice 5 # the same with another worker niceness
    python bench/ros_load.py --quick --competitors 1  # with a CPU-bound process running throughout
    python bench/ros_load.py --realtime off  # node and publisher at normal scheduling

Scheduling (``--realtime``, default auto): the node's ``realtime_priority`` and the publisher
process (the robot's controller) under ``chrt --fifo`` at that priority where the OS allows it;
what was used is printed and stored (``scheduling``: the publisher's, the node's as it reports it
in /diagnostics, the competitors).

Phases, each against a real node subprocess (``python -m frictionid_ros.node``, system
friction-only, 6 joints, default sensor-data QoS) on a private ROS domain:

1. load: a publisher subprocess sends JointState (6 joints, position/velocity/effort of a
   known Coulomb + viscous friction) at 1 kHz for ``--duration`` s, stamped with its sample time
   (like a driver's clock); the actual send time of every message is recorded. The node starts
   with that friction as its active parameters, so it feeds forward from the first message.
   Meanwhile identifications run: an ``ls`` one every 10 s and a long ``de`` (Tustin) action goal
   from 30 % to 80 % of the run, then cancelled. Measured: messages sent vs taken in by the node
   (its /diagnostics ``received``), feed-forward messages received back, feed-forward latency
   (a) inside the node, receipt of the joint state → both messages published (the node's
   /diagnostics p50/p99/max over its last 4096 messages, reported each second) and (b) end to
   end, send → ``~/friction_torque_state`` received back in the publisher process (like a driver
   and its controller: two DDS hops + both executors; matched by stamp to the recorded send
   time), p50/p99/max idle and during an identification
   (after the first SETTLE_S seconds, reported apart: discovery, the first messages);
   node RSS each 0.25 s. The ring buffer is shorter than the run (``--buffer``), so memory must
   plateau once it is full.
2. cancel: a huge ``de`` action goal cancelled 0.3-1 s after its first progress report, then at
   once an ``ls`` identification, ``--cancels`` times; a huge request refused by the limits, then
   ``ls``. Measured: cancel → worker stopped (the node's figure), cancel → result here, cancel →
   the next identification answered.
3. service storm (not with ``--quick``): 200 concurrent ``~/identify`` calls (one runs, the rest
   must be answered "busy" at once), then 200 sequential calls; every call answered, node alive.
4. crash (not with ``--quick``): ``kill -9`` during a slow identification, restart, time until a
   late subscriber gets the last good parameters on ``~/parameters`` (transient local), values
   unchanged.

The machine's own floor is measured in the same run (``machine_floor``): on each CPU, a process
bound to it that only sleeps to a 1 ms deadline at SCHED_FIFO 99 (normal scheduling with
``--realtime off``) records how late each wake-up is, and the hypervisor's steal time is read
from /proc/stat. On a virtual machine the host takes a vCPU away for several ms at a time (seen
here: 9 ms wake-ups of that probe, and of ``cyclictest -p99``, on an idle VM); no scheduling
inside the guest can beat that, so end-to-end figures are also given for the messages whose way
through did not overlap such a stall.

Prints a summary and writes ``bench/results/ros_load.json`` (``ros_load_quick.json``; the
committed ``ros_load_quick_competitor.json`` is ``--quick --competitors 1 --out ...``). The
machine's load average is recorded: figures from a busy machine are not the node's.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

import numpy as np
from _load import DESCRIPTION as COMPETITOR
from _load import Competitors

from frictionid_core.errors import FrictionIdError
from frictionid_core.files import write_json
from frictionid_ros.runtime import realtime_priority

ROOT = Path(__file__).resolve().parents[1]
NS = 1_000_000_000
JOINTS = [f"joint{i + 1}" for i in range(6)]
FV = np.array([3.0, 2.5, 2.0, 1.0, 0.8, 0.5])  # true viscous friction [N·m·s/rad]
FC = np.array([1.5, 1.2, 1.0, 0.6, 0.4, 0.3])  # true Coulomb friction [N·m]
SETTLE_S = 5.0  # start-up transient of the load phase (discovery, first messages), reported apart [s]
HUGE_BUDGET = 100_000  # generations of the long de runs (the node's max_budget is raised to it): never finish


def _env(domain: int) -> dict:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    src = [str(ROOT / "frictionid_core" / "src"), str(ROOT / "frictionid_ros")]
    env["PYTHONPATH"] = os.pathsep.join(src + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    env.pop("_ROS_WHEELS_BOOTSTRAP_COMPLETE", None)
    return env


# ----------------------------------------------------------------------------- publisher role


class FeedForwardProbe:
    """Receive times of ``~/friction_torque_state`` in the process that publishes the joint
    states (a robot driver and its controller): its own EventsExecutor thread, preallocated
    arrays, nothing else in the process but the publishing loop."""

    def __init__(self, node, size: int):
        from rclpy.experimental import EventsExecutor
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState

        self.stamp = np.zeros(size, dtype=np.int64)  # stamp of each feed-forward message [ns]
        self.recv = np.zeros(size, dtype=np.int64)  # its receive time [ns, system clock]
        self.mono = np.zeros(size)  # its receive time [s, time.monotonic: the same clock in every process]
        self.n = 0
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(JointState, "/frictionid/friction_torque_state", self._on_ff, qos)
        self.executor = EventsExecutor(context=node.context)
        self.executor.add_node(node)
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self):
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def _on_ff(self, m):
        now, mono, i = time.time_ns(), time.monotonic(), self.n
        if i < len(self.recv):
            self.recv[i], self.mono[i] = now, mono
            self.stamp[i] = m.header.stamp.sec * NS + m.header.stamp.nanosec
        self.n = i + 1

    def close(self):
        self._stop.set()
        self.thread.join(2)
        self.executor.shutdown(timeout_sec=2)


def run_publisher(rate: float, duration: float, out: Path) -> None:
    """Publish JointState at ``rate`` Hz for ``duration`` s (best effort, like a robot driver) and
    receive the node's feed-forward; writes ``out`` (JSON) and ``out``.npz (send and receive times)."""
    import rclpy
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    sys.setswitchinterval(0.0005)  # the probe's thread gets the GIL from the publishing loop at once
    rclpy.init()
    node = rclpy.create_node("bench_joint_state_publisher")
    pub = node.create_publisher(JointState, "/joint_states", qos_profile_sensor_data)
    n = int(rate * duration)
    probe = FeedForwardProbe(node, n + 1000)
    deadline = time.monotonic() + 10
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.5)
    k = np.arange(n) / rate
    freq = 0.2 + 0.07 * np.arange(6)
    amp = 0.8
    q = amp * np.sin(2 * np.pi * np.outer(k, freq))
    qd = amp * 2 * np.pi * freq * np.cos(2 * np.pi * np.outer(k, freq))
    rng = np.random.default_rng(1)
    tau = FV * qd + FC * np.sign(qd) + rng.normal(0, 0.02, qd.shape)
    msg = JointState(name=JOINTS)
    gc.freeze()  # as the node does: no ~100 ms full collections over the start-up objects while sending
    late = 0
    send_ns = np.zeros(n, dtype=np.int64)
    base_ns = time.time_ns()  # stamp of sample i: base_ns + i / rate (its sample time, like a driver's)
    t0 = time.monotonic()
    for i in range(n):
        delay = t0 + i / rate - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        elif delay < -0.002:
            late += 1
        msg.position, msg.velocity, msg.effort = q[i].tolist(), qd[i].tolist(), tau[i].tolist()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(base_ns + round(i * NS / rate), NS)
        send_ns[i] = time.time_ns()
        pub.publish(msg)
    wall = time.monotonic() - t0
    cpu = time.process_time()
    time.sleep(0.5)  # the last feed-forward messages
    probe.close()
    m = min(probe.n, len(probe.recv))
    np.savez(out.with_suffix(".npz"), send_ns=send_ns, ff_stamp=probe.stamp[:m], ff_recv=probe.recv[:m],
             ff_mono=probe.mono[:m])
    out.write_text(json.dumps({"sent": n, "wall_s": wall, "late_2ms": late, "cpu_s": cpu, "base_ns": base_ns,
                               "feedforward_received": probe.n}))
    node.destroy_node()
    rclpy.try_shutdown()


FLOOR_PERIOD_S = 1e-3  # wake-up period of the machine-floor probe [s]
FLOOR_STALL_S = 1e-3  # a wake-up later than this is a stall of the machine [s]
FLOOR_WARMUP_S = 0.5  # the floor probe's first wake-ups, not recorded [s] (it starts long before the publisher)


def run_floor(duration: float, cpu: int, out: Path) -> None:
    """The wake-up latency of CPU ``cpu``, the floor under any feed-forward figure: one thread bound
    to it that does nothing but sleep to a deadline every FLOOR_PERIOD_S for at most ``duration`` s or
    until SIGTERM (started under ``chrt --fifo 99`` where allowed: only the kernel and the hypervisor
    can delay it) and records how late each wake-up was; writes ``out`` (npz: ``due`` [s,
    time.monotonic], ``late`` [s])."""
    os.sched_setaffinity(0, {cpu})
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    gc.freeze()
    gc.disable()
    n = int(duration / FLOOR_PERIOD_S)
    due = np.zeros(n)
    late = np.zeros(n)
    t0 = time.monotonic()
    i = 0
    while i < n and not stop:
        target = t0 + (i + 1) * FLOOR_PERIOD_S
        delay = target - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        late[i] = time.monotonic() - target
        due[i] = target
        i += 1
    keep = due[:i] > t0 + FLOOR_WARMUP_S  # the process's own start (page faults, migration) is not the machine
    np.savez(out, due=due[:i][keep], late=late[:i][keep])


def steal_s() -> float:
    """CPU time the hypervisor has taken from the CPUs so far (/proc/stat steal) [s]."""
    try:
        with open("/proc/stat") as f:
            return int(f.readline().split()[8]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


def machine_stalls(floor_npz: list[Path], start_s: np.ndarray, end_s: np.ndarray) -> tuple[dict, np.ndarray]:
    """The floor probes' figures (one per CPU) and, for each interval [``start_s``, ``end_s``]
    (time.monotonic [s]), whether a stall of any CPU (a floor wake-up later than FLOOR_STALL_S)
    overlaps it: conservative, the message's threads may have run on the other CPU."""
    probes = [np.load(path) for path in floor_npz]
    due, late = (np.concatenate([f[k] for f in probes]) for k in ("due", "late"))
    stall = late > FLOOR_STALL_S
    starts = sum(int(np.sum((f["late"] > FLOOR_STALL_S) & ~np.r_[False, f["late"][:-1] > FLOOR_STALL_S]))
                 for f in probes)  # a stall and its catch-up count once
    a, b = due[stall], due[stall] + late[stall]  # each stalled stretch [s]
    # an interval overlaps a stretch when it starts before the stretch ends and ends after it starts
    order = np.argsort(a)
    a, b = a[order], np.maximum.accumulate(b[order])
    k = np.searchsorted(a, end_s, side="right") - 1  # the last stretch starting before the interval ends
    hit = (k >= 0) & (b[np.maximum(k, 0)] > start_s) if a.size else np.zeros(np.shape(end_s), bool)
    summary = {"period_ms": FLOOR_PERIOD_S * 1e3, "cpus": len(probes), "wakeups": int(late.size),
               "late_p50_ms": pct(late, 50) * 1e3, "late_p99_ms": pct(late, 99) * 1e3,
               "late_max_ms": pct(late, 100) * 1e3, "stalls": starts}
    return summary, hit


# ----------------------------------------------------------------------------- bench process


class Node:
    def __init__(self, workdir: Path, domain: int, buffer_s: float, tag: str, executor: str = "events",
                 extra: dict | None = None):
        params = workdir / "params.yaml"
        lines = "".join(f"    {k}: {json.dumps(v)}\n" for k, v in (extra or {}).items())
        params.write_text(f"""/**/frictionid:
  ros__parameters:
    joints: {json.dumps(JOINTS)}
    system: "friction-only"
    buffer_seconds: {float(buffer_s)}
    smoothing_eps: 0.01
    diagnostics_period_s: 1.0
    max_missing_pct: 50.0
    max_budget: {HUGE_BUDGET}
    input_executor: "{executor}"
    results_file: "{workdir / 'parameters.json'}"
{lines}""")
        self.err = workdir / f"node-{tag}.err"
        with open(self.err, "w") as err:
            self.proc = subprocess.Popen([sys.executable, "-m", "frictionid_ros.node", "--params-file", str(params)],
                                         env=_env(domain), stdout=err, stderr=subprocess.STDOUT)
        self.workdir = workdir

    def rss_kb(self) -> int:
        try:
            for line in open(f"/proc/{self.proc.pid}/status"):
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
        except OSError:
            pass
        return 0


class Bench:
    def __init__(self, domain: int):
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from frictionid_interfaces.msg import IdentifiedParameters
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

        self.rclpy = rclpy
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("frictionid_bench", context=self.ctx)
        self.diag = {}
        self.diag_log = []
        self.lock = threading.Lock()
        self.params = []
        rel = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
        self.latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                  durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.IdentifiedParameters = IdentifiedParameters
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, rel)
        # /diagnostics on its own executor thread, the clients on another (the feed-forward is
        # received in the publisher process: FeedForwardProbe)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.svc_node = rclpy.create_node("frictionid_bench_client", context=self.ctx)
        self.svc_executor = SingleThreadedExecutor(context=self.ctx)
        self.svc_executor.add_node(self.svc_node)
        self._closing = threading.Event()
        self.threads = [threading.Thread(target=self._spin, args=(ex,), daemon=True)
                        for ex in (self.executor, self.svc_executor)]
        for t in self.threads:
            t.start()
        self._clients = {}
        from frictionid_interfaces.action import Identify as IdentifyAction
        from rclpy.action import ActionClient

        self.IdentifyAction = IdentifyAction
        self.action = ActionClient(self.svc_node, IdentifyAction, "/frictionid/identify")

    @staticmethod
    def wait(future, timeout: float):
        """The result of ``future`` (None if not done within ``timeout`` s)."""
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        return future.result() if done.wait(timeout) else None

    def send_goal(self, feedback: list | None = None, **fields):
        """An accepted ``~/identify`` action goal handle (None if the server does not answer)."""
        if not self.action.wait_for_server(timeout_sec=30):
            raise RuntimeError("action ~/identify unavailable")
        cb = None if feedback is None else (lambda m: feedback.append((time.monotonic(), m.feedback)))
        return self.wait(self.action.send_goal_async(self.IdentifyAction.Goal(**fields), feedback_callback=cb), 30)

    def _spin(self, ex):
        """Spin until closed; an exception in one callback must not stop every later one."""
        while not self._closing.is_set():
            try:
                ex.spin_once(timeout_sec=0.05)
            except Exception:
                if self._closing.is_set() or not self.ctx.ok():
                    return

    def _on_diag(self, arr):
        with self.lock:
            for s in arr.status:
                self.diag[s.name] = {kv.key: kv.value for kv in s.values}
            statuses = {s.name: {kv.key: kv.value for kv in s.values} for s in arr.status}
            self.diag_log.append((time.monotonic(), statuses))

    def diag_value(self, key, status="frictionid: joint buffer", fresh_after=None, timeout=10.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                log = list(self.diag_log)
            for t, d in reversed(log):
                if fresh_after is None or t > fresh_after:
                    if status in d:
                        return d[status][key]
                    break
            time.sleep(0.05)
        raise RuntimeError(f"no diagnostics '{status}' within {timeout} s")

    def client(self, srv, name):
        if name not in self._clients:
            from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
            self._clients[name] = self.svc_node.create_client(srv, name, qos_profile=qos)
        return self._clients[name]

    def call_async(self, srv, name, req):
        cli = self.client(srv, name)
        if not cli.wait_for_service(timeout_sec=30):
            raise RuntimeError(f"{name} unavailable")
        done = threading.Event()
        fut = cli.call_async(req)
        fut.add_done_callback(lambda _: done.set())
        return fut, done

    def call(self, srv, name, req, timeout=120.0):
        fut, done = self.call_async(srv, name, req)
        if not done.wait(timeout):
            return None
        return fut.result()

    def latched_parameters(self, timeout=30.0):
        got = []  # the subscription is kept: destroying one the executor may be serving is racy
        self.svc_node.create_subscription(self.IdentifiedParameters, "/frictionid/parameters", got.append,
                                          self.latched)
        deadline = time.monotonic() + timeout
        while not got and time.monotonic() < deadline:
            time.sleep(0.005)
        return got[-1] if got else None

    def close(self):
        self._closing.set()
        for t in self.threads:
            t.join(2)
        for ex in (self.executor, self.svc_executor):
            ex.shutdown(timeout_sec=2)
        for t in self.threads:
            t.join(2)
        self.node.destroy_node()
        self.svc_node.destroy_node()
        self.rclpy.shutdown(context=self.ctx)


def wait_ready(bench: Bench, node: Node, timeout=30.0) -> float:
    from frictionid_interfaces.srv import Identify

    t0 = time.monotonic()
    cli = bench.client(Identify, "/frictionid/identify")
    while not cli.wait_for_service(timeout_sec=0.1):
        if node.proc.poll() is not None:
            raise RuntimeError(f"node exited: {node.err.read_text()}")
        if time.monotonic() - t0 > timeout:
            raise RuntimeError("node not ready")
    return time.monotonic() - t0


def _cpu_s(pid) -> float:
    """User + system CPU time of process ``pid`` so far [s]."""
    try:
        f = open(f"/proc/{int(pid)}/stat").read().rsplit(")", 1)[1].split()
        return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


def _running(pid) -> bool:
    """True if process ``pid`` exists and is not a zombie."""
    try:
        return open(f"/proc/{int(pid)}/stat").read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, ValueError, IndexError):
        return False


def pct(a, q):
    a = np.asarray(a, float)
    a = a[np.isfinite(a)]
    return float(np.percentile(a, q)) if a.size else float("nan")


def write_true_parameters(path: Path) -> None:
    """The true friction of the published motion as the node's results file."""
    from frictionid_ros.store import JointParams, Results, write_results

    write_results(path, Results({j: JointParams(j, "friction-only", "coulomb", False, "ls",
                                                {"Fv": float(FV[i]), "Fc": float(FC[i]), "offset": 0.0})
                                 for i, j in enumerate(JOINTS)}))


def timeline(lat_s: np.ndarray, t_s: np.ndarray, during: np.ndarray, step: float = 2.0) -> list:
    """[start [s], p50, p99, max [ms], share during an identification] of each ``step`` s: tells a
    burst of the machine (every percentile up) from the node's."""
    rows = []
    for a in np.arange(0.0, float(np.nanmax(t_s, initial=0.0)), step):
        m = (t_s >= a) & (t_s < a + step) & np.isfinite(lat_s)
        if m.any():
            rows.append([round(float(a), 1), *(round(pct(lat_s[m], q) * 1e3, 3) for q in (50, 99, 100)),
                         round(float(during[m].mean()), 2)])
    return rows


def lat_stats(lat_s: np.ndarray) -> dict:
    """p50, p99, max [ms] and n of latencies [s]."""
    return {"p50": pct(lat_s, 50) * 1e3, "p99": pct(lat_s, 99) * 1e3, "max": pct(lat_s, 100) * 1e3,
            "n": int(np.isfinite(lat_s).sum())}


def phase_load(bench: Bench, node: Node, args, work: Path, domain: int, buffer_s: float) -> dict:
    """1 kHz x 6 joints for ``args.duration`` s; an ls identification every 10 s and one long de
    action goal from 30 % to 80 % of the run (then cancelled): feed-forward latency idle and during."""
    from frictionid_interfaces.srv import Identify

    pub_out = work / "publisher.json"
    floor_out = [work / f"floor{cpu}.npz" for cpu in sorted(os.sched_getaffinity(0))]
    floors = [subprocess.Popen([*args.floor_prefix, sys.executable, __file__, "--role", "floor", "--cpu", path.stem[5:],
                                "--duration", str(args.duration + 60), "--pub-out", str(path)], env=_env(domain))
              for path in floor_out]
    steal0 = steal_s()
    pub = subprocess.Popen([*args.pub_prefix, sys.executable, __file__, "--role", "publisher", "--rate", str(args.rate),
                            "--duration", str(args.duration), "--pub-out", str(pub_out)], env=_env(domain))
    rss, idents = [], []  # idents: boxes of (start, end, success, message)
    cpu0 = {"node": _cpu_s(node.proc.pid), "bench": time.process_time()}
    t_load = time.monotonic()
    next_ls = t_load + 10.0
    de = {"handle": None, "start": 0.0, "feedback": []}

    def run_identify(req, box):
        t0 = time.monotonic()
        res = bench.call(Identify, "/frictionid/identify", req, timeout=300)
        box.append((t0, time.monotonic(), bool(res and res.success), res.message if res else "timeout", res))

    try:
        while pub.poll() is None:
            now = time.monotonic()
            rss.append((now - t_load, node.rss_kb()))
            if now >= next_ls:
                box = []
                threading.Thread(target=run_identify, args=(Identify.Request(window_seconds=buffer_s * 0.9), box),
                                 daemon=True).start()
                idents.append(box)
                next_ls += 10.0
            if de["handle"] is None and now - t_load > 0.3 * args.duration:
                de["start"] = time.monotonic()
                de["handle"] = bench.send_goal(de["feedback"], friction_model="tustin", solver="de", population=200,
                                               budget=HUGE_BUDGET, window_seconds=0.9 * buffer_s, dry_run=True)
            if de["handle"] is not None and "end" not in de:
                if "result" not in de:
                    de["result"] = de["handle"].get_result_async()
                    de["result"].add_done_callback(lambda _: de.setdefault("done_at", time.monotonic()))
                if "done_at" not in de and "cancelled" not in de and now - t_load > 0.8 * args.duration:
                    de["cancelled"] = bench.wait(de["handle"].cancel_goal_async(), 10)
                got = bench.wait(de["result"], 30) if "done_at" in de else None
                if got is not None:
                    de["end"] = de["done_at"]
                    idents.append([(de["start"], de["end"], bool(got.result.success), got.result.message, None)])
            time.sleep(0.25)
    finally:
        if pub.poll() is None:
            pub.kill()
        for floor in floors:
            floor.terminate()
            floor.wait(10)
    load_wall = time.monotonic() - t_load
    steal = steal_s() - steal0
    cpu = {"node": (_cpu_s(node.proc.pid) - cpu0["node"]) / load_wall,
           "bench_clients": (time.process_time() - cpu0["bench"]) / load_wall}
    time.sleep(2.5)  # let the last identification and diagnostics in
    if de["handle"] is not None and "end" not in de:  # not answered during the load phase
        got = bench.wait(de["result"], 30) if "result" in de else None
        de["end"] = de.get("done_at", time.monotonic())
        idents.append([(de["start"], de["end"], bool(got and got.result.success),
                        got.result.message if got else "no answer", None)])
    pubres = json.loads(pub_out.read_text())
    received = int(bench.diag_value("received", fresh_after=time.monotonic()))
    done_idents = [b[0] for b in idents if b]
    times = np.load(pub_out.with_suffix(".npz"))
    send_ns, ff_mono = times["send_ns"], times["ff_mono"]
    idx = np.round((times["ff_stamp"] - pubres["base_ns"]) * args.rate / NS).astype(np.int64)
    ok = (idx >= 0) & (idx < len(send_ns))
    lat = np.full(len(idx), np.nan)  # end to end: actual send → feed-forward received by the publisher [s]
    lat[ok] = (times["ff_recv"][ok] - send_ns[idx[ok]]) * 1e-9
    during = np.zeros(len(idx), bool)
    for a, b, *_ in done_idents:
        during |= (ff_mono >= a) & (ff_mono <= b)
    settled = ff_mono >= t_load + SETTLE_S  # idle/during: after the start-up transient
    floor_fig, stalled = machine_stalls(floor_out, ff_mono - np.nan_to_num(lat), ff_mono)
    clear = settled & ~stalled  # no stall of the machine itself while the message was on its way
    reports = [(t, d["frictionid: identification"]) for t, d in bench.diag_log
               if "frictionid: identification" in d and d["frictionid: identification"]["ff_published"] != "0"]
    node_us = {k: [float(r[f"ff_latency_{k}_us"]) for _, r in reports] for k in ("p50", "p99", "max")}
    # The node's figures cover its last LATENCY_WINDOW messages (~4.1 s at 1 kHz): a report is
    # "during" when that whole stretch lies inside an identification, "idle" when none touches it.
    span = 4096 / args.rate + 0.2
    spans = [(a, b) for a, b, *_ in done_idents]
    inside = [r for t, r in reports if any(a <= t - span and t <= b for a, b in spans)]
    outside = [r for t, r in reports
               if t - span >= t_load + SETTLE_S and not any(t - span <= b and a <= t for a, b in spans)]

    def node_split(rs):
        return {"reports": len(rs), "p99_worst_us": max((float(r["ff_latency_p99_us"]) for r in rs), default=None),
                "max_worst_us": max((float(r["ff_latency_max_us"]) for r in rs), default=None)}

    rss_kb = np.array([r for _, r in rss if r > 0])
    rss_full = [r for t, r in rss if t > buffer_s + 2.0 and r > 0]
    first_ok = next((b[4] for b in done_idents if b[2] and b[4] is not None), None)
    accuracy = None
    if first_ok is not None:
        j = {jf.joint_name: dict(zip(jf.param_names, jf.param_values)) for jf in first_ok.result.joints}
        accuracy = {"max_rel_err_Fv_pct": max(abs(j[m]["Fv"] / FV[i] - 1) * 100 for i, m in enumerate(JOINTS)),
                    "max_rel_err_Fc_pct": max(abs(j[m]["Fc"] / FC[i] - 1) * 100 for i, m in enumerate(JOINTS))}
    generations = [f.generation for _, f in de["feedback"]]
    return {
        "sent": pubres["sent"], "publisher_wall_s": round(pubres["wall_s"], 3),
        "publisher_late_gt_2ms": pubres["late_2ms"],
        "cpu_cores": {**{k: round(v, 3) for k, v in cpu.items()},
                      "publisher_and_probe": round(pubres["cpu_s"] / pubres["wall_s"], 3)},
        "received_by_node": received, "lost": pubres["sent"] - received,
        "rejected": int(bench.diag_value("rejected")),
        "feedforward_published_by_node": int(bench.diag_value("ff_published", status="frictionid: identification")),
        "feedforward_received_by_publisher": int(pubres["feedforward_received"]),
        "node_latency_us": {"p50_median": pct(node_us["p50"], 50), "p99_median": pct(node_us["p99"], 50),
                            "p99_worst": max(node_us["p99"], default=None),
                            "max_worst": max(node_us["max"], default=None),
                            "idle": node_split(outside), "during_identification": node_split(inside)},
        "end_to_end_latency_ms": {"all": lat_stats(lat), "start_up": lat_stats(lat[~settled]),
                                  "idle": lat_stats(lat[settled & ~during]),
                                  "during_identification": lat_stats(lat[settled & during])},
        "machine_floor": {**floor_fig, "steal_s": round(steal, 3), "scheduling": args.floor_sched,
                          "messages_overlapping_a_stall": int(np.sum(settled & stalled))},
        "end_to_end_latency_ms_outside_machine_stalls": {"idle": lat_stats(lat[clear & ~during]),
                                                         "during_identification": lat_stats(lat[clear & during])},
        "end_to_end_timeline_ms": timeline(lat, ff_mono - t_load, during),
        "worst_end_to_end": [{"ms": round(float(lat[i]) * 1e3, 3), "at_s": round(float(ff_mono[i] - t_load), 3),
                              "during_identification": bool(during[i]), "machine_stall": bool(stalled[i])}
                             for i in np.argsort(np.nan_to_num(lat, nan=-1.0))[::-1][:8]],
        "long_identification": {"feedback_messages": len(de["feedback"]),
                                "generations_done": max(generations, default=0),
                                "seconds": round(de.get("end", 0.0) - de["start"], 2)},
        "rss_kb": {"start": int(rss_kb[0]) if rss_kb.size else None, "max": int(rss_kb.max()) if rss_kb.size else None,
                   "end": int(rss_kb[-1]) if rss_kb.size else None,
                   "after_buffer_full_min": min(rss_full) if rss_full else None,
                   "after_buffer_full_max": max(rss_full) if rss_full else None},
        "rss_timeline_kb": [(round(t, 1), r) for t, r in rss[::8]],
        "buffer_bytes": int(bench.diag_value("buffer_bytes")),
        "worker_rss_kb_end": int(bench.diag_value("worker_rss_kb")),
        "identifications": [{"start_s": round(a - t_load, 2), "wall_s": round(b - a, 3), "success": okay,
                             "message": message[:160]} for a, b, okay, message, _ in done_idents],
        "accuracy_first_ls": accuracy,
    }


def phase_cancel(bench: Bench, cycles: int) -> dict:
    """``cycles`` times: a huge de action goal, cancelled 0.3-1 s after its first progress report,
    then at once an ls identification; and a huge request refused by the limits, then ls.
    Times: cancel → result here, cancel → worker stopped (the node's figure in the result
    message), cancel (refusal) → the next identification answered successfully."""
    import re

    from frictionid_interfaces.srv import Identify

    rng = np.random.default_rng(7)
    normal = Identify.Request(window_seconds=2.0, dry_run=True)
    rows = []
    for _ in range(cycles):
        feedback = []
        handle = bench.send_goal(feedback, friction_model="tustin", solver="de", population=200,
                                 budget=HUGE_BUDGET, window_seconds=5.0)
        deadline = time.monotonic() + 60
        while not any(f.generation for _, f in feedback) and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(float(rng.uniform(0.3, 1.0)))
        t_cancel = time.monotonic()
        bench.wait(handle.cancel_goal_async(), 10)
        got = bench.wait(handle.get_result_async(), 30)
        t_result = time.monotonic()
        res = bench.call(Identify, "/frictionid/identify", normal, timeout=60)
        t_next = time.monotonic()
        stopped = re.search(r"stopped (\d+) ms after the cancel", got.result.message) if got else None
        rows.append({"status": int(got.status) if got else None,
                     "cancel_to_result_ms": (t_result - t_cancel) * 1e3,
                     "cancel_to_worker_stopped_ms": float(stopped.group(1)) if stopped else None,
                     "cancel_to_next_success_ms": (t_next - t_cancel) * 1e3 if res and res.success else None,
                     "generations_before_cancel": max((f.generation for _, f in feedback), default=0)})
    t0 = time.monotonic()
    refused = bench.call(Identify, "/frictionid/identify",
                         Identify.Request(solver="de", budget=2_000_000_000, window_seconds=5.0), timeout=30)
    res = bench.call(Identify, "/frictionid/identify", normal, timeout=60)
    worker = [r["cancel_to_worker_stopped_ms"] for r in rows if r["cancel_to_worker_stopped_ms"] is not None]
    return {"cycles": rows,
            "cancel_to_worker_stopped_ms_max": max(worker, default=None),
            "cancel_to_result_ms_max": max((r["cancel_to_result_ms"] for r in rows), default=None),
            "cancel_to_next_success_ms_max": max((r["cancel_to_next_success_ms"] or float("inf") for r in rows),
                                                 default=None),
            "refused": refused.message if refused else None,
            "refusal_to_next_success_ms": (time.monotonic() - t0) * 1e3 if res and res.success else None}


def phase_storm(bench: Bench, node: Node) -> dict:
    """200 concurrent ~/identify calls (one runs, the rest answered "busy" at once), then 200 in a row."""
    from frictionid_interfaces.srv import Identify

    storm = {}
    req = Identify.Request(window_seconds=2.0, dry_run=True)
    t0 = time.monotonic()
    calls = [bench.call_async(Identify, "/frictionid/identify", req) for _ in range(200)]
    deadline = time.monotonic() + 60
    answered = [done.wait(max(0.0, deadline - time.monotonic())) for _, done in calls]
    results = [f.result() for f, _ in calls if f.done()]
    storm["concurrent"] = {"calls": 200, "answered": int(sum(answered)), "wall_s": round(time.monotonic() - t0, 3),
                           "success": sum(r.success for r in results),
                           "busy": sum((not r.success) and r.message.startswith("busy") for r in results),
                           "other_failures": [r.message for r in results
                                              if not r.success and not r.message.startswith("busy")][:3]}
    lat_calls, ok = [], 0
    t0 = time.monotonic()
    for _ in range(200):
        a = time.monotonic()
        r = bench.call(Identify, "/frictionid/identify", req, timeout=30)
        lat_calls.append(time.monotonic() - a)
        ok += bool(r and r.success)
    storm["sequential"] = {"calls": 200, "success": ok, "wall_s": round(time.monotonic() - t0, 3),
                           "p50_ms": pct(lat_calls, 50) * 1e3, "p99_ms": pct(lat_calls, 99) * 1e3}
    storm["node_alive"] = node.proc.poll() is None
    return storm


def phase_crash(bench: Bench, node: Node, args, work: Path, domain: int, buffer_s: float, extra: dict):
    """kill -9 during a slow identification, restart: (figures, the new node)."""
    from frictionid_interfaces.srv import Identify

    crash = {}
    good = bench.latched_parameters()
    good_values = {jf.joint_name: list(jf.param_values) for jf in good.joints} if good else None
    # refill a little data so that the slow run has something to chew on, then kill it mid-way
    pub2_out = work / "publisher2.json"
    subprocess.run([sys.executable, __file__, "--role", "publisher", "--rate", str(args.rate), "--duration", "3",
                    "--pub-out", str(pub2_out)], env=_env(domain), timeout=60)
    box = []
    slow = Identify.Request(friction_model="tustin", solver="de", population=100, budget=HUGE_BUDGET,
                            window_seconds=3.0)
    threading.Thread(target=lambda: box.append(bench.call(Identify, "/frictionid/identify", slow, timeout=300)),
                     daemon=True).start()
    busy, deadline = "False", time.monotonic() + 20
    while busy != "True" and time.monotonic() < deadline:
        busy = bench.diag_value("busy", status="frictionid: identification", fresh_after=time.monotonic())
    crash["busy_when_killed"] = busy == "True"
    worker_pid = bench.diag_value("worker_pid")
    os.kill(node.proc.pid, signal.SIGKILL)
    node.proc.wait(10)
    crash["killed_rc"] = node.proc.returncode
    time.sleep(0.5)
    crash["worker_gone_after_kill"] = not _running(worker_pid)
    crash["killed_request_answered"] = bool(box)
    try:
        saved = json.loads((work / "parameters.json").read_text())
        crash["results_file_valid_json"] = True
        crash["results_file_joints"] = sorted(saved.get("per_joint", {}))
    except (OSError, ValueError) as exc:
        crash["results_file_valid_json"] = f"no: {exc}"
    t0 = time.monotonic()
    node = Node(work, domain, buffer_s, "restart", args.input_executor, extra)
    got = bench.latched_parameters()  # the dead node cannot answer: this comes from the new one
    crash["parameters_after_restart_s"] = round(time.monotonic() - t0, 3)
    got_values = {jf.joint_name: list(jf.param_values) for jf in got.joints} if got else None
    crash["parameters_restored_equal"] = got_values == good_values and good_values is not None
    return crash, node


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=None, help="load phase [s] (default 60; 20 with --quick)")
    ap.add_argument("--quick", action="store_true", help="20 s of load, 3 cancels, no storm and no crash phase")
    ap.add_argument("--rate", type=float, default=1000.0, help="joint_states rate [Hz]")
    ap.add_argument("--buffer", type=float, default=None, help="node buffer_seconds (default duration/3)")
    ap.add_argument("--cancels", type=int, default=None, help="cancel cycles (default 5; 3 with --quick)")
    ap.add_argument("--input-executor", default="events", choices=("events", "single_threaded"),
                    help="the node's input_executor parameter")
    ap.add_argument("--worker-nice", type=int, default=None, help="the node's worker_nice (default: the node's)")
    ap.add_argument("--realtime", default="auto", metavar="PRIO|auto|off",
                    help="the node's realtime_priority (its input/feed-forward thread SCHED_FIFO) and the publisher "
                         "process (the robot's controller) under chrt --fifo at that priority, as ros2_control runs "
                         "its loop; auto (default): SCHED_FIFO 10 where the OS allows, else normal scheduling")
    ap.add_argument("--competitors", type=int, default=0,
                    help="CPU-bound processes (python -c 'while True: pass') running throughout: a robot computer "
                         "is never idle")
    ap.add_argument("--out", type=Path, default=None,
                    help="JSON results (default bench/results/ros_load.json, ros_load_quick.json with --quick)")
    ap.add_argument("--role", default="bench", help=argparse.SUPPRESS)
    ap.add_argument("--pub-out", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--cpu", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    args.duration = args.duration or (20.0 if args.quick else 60.0)
    if args.role == "publisher":
        run_publisher(args.rate, args.duration, args.pub_out)
        return 0
    if args.role == "floor":
        run_floor(args.duration, args.cpu, args.pub_out)
        return 0
    out = args.out or ROOT / "bench" / "results" / ("ros_load_quick.json" if args.quick else "ros_load.json")
    cancels = args.cancels if args.cancels is not None else (3 if args.quick else 5)

    warnings.simplefilter("ignore", DeprecationWarning)
    domain = random.randint(1, 200)
    buffer_s = args.buffer or max(5.0, round(args.duration / 3))
    extra = {} if args.worker_nice is None else {"worker_nice": args.worker_nice}
    extra["realtime_priority"] = args.realtime
    try:
        prio = realtime_priority(args.realtime)
    except FrictionIdError as exc:
        ap.error(str(exc))
    args.pub_prefix = ["chrt", "--fifo", str(prio)] if prio else []
    args.floor_prefix = ["chrt", "--fifo", "99"] if prio else []
    args.floor_sched = "SCHED_FIFO 99 (chrt)" if prio else "normal (SCHED_OTHER)"
    competitors = Competitors(args.competitors).start()
    work = Path(tempfile.mkdtemp(prefix="frictionid_bench_"))
    write_true_parameters(work / "parameters.json")  # restored at start: feed-forward from the first message
    result = {"input_executor": args.input_executor, "node_parameters": extra, "duration_s": args.duration,
              "rate_hz": args.rate, "joints": len(JOINTS), "buffer_seconds": buffer_s, "domain": domain,
              "cpus": os.cpu_count(), "loadavg_start": os.getloadavg(),
              "scheduling": {"publisher": f"SCHED_FIFO {prio} (chrt)" if prio else "normal (SCHED_OTHER)",
                             "node_requested": args.realtime, "competitors": args.competitors,
                             "competitor": f"{COMPETITOR} (normal scheduling)"}}
    bench = Bench(domain)
    gc.freeze()  # as the node does: no ~100 ms full collections stalling the clients
    node = Node(work, domain, buffer_s, "load", args.input_executor, extra)
    try:
        result["node_start_s"] = wait_ready(bench, node)
        result["scheduling"]["node_input_thread"] = bench.diag_value("scheduling")
        result["load"] = phase_load(bench, node, args, work, domain, buffer_s)
        result["cancel"] = phase_cancel(bench, cancels)
        result["cancel"]["node_alive"] = node.proc.poll() is None
        if not args.quick:
            result["service_storm"] = phase_storm(bench, node)
            result["crash"], node = phase_crash(bench, node, args, work, domain, buffer_s, extra)
    finally:
        if node.proc.poll() is None:
            node.proc.send_signal(signal.SIGTERM)
            try:
                result["final_stop_rc"] = node.proc.wait(15)
            except subprocess.TimeoutExpired:
                node.proc.kill()
        bench.close()
        competitors.stop()

    result["loadavg_end"] = os.getloadavg()
    write_json(out, result)
    L, C = result["load"], result["cancel"]
    e2e = L["end_to_end_latency_ms"]
    print(f"scheduling: {result['scheduling']}")
    print(f"load: {L['sent']} sent at {args.rate:g} Hz x {len(JOINTS)} joints, node received {L['received_by_node']} "
          f"(lost {L['lost']}); feed-forward published {L['feedforward_published_by_node']}, received by the "
          f"publisher {L['feedforward_received_by_publisher']}")
    print(f"  CPU [cores]: {L['cpu_cores']}")
    print(f"  node feed-forward latency (receipt -> published): p50 {L['node_latency_us']['p50_median']:.0f} us, "
          f"p99 (median of the 1 s reports) {L['node_latency_us']['p99_median']:.0f} us, worst report p99 "
          f"{L['node_latency_us']['p99_worst']:.0f} us, max {L['node_latency_us']['max_worst']:.0f} us; "
          f"idle {L['node_latency_us']['idle']}, during identification {L['node_latency_us']['during_identification']}")
    for name in ("start_up", "idle", "during_identification"):
        f = e2e[name]
        print(f"  end to end (publisher -> node -> publisher), {name.replace('_', ' ')}: p50 {f['p50']:.3f} ms, "
              f"p99 {f['p99']:.3f} ms, max {f['max']:.3f} ms (n={f['n']})")
    print(f"  worst end to end: {L['worst_end_to_end']}")
    M, clear = L["machine_floor"], L["end_to_end_latency_ms_outside_machine_stalls"]
    print(f"  machine floor (on each of {M['cpus']} CPUs a thread that only sleeps {M['period_ms']:g} ms, "
          f"{M['scheduling']}): wake-up late p99 "
          f"{M['late_p99_ms']:.3f} ms, max {M['late_max_ms']:.3f} ms; {M['stalls']} stalls over "
          f"{FLOOR_STALL_S * 1e3:g} ms, {M['messages_overlapping_a_stall']} messages on their way during one; "
          f"hypervisor steal {M['steal_s']:.2f} s")
    for name in ("idle", "during_identification"):
        f = clear[name]
        print(f"  end to end outside the machine's stalls, {name.replace('_', ' ')}: p50 {f['p50']:.3f} ms, "
              f"p99 {f['p99']:.3f} ms, max {f['max']:.3f} ms (n={f['n']})")
    print(f"  long de goal: {L['long_identification']}")
    print(f"  node RSS: start {L['rss_kb']['start']} kB, max {L['rss_kb']['max']} kB, after the buffer filled "
          f"{L['rss_kb']['after_buffer_full_min']}..{L['rss_kb']['after_buffer_full_max']} kB "
          f"(ring buffer {L['buffer_bytes'] / 1e6:.1f} MB); worker process {L['worker_rss_kb_end']} kB")
    for i in L["identifications"]:
        print(f"  identify at {i['start_s']} s: {i['wall_s']} s, success {i['success']}: {i['message'][:90]}")
    print(f"  accuracy of the first ls identification: {L['accuracy_first_ls']}")
    print(f"cancel ({len(C['cycles'])} cycles): worker stopped <= {C['cancel_to_worker_stopped_ms_max']} ms after the "
          f"cancel, result here <= {C['cancel_to_result_ms_max']:.0f} ms, next identification answered <= "
          f"{C['cancel_to_next_success_ms_max']:.0f} ms after the cancel; refused huge request ({C['refused']}), next "
          f"identification {C['refusal_to_next_success_ms']} ms later; node alive {C['node_alive']}")
    if "service_storm" in result:
        S = result["service_storm"]
        print(f"service storm: concurrent {S['concurrent']}; sequential {S['sequential']}; alive {S['node_alive']}")
        print(f"crash: {result['crash']}")
    print(f"machine load average (1, 5, 15 min): start {result['loadavg_start']}, end {result['loadavg_end']}")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
