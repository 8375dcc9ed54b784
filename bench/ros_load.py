"""Load and fault benchmark of the frictionid ROS 2 node (not a test).

    python bench/ros_load.py                 # 60 s at 1 kHz, 6 joints
    python bench/ros_load.py --duration 20   # shorter first run

Phases, each against a real node subprocess (``python -m frictionid_ros.node``, system
friction-only, 6 joints, default sensor-data QoS) on a private ROS domain:

1. load: a publisher subprocess sends JointState (6 joints, position/velocity/effort of a
   known Coulomb + viscous friction) at 1 kHz for ``--duration`` s, stamped with its sample time
   (like a driver's clock); the actual send time of every message is recorded.
   Meanwhile identifications run: an ``ls`` one every 10 s and one slow ``de`` (Tustin) run.
   Measured: messages sent vs taken in by the node (its /diagnostics ``received``), feed-forward
   messages received here, feed-forward latency (a) inside the node, middleware receipt of the
   joint state → both messages published (the node's /diagnostics p50/p99 over its last 4096
   messages, reported each second) and (b) end to end, send → ``~/friction_torque_state`` received here
   (two DDS hops + both executors; matched by stamp to the recorded send time), split idle /
   during an identification; node RSS each 0.25 s.
   The ring buffer is shorter than the run (``--buffer``), so memory must plateau once it is full.
2. service storm: 200 concurrent ``~/identify`` calls (one runs, the rest must be answered
   "busy" at once), then 200 sequential calls; every call answered, node alive.
3. crash: ``kill -9`` during a slow identification, restart, time until a late subscriber gets
   the last good parameters on ``~/parameters`` (transient local), values unchanged.

Prints a summary and writes ``bench/results/ros_load.json``.
"""

from __future__ import annotations

import argparse
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

ROOT = Path(__file__).resolve().parents[1]
NS = 1_000_000_000
JOINTS = [f"joint{i + 1}" for i in range(6)]
FV = np.array([3.0, 2.5, 2.0, 1.0, 0.8, 0.5])  # true viscous friction [N·m·s/rad]
FC = np.array([1.5, 1.2, 1.0, 0.6, 0.4, 0.3])  # true Coulomb friction [N·m]


def _env(domain: int) -> dict:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    src = [str(ROOT / "frictionid_core" / "src"), str(ROOT / "frictionid_ros")]
    env["PYTHONPATH"] = os.pathsep.join(src + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    env.pop("_ROS_WHEELS_BOOTSTRAP_COMPLETE", None)
    return env


# ----------------------------------------------------------------------------- publisher role


def run_publisher(rate: float, duration: float, out: Path) -> None:
    """Publish JointState at ``rate`` Hz for ``duration`` s (best effort, like a robot driver)."""
    import rclpy
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node("bench_joint_state_publisher")
    pub = node.create_publisher(JointState, "/joint_states", qos_profile_sensor_data)
    deadline = time.monotonic() + 10
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.5)
    n = int(rate * duration)
    k = np.arange(n) / rate
    freq = 0.2 + 0.07 * np.arange(6)
    amp = 0.8
    q = amp * np.sin(2 * np.pi * np.outer(k, freq))
    qd = amp * 2 * np.pi * freq * np.cos(2 * np.pi * np.outer(k, freq))
    rng = np.random.default_rng(1)
    tau = FV * qd + FC * np.sign(qd) + rng.normal(0, 0.02, qd.shape)
    msg = JointState(name=JOINTS)
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
    np.save(out.with_suffix(".npy"), send_ns)
    out.write_text(json.dumps({"sent": n, "wall_s": wall, "late_2ms": late, "cpu_s": time.process_time(),
                               "base_ns": base_ns}))
    time.sleep(0.5)
    node.destroy_node()
    rclpy.try_shutdown()


# ----------------------------------------------------------------------------- bench process


class Node:
    def __init__(self, workdir: Path, domain: int, buffer_s: float, tag: str, executor: str = "events"):
        params = workdir / "params.yaml"
        params.write_text(f"""/**/frictionid:
  ros__parameters:
    joints: {json.dumps(JOINTS)}
    system: "friction-only"
    buffer_seconds: {float(buffer_s)}
    smoothing_eps: 0.01
    diagnostics_period_s: 1.0
    input_executor: "{executor}"
    results_file: "{workdir / 'parameters.json'}"
""")
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
        from sensor_msgs.msg import JointState

        self.rclpy = rclpy
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("frictionid_bench", context=self.ctx)
        self.ff_stamp = np.zeros(2_000_000, dtype=np.int64)  # stamp of each feed-forward message [ns]
        self.ff_recv = np.zeros(2_000_000, dtype=np.int64)  # its receive time [ns, system clock]
        self.lat_t = np.zeros(2_000_000)  # its receive time (monotonic) [s]
        self.n_ff = 0
        self.diag = {}
        self.diag_log = []
        self.lock = threading.Lock()
        self.params = []
        rel = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
        self.latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                  durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.IdentifiedParameters = IdentifiedParameters
        self.node.create_subscription(JointState, "/frictionid/friction_torque_state", self._on_ff, rel)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, rel)
        # Feed-forward subscription on its own executor thread: nothing else delays it.
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

    def _spin(self, ex):
        """Spin until closed; an exception in one callback must not stop every later one."""
        while not self._closing.is_set():
            try:
                ex.spin_once(timeout_sec=0.05)
            except Exception:  # noqa: BLE001
                if self._closing.is_set() or not self.ctx.ok():
                    return

    def _on_ff(self, m):
        now = time.time_ns()
        i = self.n_ff
        if i < len(self.ff_recv):
            self.ff_recv[i] = now
            self.ff_stamp[i] = m.header.stamp.sec * NS + m.header.stamp.nanosec
            self.lat_t[i] = time.monotonic()
        self.n_ff = i + 1

    def _on_diag(self, arr):
        with self.lock:
            for s in arr.status:
                self.diag[s.name] = {kv.key: kv.value for kv in s.values}
            self.diag_log.append((time.monotonic(), {s.name: {kv.key: kv.value for kv in s.values} for s in arr.status}))

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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="load phase [s] (default 60)")
    ap.add_argument("--rate", type=float, default=1000.0, help="joint_states rate [Hz]")
    ap.add_argument("--buffer", type=float, default=None, help="node buffer_seconds (default duration/3)")
    ap.add_argument("--input-executor", default="events", choices=("events", "single_threaded"),
                    help="the node's input_executor parameter")
    ap.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "ros_load.json")
    ap.add_argument("--role", default="bench", help=argparse.SUPPRESS)
    ap.add_argument("--pub-out", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.role == "publisher":
        run_publisher(args.rate, args.duration, args.pub_out)
        return 0

    warnings.simplefilter("ignore", DeprecationWarning)
    from frictionid_interfaces.srv import Identify

    domain = random.randint(1, 200)
    buffer_s = args.buffer or max(5.0, round(args.duration / 3))
    work = Path(tempfile.mkdtemp(prefix="frictionid_bench_"))
    result = {"input_executor": args.input_executor, "duration_s": args.duration, "rate_hz": args.rate, "joints": len(JOINTS), "buffer_seconds": buffer_s,
              "domain": domain, "cpus": os.cpu_count(), "loadavg_start": os.getloadavg()}
    bench = Bench(domain)
    node = Node(work, domain, buffer_s, "load", args.input_executor)
    try:
        result["node_start_s"] = wait_ready(bench, node)
        # ---------------------------------------------------------------- 1. load
        pub_out = work / "publisher.json"
        pub = subprocess.Popen([sys.executable, __file__, "--role", "publisher", "--rate", str(args.rate),
                                "--duration", str(args.duration), "--pub-out", str(pub_out)], env=_env(domain))
        rss = []
        idents = []  # (start, end, response)
        cpu0 = {"node": _cpu_s(node.proc.pid), "bench": time.process_time()}
        t_load = time.monotonic()
        next_ls = t_load + 10.0
        de_started = False
        de_thread = None

        def run_identify(req, box):
            t0 = time.monotonic()
            res = bench.call(Identify, "/frictionid/identify", req, timeout=300)
            box.append((t0, time.monotonic(), res))

        while pub.poll() is None:
            now = time.monotonic()
            rss.append((now - t_load, node.rss_kb()))
            if now >= next_ls:
                box = []
                threading.Thread(target=run_identify, args=(Identify.Request(window_seconds=buffer_s * 0.9), box),
                                 daemon=True).start()
                idents.append(box)
                next_ls += 10.0
            if not de_started and now - t_load > 0.45 * args.duration:
                box = []
                req = Identify.Request(friction_model="tustin", solver="de", population=30, budget=60,
                                       window_seconds=min(5.0, buffer_s), dry_run=True)
                de_thread = threading.Thread(target=run_identify, args=(req, box), daemon=True)
                de_thread.start()
                idents.append(box)
                de_started = True
            time.sleep(0.25)
        load_wall = time.monotonic() - t_load
        cpu_load = {"node": (_cpu_s(node.proc.pid) - cpu0["node"]) / load_wall,
                    "bench_subscriber": (time.process_time() - cpu0["bench"]) / load_wall}
        if de_thread is not None:
            de_thread.join(300)
        time.sleep(2.5)  # let the last diagnostics in
        pubres = json.loads(pub_out.read_text())
        received = int(bench.diag_value("received", fresh_after=time.monotonic()))
        rejected = int(bench.diag_value("rejected"))
        done_idents = [b[0] for b in idents if b]
        spans = [(a, b) for a, b, _ in done_idents]
        n = min(bench.n_ff, len(bench.ff_recv))
        send_ns = np.load(pub_out.with_suffix(".npy"))
        idx = np.round((bench.ff_stamp[:n] - pubres["base_ns"]) * args.rate / NS).astype(np.int64)
        ok = (idx >= 0) & (idx < len(send_ns))
        lat = np.full(n, np.nan)  # end to end: actual send → feed-forward received here [s]
        lat[ok] = (bench.ff_recv[:n][ok] - send_ns[idx[ok]]) * 1e-9
        lat_t = bench.lat_t[:n]
        during = np.zeros(n, bool)
        for a, b in spans:
            during |= (lat_t >= a) & (lat_t <= b)
        node_p50 = [float(d["frictionid: identification"]["ff_latency_p50_us"]) for _, d in bench.diag_log
                    if "frictionid: identification" in d and d["frictionid: identification"]["ff_published"] != "0"]
        node_p99 = [float(d["frictionid: identification"]["ff_latency_p99_us"]) for _, d in bench.diag_log
                    if "frictionid: identification" in d and d["frictionid: identification"]["ff_published"] != "0"]
        node_max = [float(d["frictionid: identification"]["ff_latency_max_us"]) for _, d in bench.diag_log
                    if "frictionid: identification" in d and d["frictionid: identification"]["ff_published"] != "0"]
        rss_kb = np.array([r for _, r in rss if r > 0])
        full_at = buffer_s + 2.0
        rss_full = [r for t, r in rss if t > full_at and r > 0]
        ff_published = int(bench.diag_value("ff_published", status="frictionid: identification"))
        first_ok = next((b for b in done_idents if b[2] is not None and b[2].success
                         and b[2].result.joints and b[2].result.joints[0].friction_model == "coulomb"), None)
        ident_summary = [{"start_s": round(a - t_load, 2), "wall_s": round(b - a, 3),
                          "success": bool(r.success) if r else None,
                          "message": (r.message[:160] if r else "timeout")} for a, b, r in done_idents]
        accuracy = None
        if first_ok:
            j = {jf.joint_name: dict(zip(jf.param_names, jf.param_values)) for jf in first_ok[2].result.joints}
            accuracy = {"max_rel_err_Fv_pct": max(abs(j[n]["Fv"] / FV[i] - 1) * 100 for i, n in enumerate(JOINTS)),
                        "max_rel_err_Fc_pct": max(abs(j[n]["Fc"] / FC[i] - 1) * 100 for i, n in enumerate(JOINTS))}
        result["load"] = {
            "sent": pubres["sent"], "publisher_wall_s": round(pubres["wall_s"], 3),
            "publisher_late_gt_2ms": pubres["late_2ms"],
            "cpu_cores": {**{k: round(v, 3) for k, v in cpu_load.items()},
                          "publisher": round(pubres["cpu_s"] / pubres["wall_s"], 3)},
            "received_by_node": received, "lost": pubres["sent"] - received, "rejected": rejected,
            "feedforward_published_by_node": ff_published,  # one per joint state once parameters are active
            "feedforward_received_here": int(bench.n_ff),
            "node_latency_us": {"p50_median": pct(node_p50, 50), "p99_median": pct(node_p99, 50),
                                "p99_worst": max(node_p99) if node_p99 else None,
                                "max_worst": max(node_max) if node_max else None},
            "end_to_end_latency_ms": {
                "all": {"p50": pct(lat, 50) * 1e3, "p99": pct(lat, 99) * 1e3, "max": pct(lat, 100) * 1e3,
                        "n": int(np.isfinite(lat).sum())},
                "idle": {"p50": pct(lat[~during], 50) * 1e3, "p99": pct(lat[~during], 99) * 1e3,
                         "n": int((~during).sum())},
                "during_identification": {"p50": pct(lat[during], 50) * 1e3, "p99": pct(lat[during], 99) * 1e3,
                                          "max": pct(lat[during], 100) * 1e3, "n": int(during.sum())}},
            "rss_kb": {"start": int(rss_kb[0]) if rss_kb.size else None, "max": int(rss_kb.max()) if rss_kb.size else None,
                       "end": int(rss_kb[-1]) if rss_kb.size else None,
                       "after_buffer_full_min": min(rss_full) if rss_full else None,
                       "after_buffer_full_max": max(rss_full) if rss_full else None},
            "rss_timeline_kb": [(round(t, 1), r) for t, r in rss[::8]],
            "buffer_bytes": int(bench.diag_value("buffer_bytes")),
            "worker_rss_kb_end": int(bench.diag_value("worker_rss_kb")),
            "identifications": ident_summary, "accuracy_first_ls": accuracy,
        }

        # ---------------------------------------------------------------- 2. service storm
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
        result["service_storm"] = storm

        # ---------------------------------------------------------------- 3. kill -9, restart
        crash = {}
        good = bench.latched_parameters()
        good_values = {jf.joint_name: list(jf.param_values) for jf in good.joints} if good else None
        # refill a little data so that the slow run has something to chew on, then kill it mid-way
        pub2_out = work / "publisher2.json"
        pub2 = subprocess.Popen([sys.executable, __file__, "--role", "publisher", "--rate", str(args.rate),
                                 "--duration", "3", "--pub-out", str(pub2_out)], env=_env(domain))
        pub2.wait(60)
        box = []
        slow = Identify.Request(friction_model="tustin", solver="de", population=100, budget=3000, window_seconds=3.0)
        th = threading.Thread(target=run_identify, args=(slow, box), daemon=True)
        th.start()
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
        node = Node(work, domain, buffer_s, "restart", args.input_executor)
        got = bench.latched_parameters()  # the dead node cannot answer: this comes from the new one
        crash["parameters_after_restart_s"] = round(time.monotonic() - t0, 3)
        got_values = {jf.joint_name: list(jf.param_values) for jf in got.joints} if got else None
        crash["parameters_restored_equal"] = got_values == good_values and good_values is not None
        result["crash"] = crash
    finally:
        for p in ("pub", "pub2"):
            proc = locals().get(p)
            if proc is not None and proc.poll() is None:
                proc.kill()
        if node.proc.poll() is None:
            node.proc.send_signal(signal.SIGTERM)
            try:
                result["final_stop_rc"] = node.proc.wait(15)
            except subprocess.TimeoutExpired:
                node.proc.kill()
        bench.close()

    result["loadavg_end"] = os.getloadavg()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2, default=str) + "\n")
    L, S, C = result["load"], result["service_storm"], result["crash"]
    e2e = L["end_to_end_latency_ms"]
    print(f"load: {L['sent']} sent at {args.rate:g} Hz x {len(JOINTS)} joints, node received {L['received_by_node']} "
          f"(lost {L['lost']}); feed-forward published {L['feedforward_published_by_node']}, received here "
          f"{L['feedforward_received_here']}")
    print(f"  CPU [cores]: {L['cpu_cores']}")
    print(f"  node feed-forward latency (receipt -> published): p50 {L['node_latency_us']['p50_median']:.0f} us, "
          f"p99 (median of the 1 s reports) {L['node_latency_us']['p99_median']:.0f} us, worst report p99 "
          f"{L['node_latency_us']['p99_worst']:.0f} us, max {L['node_latency_us']['max_worst']:.0f} us")
    print(f"  end to end (pub -> node -> here): p50 {e2e['all']['p50']:.3f} ms, p99 {e2e['all']['p99']:.3f} ms; "
          f"during identification p50 {e2e['during_identification']['p50']:.3f} ms, p99 "
          f"{e2e['during_identification']['p99']:.3f} ms (n={e2e['during_identification']['n']})")
    print(f"  node RSS: start {L['rss_kb']['start']} kB, max {L['rss_kb']['max']} kB, after the buffer filled "
          f"{L['rss_kb']['after_buffer_full_min']}..{L['rss_kb']['after_buffer_full_max']} kB "
          f"(ring buffer {L['buffer_bytes'] / 1e6:.1f} MB); worker process {L['worker_rss_kb_end']} kB")
    for i in L["identifications"]:
        print(f"  identify at {i['start_s']} s: {i['wall_s']} s, success {i['success']}: {i['message'][:90]}")
    print(f"  accuracy of the first ls identification: {L['accuracy_first_ls']}")
    print(f"service storm: concurrent {S['concurrent']}; sequential {S['sequential']}; alive {S['node_alive']}")
    print(f"crash: {C}")
    print(f"machine load average (1, 5, 15 min): start {result['loadavg_start']}, end {result['loadavg_end']}")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
