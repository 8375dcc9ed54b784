"""``frictionid loop``: friction compensation in the loop, measured end to end with real rclpy.

Registered in the core CLI through the entry-point group ``frictionid.commands`` (the core
imports no ROS). Three processes on a ROS domain of their own (discovery on this host only):
``frictionid_sim`` (:mod:`.sim_node`), ``frictionid_loop_controller`` (:mod:`.controller_node`)
and ``frictionid_node`` (online re-identification behind the safety gate, feed-forward from the
controller's desired velocity). This process only drives the phases through parameters and
services and computes the figures from the controller's record (:mod:`frictionid_core.loop.evaluate`).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

from frictionid_core import FrictionIdError, write_json
from frictionid_ros.runtime import AUTO_PRIORITY, realtime_priority, reserve_domain

DESCRIPTION = """\
Run a simulated arm (MuJoCo, hidden Stribeck friction), a PD + rigid-body controller and the
frictionid node as separate ROS 2 processes on a low-speed tracking task with reversals, through
phases: feed-forward off; identified feed-forward on (~/identify on the off phase); a Coulomb
drift (+DRIFT_FRACTION over DRIFT_S) with online re-identification; the feed-forward off again
under the drifted friction (the reference of the drift's gain); a deliberately bad parameter set
offered to the safety gate (~/load). With --payload-kg M, instead of the drift: a payload of M kg
fixed to the arm's last link after the on phase, identified by the node (~/identify_payload) and
taken by the controller's rigid-body feed-forward (online re-identification off). Writes the
figures as JSON (--json) and one PNG of the tracking error per phase (--plots).

--hidden-friction lugre: the arm's hidden friction is a LuGre law; after the off phase the node
identifies a Stribeck law on it (phase feedforward_on), then a LuGre law on the same window (phase
feedforward_on_lugre, its states driven by the desired velocity); no drift, no online
re-identification. The JSON's lugre_vs_stribeck_at_reversals compares the two."""

NS = 1_000_000_000
# The node's wall-time limit of an identification in the loop (its answer comes by then, the job
# done or stopped); a client waits that long and ANSWER_MARGIN_S more for the answer to arrive.
NODE_MAX_WALL_S = 120.0
ANSWER_MARGIN_S = 30.0
ANSWER_TIMEOUT_S = NODE_MAX_WALL_S + ANSWER_MARGIN_S


def register(subparsers):
    """Add the ``loop`` sub-command to the core CLI; returns its handler."""
    p = subparsers.add_parser("loop", help="friction feed-forward in a simulated ROS 2 control loop: tracking "
                                           "gain, drift recovery, safety gate, latency", description=DESCRIPTION)
    add_arguments(p)
    return handler


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", default="tx40", help="tx40 | urdf:PATH (a fixed-base URDF; meshes are not needed)")
    p.add_argument("--json", required=True, type=Path, help="write the figures here")
    p.add_argument("--plots", type=Path, help="write loop_<phase>.png here")
    p.add_argument("--phase-s", type=float, default=12.0, help="length of the feed-forward off/on phases [s]")
    p.add_argument("--drift-s", type=float, default=60.0, help="the Coulomb drift ramps over this long [s]")
    p.add_argument("--drift-fraction", type=float, default=0.3, help="Coulomb level increase of the drift")
    p.add_argument("--after-s", type=float, default=20.0, help="observed after the drift [s]")
    p.add_argument("--online-period-s", type=float, default=3.0, help="online re-identification period [s]")
    p.add_argument("--online-window-s", type=float, default=8.0, help="online re-identification window [s]")
    p.add_argument("--velocity-source", choices=("reference", "measured"), default="reference",
                   help="the node's feed-forward velocity: the controller's desired velocity (default) or the "
                        "measured one (its sign chatters near zero speed)")
    p.add_argument("--no-drift", action="store_true", help="only the off and on phases (and the gate)")
    p.add_argument("--payload-kg", type=float, default=0.0, metavar="M",
                   help="attach a payload of M kg to the simulated arm's last link after the on phase; the node "
                        "identifies it and the controller takes it (implies --no-drift, online re-identification off)")
    p.add_argument("--payload-s", type=float, default=15.0,
                   help="the payload's phase before its identification [s]")
    p.add_argument("--hidden-friction", choices=("stribeck", "lugre"), default="stribeck",
                   help="the simulated arm's hidden friction (default stribeck); lugre: a Stribeck and a LuGre "
                        "feed-forward identified on the same off phase, one phase each (no drift)")
    p.add_argument("--realtime", default="auto", metavar="PRIO|auto|off",
                   help="run the three processes SCHED_FIFO at priority PRIO (1..99), as ros2_control runs its "
                        "control loop (the identification worker goes back to normal scheduling); auto "
                        f"(default): {AUTO_PRIORITY} if this user may (root, or an rtprio limit), else off")
    p.add_argument("--keep", action="store_true", help="keep the work folder (logs, record, parameters)")


def handler(args) -> int:
    """Run ``loop``; FrictionIdError propagates to the CLI (one line, exit code 2)."""
    args.realtime = realtime_priority(args.realtime)
    print("scheduling: " + (f"SCHED_FIFO {args.realtime}" if args.realtime else
                            "normal (no real-time priority: expect latency tails of several ms on a busy machine)"))
    for name in ("phase_s", "drift_s", "after_s", "online_period_s", "online_window_s", "payload_s"):
        if not getattr(args, name) > 0:
            raise FrictionIdError(f"--{name.replace('_', '-')} must be > 0")
    if args.payload_kg < 0 or args.payload_kg != args.payload_kg:
        raise FrictionIdError(f"--payload-kg must be > 0 (0: no payload), got {args.payload_kg}")
    if args.payload_kg > 0:
        args.no_drift = True
    t0 = time.monotonic()
    result, record, phases = run(args)
    write_json(args.json, result)
    from frictionid_core.loop import median_ratio, plot

    if args.plots:
        plot(record, phases, args.plots)
    r = result["rms_tracking_error"]
    print(f"RMS tracking error [mrad] off {[round(x * 1e3, 3) for x in r['feedforward_off']]}")
    print(f"                          on  {[round(x * 1e3, 3) for x in r['feedforward_on']]}")
    print(f"median RMS(on)/RMS(off) = {median_ratio(result):.3f}")
    if "lugre_vs_stribeck_at_reversals" in result:
        c = result["lugre_vs_stribeck_at_reversals"]
        print(f"RMS at reversals, LuGre / Stribeck feed-forward: median {c['median']:.3f}, per joint "
              f"{[None if x is None else round(x, 3) for x in c['per_joint']]}")
    if "drift" in result:
        print(f"drift: recovered fraction {result['drift']['recovered_fraction']:.3f}, "
              f"recovery {result['drift']['recovery_s']} s")
    if "payload" in result:
        p = result["payload"]
        print(f"payload: true {p['true_kg']:g} kg, identified {p['identified_kg']:.4g} kg; tracking RMS [mrad] before "
              f"{p['rms_before'] * 1e3:.3f}, attached {p['rms_attached'] * 1e3:.3f}, after the update "
              f"{p['rms_after'] * 1e3:.3f} ({p['rms_after'] / p['rms_before']:.3f} × before)")
    print(f"bad parameters rejected: {result['gate']['bad_parameters_rejected']}")
    lat = result.get("feedforward_latency_ms", {})
    print("feed-forward latency [ms]: " + ", ".join(f"{k} {v:.3f}" for k, v in lat.items()))
    import numpy as np

    hop = np.percentile(record["state_latency_ns"], [50, 99]) * 1e-6
    print(f"  of which joint_states stamp → controller receipt [ms]: p50 {hop[0]:.3f}, p99 {hop[1]:.3f}")
    print(f"wrote {args.json} in {time.monotonic() - t0:.0f} s")
    return 0


def ros_env(domain: int) -> dict:
    """The environment of a loop process: ``domain``, discovery on this host, these packages first."""
    import frictionid_core
    import frictionid_ros

    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    paths = [str(Path(m.__file__).resolve().parents[1]) for m in (frictionid_ros, frictionid_core)]
    env["PYTHONPATH"] = os.pathsep.join(paths + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    env.pop("_ROS_WHEELS_BOOTSTRAP_COMPLETE", None)  # let the child bootstrap its own library path
    return env


def node_parameters(robot: str, joints: list[str], work: Path, args) -> Path:
    """The frictionid node's parameters file of the loop."""
    system = robot if robot.startswith("urdf:") else "tx40"
    values = {"system": system, "joints": joints, "friction_model": "coulomb", "solver": "ls",
              "velocity_source": args.velocity_source, "smoothing_eps": 0.02, "known_rigid_body": True,
              "online_period_s": float(args.online_period_s) if gated(args) else 0.0,
              "online_window_s": float(args.online_window_s),
              "online_holdout": 0.25, "gate_max_abs": 1000.0, "feedforward_max": 100.0, "feedforward_ramp_s": 0.5,
              "results_file": str(work / "results" / "parameters.json"), "max_missing_pct": 20.0,
              # lugre: the off phase stays buffered for its second identification
              "buffer_seconds": 30.0 if args.hidden_friction == "stribeck" else 4.0 * args.phase_s + 30.0,
              "diagnostics_period_s": 0.5, "max_wall_s": NODE_MAX_WALL_S}
    path = work / "node.yaml"
    path.write_text("frictionid:\n  ros__parameters:\n" + "".join(
        f"    {k}: {json.dumps(v)}\n" for k, v in values.items()))
    return path


def _die_with_parent() -> None:
    """In a loop process before exec: SIGTERM when this process dies (Linux PR_SET_PDEATHSIG)."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)
    except Exception:  # not Linux: the processes are stopped by Processes.stop
        pass


class Processes:
    """The loop's processes, output in ``work``; stopped by SIGINT (their records are written then)."""

    def __init__(self, work: Path, domain: int, realtime: int = 0):
        self.work, self.env, self.procs = work, ros_env(domain), {}
        self.prefix = ["chrt", "--fifo", str(realtime)] if realtime > 0 else []

    def start(self, name: str, module: str, *args: str) -> None:
        with open(self.work / f"{name}.out", "w") as out, open(self.work / f"{name}.err", "w") as err:
            self.procs[name] = subprocess.Popen([*self.prefix, sys.executable, "-m", module, *args], env=self.env,
                                                stdout=out,
                                                stderr=err, cwd=self.work, preexec_fn=_die_with_parent)

    def check(self) -> None:
        for name, p in self.procs.items():
            if p.poll() is not None:
                tail = (self.work / f"{name}.err").read_text()[-2000:]
                raise FrictionIdError(f"loop process {name} exited with {p.returncode}: {tail}")

    def stop(self) -> None:
        for p in self.procs.values():
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in self.procs.values():
            try:
                p.wait(15.0)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(5.0)


class Client:
    """rclpy in this process on ``domain``: services, parameters, the gate's diagnostics."""

    def __init__(self, domain: int):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            import rclpy
            from diagnostic_msgs.msg import DiagnosticArray
            from rclpy.executors import SingleThreadedExecutor

        self.rclpy = rclpy
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("frictionid_loop_driver", context=self.ctx)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.gate: list[tuple[float, str, dict]] = []
        self.buffer: dict = {}
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, 10)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set() and self.ctx.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:  # shutting down
                return

    def _on_diag(self, arr) -> None:
        for s in arr.status:
            values = {kv.key: kv.value for kv in s.values}
            if s.name.endswith(": safety gate"):
                if not self.gate or self.gate[-1][2].get("reviews") != values.get("reviews"):
                    self.gate.append((time.time(), s.message, values))
            elif s.name.endswith(": joint buffer"):
                self.buffer = values

    def call(self, srv_type, name: str, request, timeout: float = 60.0):
        cli = self.node.create_client(srv_type, name)
        try:
            if not cli.wait_for_service(timeout_sec=timeout):
                raise FrictionIdError(f"service {name} did not appear within {timeout:g} s")
            future = cli.call_async(request)
            done = threading.Event()
            future.add_done_callback(lambda _: done.set())
            if not done.wait(timeout):
                raise FrictionIdError(f"service {name}: no answer within {timeout:g} s")
            return future.result()
        finally:
            self.node.destroy_client(cli)

    def wait_service(self, srv_type, name: str, procs: Processes, timeout: float = 60.0) -> None:
        """Wait until service ``name`` is offered; FrictionIdError as soon as a loop process dies."""
        cli = self.node.create_client(srv_type, name)
        deadline = time.monotonic() + timeout
        try:
            while not cli.wait_for_service(timeout_sec=0.2):
                procs.check()
                if time.monotonic() > deadline:
                    raise FrictionIdError(f"service {name} did not appear within {timeout:g} s")
        finally:
            self.node.destroy_client(cli)

    def set_parameter(self, node: str, name: str, value) -> None:
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        res = self.call(SetParameters, f"/{node}/set_parameters",
                        SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()]))
        if not res.results or not res.results[0].successful:
            raise FrictionIdError(f"{node}: cannot set {name} = {value!r}")

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        self.rclpy.try_shutdown(context=self.ctx)


def _wait(seconds: float, procs: Processes) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        procs.check()
        time.sleep(min(0.2, max(0.0, end - time.monotonic())))


def offer_bad_parameters(client: Client, results_file: Path, refused_by: str = "safety gate") -> bool:
    """Offer the active set with every Coulomb level negated and tripled to the gate (~/load; its
    safety screen without online re-identification); True if the node refused it (its message names
    ``refused_by``: the gate, or the safety screen when online re-identification is off) and did not
    activate it (the online re-identification may replace the active set meanwhile: that is no sign
    of the offer)."""
    from frictionid_interfaces.srv import ParametersFile

    data = json.loads(results_file.read_text())
    bad = json.loads(json.dumps(data))
    for p in bad["per_joint"].values():
        p["params"] = {k: -3.0 * v if k.startswith("Fc") else v for k, v in p["params"].items()}
    bad["params"] = {k: -3.0 * v if k.rsplit("/", 1)[-1].startswith("Fc") else v for k, v in bad["params"].items()}
    write_json(results_file.parent / "bad.json", bad)
    while True:  # the online re-identification may hold the slot for a moment (answered "busy" at once)
        res = client.call(ParametersFile, "/frictionid/load", ParametersFile.Request(path="bad.json"))
        if res.success or "busy" not in res.message:
            break
        time.sleep(0.2)
    params = lambda results: {joint: p["params"] for joint, p in results["per_joint"].items()}
    active = params(json.loads(results_file.read_text()))
    return (not res.success) and refused_by in res.message and active != params(bad)


def gated(args) -> bool:
    """Whether the loop runs the node's online re-identification (its safety gate answers ~/load):
    not with a payload or a hidden LuGre law, whose phases would be disturbed by it."""
    return args.payload_kg <= 0 and args.hidden_friction == "stribeck"


def payload_phases(client: Client, args, phase, phases: dict, procs: Processes) -> float:
    """Attach the payload to the simulated arm (phase ``payload_attached``), identify it on that
    phase (~/identify_payload, the first second left out), let the controller take it (phase
    ``payload_updated``); returns the identified mass [kg]."""
    from frictionid_interfaces.srv import IdentifyPayload

    from frictionid_ros.node import to_time

    client.set_parameter("frictionid_sim", "payload_kg", float(args.payload_kg))
    phase("payload_attached", args.payload_s)
    start, end = phases["payload_attached"]
    request = IdentifyPayload.Request(window_start=to_time(start + NS), window_end=to_time(end))
    res = client.call(IdentifyPayload, "/frictionid/identify_payload", request, timeout=ANSWER_TIMEOUT_S)
    if not res.success:
        raise FrictionIdError(f"identification of the payload failed: {res.message}")
    print(f"payload: {res.message}")
    _wait(1.0, procs)  # the controller takes ~/payload (transient local) at once; its switch settles
    phase("payload_updated", args.phase_s)
    return float(res.inertia.m)


def identify_off_phase(client: Client, friction: str = "", span: tuple[int, int] | None = None,
                       seconds: float = 0.0) -> None:
    """~/identify the off phase with the law ``friction`` (by lm; empty: the node's law and solver),
    activating the result: its last ``seconds``, or the stamps ``span`` [ns] less their first second when the
    off phase lies in the past; FrictionIdError when it fails."""
    from builtin_interfaces.msg import Time
    from frictionid_interfaces.srv import Identify

    request = Identify.Request(friction_model=friction, solver="lm" if friction else "", window_seconds=seconds)
    if span is not None:
        start, end = span[0] + NS, span[1]
        request.window_start, request.window_end = (Time(sec=x // NS, nanosec=x % NS) for x in (start, end))
    while True:  # the online re-identification may hold the slot for a moment
        res = client.call(Identify, "/frictionid/identify", request, timeout=ANSWER_TIMEOUT_S)
        if res.success or not res.message.startswith("busy"):
            break
        time.sleep(0.2)
    if not res.success:
        raise FrictionIdError(f"identification of the off phase failed: {res.message}")

def run(args) -> tuple[dict, dict, dict]:
    """The loop's phases → (the JSON figures, the controller's record, the phases' stamps)."""
    import numpy as np
    from frictionid_interfaces.srv import Identify

    from frictionid_core.loop import load_robot, summarize

    robot = load_robot(args.robot)
    work = Path(tempfile.mkdtemp(prefix="frictionid-loop-"))
    (work / "results").mkdir()
    lease = reserve_domain()  # held until the processes are stopped
    domain = lease.id
    record_file = work / "record.npz"
    procs = Processes(work, domain, args.realtime)
    client = None
    phases: dict[str, tuple[int, int]] = {}
    try:
        procs.start("node", "frictionid_ros.node", "--params-file", str(node_parameters(args.robot, robot.joints,
                                                                                          work, args)))
        procs.start("controller", "frictionid_ros.loop.controller_node", "--ros-args", "-p", f"robot:={args.robot}",
                    "-p", f"record_file:={record_file}")
        procs.start("sim", "frictionid_ros.loop.sim_node", "--ros-args", "-p", f"robot:={args.robot}",
                    "-p", f"drift_s:={args.drift_s}", "-p", f"drift_fraction:={args.drift_fraction}",
                    "-p", f"hidden_friction:={args.hidden_friction}")
        client = Client(domain)
        from rcl_interfaces.srv import SetParameters

        for name, srv_type in (("/frictionid/identify", Identify), ("/frictionid_loop_controller/set_parameters",
                               SetParameters), ("/frictionid_sim/set_parameters", SetParameters)):
            client.wait_service(srv_type, name, procs)
        deadline = time.monotonic() + 60.0
        while float(client.buffer.get("rate_hz", 0.0)) < 500.0:
            procs.check()
            if time.monotonic() > deadline:
                raise FrictionIdError("the frictionid node receives no joint states from the simulated arm")
            time.sleep(0.2)
        _wait(2.0, procs)  # the start transient

        def phase(name: str, seconds: float) -> None:
            start = time.time_ns()
            _wait(seconds, procs)
            phases[name] = (start, time.time_ns())

        phase("feedforward_off", args.phase_s)
        lugre = args.hidden_friction == "lugre"
        identify_off_phase(client, "stribeck" if lugre else "", seconds=args.phase_s - 1.0)
        client.set_parameter("frictionid_loop_controller", "feedforward_enabled", True)
        phase("feedforward_on", args.phase_s)
        if lugre:
            identify_off_phase(client, "lugre", span=phases["feedforward_off"])
            phase("feedforward_on_lugre", args.phase_s)
        if not args.no_drift and not lugre:
            client.set_parameter("frictionid_sim", "drift_start", True)
            phase("drift", args.drift_s)
            phase("after_drift", args.after_s)
            client.set_parameter("frictionid_loop_controller", "feedforward_enabled", False)
            phase("drift_off", args.phase_s)
        identified_kg = None
        if args.payload_kg > 0:
            identified_kg = payload_phases(client, args, phase, phases, procs)
        rejected = offer_bad_parameters(client, work / "results" / "parameters.json",
                                        "safety gate" if gated(args) else "refused by the safety screen")
    finally:
        if client is not None:
            client.close()
        procs.stop()
        lease.release()
    if not record_file.exists():
        raise FrictionIdError(f"the controller wrote no record (see {work}/controller.err)")
    with np.load(record_file) as z:
        record = {k: z[k] for k in z.files}
    figures = summarize(record, phases, after_s=args.after_s)
    result = {k: figures[k] for k in ("rms_tracking_error", "drift") if k in figures}
    if "feedforward_on_lugre" in phases:
        at = figures["rms_at_reversals"]
        ratio = [None if a is None or b is None or b <= 0 else a / b
                 for a, b in zip(at["feedforward_on_lugre"], at["feedforward_on"])]
        known = [r for r in ratio if r is not None]
        result["lugre_vs_stribeck_at_reversals"] = {"per_joint": ratio,
                                                    "median": float(np.median(known)) if known else None}
    result["gate"] = {"bad_parameters_rejected": bool(rejected)}
    if args.payload_kg > 0:
        from frictionid_core.loop import payload_figures

        result["payload"] = payload_figures(record, phases, args.payload_kg, identified_kg)
    result.update({k: v for k, v in figures.items() if k not in result})
    if not args.keep:
        import shutil

        shutil.rmtree(work, ignore_errors=True)
    else:
        print(f"work folder: {work}")
    return result, record, phases


def main(argv: list[str] | None = None) -> int:
    """``frictionid_loop``: the same command without the core CLI."""
    from frictionid_core.cli import run_handler

    parser = argparse.ArgumentParser(prog="frictionid_loop", description=DESCRIPTION)
    add_arguments(parser)
    return run_handler(handler, parser.parse_args(argv))

