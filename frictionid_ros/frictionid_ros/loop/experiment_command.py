"""``frictionid experiment``: the node's ``~/run_experiment`` end to end against the simulated arm, as
separate ROS 2 processes (docs/experiment.md).

Registered in the core CLI through the entry-point group ``frictionid.commands``. Two processes on a
ROS domain of their own: ``frictionid_sim`` as a position-controlled robot (its servo follows
JointTrajectory commands as a JointTrajectoryController would, :class:`frictionid_core.loop.TrajectoryFollower`;
hidden Stribeck friction; sensor noise on what it publishes) and ``frictionid_node`` (system ``tx40`` or
``urdf:PATH``). This process sends one goal — design the excitation within the arm's limits, approach,
excite, record, identify, validate, judge — injects a ``--fault`` during the excitation, then measures
what happened from the arm's own record: how fast it stood still after an abort, whether anything was
applied, whether the node still answers ``~/identify``, the identification against the arm's hidden
friction and rotor inertias, and the bag identified again offline by ``frictionid identify BAG
--request RESULT.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from frictionid_core import FrictionIdError, write_json
from frictionid_core.loop import SERVO_BANDWIDTH_HZ
from frictionid_ros.experiment import DEFAULT_RATES
from frictionid_ros.loop.loop_command import ANSWER_MARGIN_S, Client, Processes
from frictionid_ros.runtime import AUTO_PRIORITY, realtime_priority, reserve_domain

DESCRIPTION = """\
Run the frictionid node's ~/run_experiment against the simulated arm of 'frictionid loop' as separate
ROS 2 processes: the node designs an excitation within the arm's limits, moves it slowly to the
start pose, plays the excitation through the arm's trajectory controller while recording the joint
states into an MCAP bag, identifies on the first part, validates on the rest and applies the result
only if the validation passes. --fault injects, during the excitation, a blocked joint (tracking), an
effort spike (effort) or a stalled joint-state stream (silence): the experiment must abort, the arm
hold still, nothing be applied. Writes the figures as JSON (--json); the experiment's files (the
excitation, the bag, the result) stay in --out."""

NS = 1_000_000_000
STILL_SPEED = 0.01  # the arm stands still when every joint is slower than this [rad/s | m/s]
FAULT_AT = 0.4  # the fault is injected at this share of the excitation
AFTER_WINDOW_S = 30.0  # ~/identify afterwards: a dry run on the last 30 s (the excitation, or what came of it)
NODE_MAX_WALL_S = 300.0  # the node's wall-time limit of an identification; its answer comes by then
EFFORT_NOISE = 0.05  # [N·m]: the TX40's published torque noise (docs/reference.md#tx40), every robot
POSITION_NOISE = 1e-6  # [rad]: an absolute encoder's noise (the TX40's: 1.0-3.0e-6 rad)
MIN_SPEED = 0.2  # [rad/s]: 4 × the largest Stribeck speed of the hidden friction (docs/experiment.md#sim)
CUTOFF_HZ = 30.0  # [Hz]: above the servo's bandwidth (docs/experiment.md#sim)
REVERSAL_PERIODS = 1.0  # rows within one cut-off period of a reversal left out (docs/experiment.md#sim)


def register(subparsers):
    """Add the ``experiment`` sub-command to the core CLI; returns its handler."""
    p = subparsers.add_parser("experiment", help="the node's ~/run_experiment end to end against the simulated arm "
                                                 "(ROS 2 processes): excite, record, identify, validate, judge",
                              description=DESCRIPTION)
    add_arguments(p)
    return handler


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", default="tx40", help="tx40 | urdf:PATH (a fixed-base URDF; meshes are not needed)")
    p.add_argument("--json", required=True, type=Path, help="write the figures here")
    p.add_argument("--out", type=Path, help="the node's results folder, where the experiment's excitation, bag and "
                                            "result stay (default: <json name>_files beside the JSON)")
    p.add_argument("--fault", choices=("tracking", "effort", "silence"),
                   help="during the excitation: block a joint, spike its effort, or stall the joint states")
    p.add_argument("--fault-joint", type=int, default=1, help="the joint of the fault, 0-based (default 1)")
    p.add_argument("--interface", choices=("trajectory", "position"), default="trajectory",
                   help="how the node commands the arm: one JointTrajectory (default) or streamed positions")
    p.add_argument("--duration", type=float, default=20.0, help="the excitation's length [s] (default 20)")
    p.add_argument("--evals", type=int, default=1500, help="the excitation design's evaluations (default 1500)")
    p.add_argument("--seed", type=int, default=0, help="the excitation design's seed (default 0)")
    p.add_argument("--friction", default="coulomb", help="the friction law identified (default coulomb)")
    p.add_argument("--solver", default="ls", help="the solver (default ls)")
    p.add_argument("--cutoff", type=float, default=CUTOFF_HZ, metavar="HZ",
                   help=f"filter cut-off of every joint [Hz] (default {CUTOFF_HZ:g}: above the arm's servo bandwidth, "
                        f"{SERVO_BANDWIDTH_HZ:g} Hz, whose response to each friction step is motion; 0: chosen from "
                        "the data)")
    p.add_argument("--reversal-periods", type=float, default=REVERSAL_PERIODS, metavar="P",
                   help=f"rows within P cut-off periods of a reversal left out (default {REVERSAL_PERIODS:g}: the "
                        "servo's response to each friction step spreads over about that; 0: the rule's, none with a "
                        "given --min-speed)")
    p.add_argument("--min-speed", type=float, default=MIN_SPEED, metavar="V",
                   help=f"rows slower than V [rad/s] left out (default {MIN_SPEED:g}: the arm's hidden Stribeck "
                        "friction, vs <= 0.05 rad/s, which the Coulomb law does not model; 0: chosen from the data)")
    p.add_argument("--max-tracking-error", type=float, default=0.05, metavar="RAD",
                   help="abort when a joint is further than this from its commanded position (default 0.05)")
    p.add_argument("--validation-share", type=float, default=0.3, help="share held back for validation (0.3)")
    p.add_argument("--max-floor-ratio", type=float, default=1.5,
                   help="accepted when the validation error is at most this × its noise floor (default 1.5)")
    p.add_argument("--effort-noise", type=float, default=EFFORT_NOISE, help="the arm's effort noise [N·m] (0.05)")
    p.add_argument("--position-noise", type=float, default=POSITION_NOISE, help="its position noise [rad] (1e-6)")
    p.add_argument("--realtime", default="auto", metavar="PRIO|auto|off",
                   help="run the processes SCHED_FIFO at priority PRIO (1..99); auto (default): "
                        f"{AUTO_PRIORITY} if this user may, else off")
    p.add_argument("--keep", action="store_true", help="keep the processes' logs (in --out)")


def handler(args) -> int:
    """Run ``experiment``; FrictionIdError propagates to the CLI (one line, exit code 2)."""
    args.realtime = realtime_priority(args.realtime)
    for name in ("duration", "validation_share", "max_floor_ratio", "max_tracking_error"):
        if not getattr(args, name) > 0:
            raise FrictionIdError(f"--{name.replace('_', '-')} must be > 0")
    if not (args.effort_noise >= 0 and args.position_noise >= 0):
        raise FrictionIdError("--effort-noise and --position-noise must be >= 0")
    t0 = time.monotonic()
    result = run(args)
    result["wall_s"]["command"] = time.monotonic() - t0
    write_json(args.json, result)
    v = result["validation"]
    print(f"excitation: cond {result['excitation'].get('cond', float('nan')):.4g}, max ratio "
          + ", ".join(f"{k} {x:.3g}" for k, x in result["excitation"].get("max_ratio", {}).items()))
    if result["aborted"]:
        print(f"aborted ({result['abort_reason']}): {result['abort_text']}")
        print(f"  the arm stood still {result['held_still_s']} s after the abort; applied: {result['applied']}; "
              f"parameters file untouched: {result['nothing_applied']}")
    else:
        print(f"validation {v['relerr_pct']:.4g} % = {v['ratio']:.3g} × its noise floor {v['noise_floor_pct']:.4g} %; "
              f"accepted {result['accepted']}, applied {result['applied']}")
        t = result["truth_error_pct"]
        print(f"against the arm's hidden truth: max |error| Fv {t['max_abs_Fv_pct']:.3g} %, Fc "
              f"{t['max_abs_Fc_pct']:.3g} %, Ia {t['max_abs_Ia_pct']}")
        off = result["offline_reidentification"]
        print(f"offline 'frictionid identify BAG --request RESULT': max relative difference {off['max_rel_diff']:.3g}")
    print(f"~/identify afterwards: {result['identify_after']['success']} ({result['identify_after']['message'][:80]})")
    print(f"wrote {args.json} in {result['wall_s']['command']:.0f} s")
    return 0


def node_parameters(robot_spec: str, joints: list[str], out: Path) -> Path:
    """The node's parameters file."""
    system = robot_spec if robot_spec.startswith("urdf:") else "tx40"
    values = {"system": system, "joints": joints, "friction_model": "coulomb", "solver": "ls",
              "results_file": str(out / "parameters.json"), "buffer_seconds": 40.0, "max_wall_s": NODE_MAX_WALL_S,
              "max_missing_pct": 20.0, "unique_name": False, "diagnostics_period_s": 1.0}
    path = out / "node.yaml"
    path.write_text("frictionid:\n  ros__parameters:\n" + "".join(
        f"    {k}: {json.dumps(v)}\n" for k, v in values.items()))
    return path


def goal_of(args):
    from frictionid_interfaces.action import RunExperiment

    return RunExperiment.Goal(duration_s=float(args.duration), evals=int(args.evals), seed=int(args.seed),
                              command_interface=args.interface, friction_model=args.friction, solver=args.solver,
                              cutoff_hz=float(args.cutoff), reversal_periods=float(args.reversal_periods),
                              min_speed=float(args.min_speed), max_tracking_error=float(args.max_tracking_error),
                              validation_share=float(args.validation_share),
                              max_floor_ratio=float(args.max_floor_ratio))


def send_goal(client: Client, goal, fault, procs: Processes, timeout: float = 900.0):
    """Send ``goal`` to ``~/run_experiment``; ``fault(feedback)`` is called with every feedback. Returns
    the result message."""
    from frictionid_interfaces.action import RunExperiment

    from frictionid_ros.runtime.action_client import ActionClient

    action = ActionClient(client.node, RunExperiment, "/frictionid/run_experiment")
    deadline = time.monotonic() + 120.0
    while not action.wait_for_server(timeout_sec=0.5):
        procs.check()
        if time.monotonic() > deadline:
            raise FrictionIdError("the node's ~/run_experiment did not appear within 120 s")
    phase = [""]

    def on_feedback(msg):
        fb = msg.feedback
        if fb.phase != phase[0]:
            phase[0] = fb.phase
            print(f"  {fb.elapsed_s:6.1f} s  {fb.phase}", flush=True)
        fault(fb)

    done = threading.Event()
    box = {}
    future = action.send_goal_async(goal, feedback_callback=on_feedback)
    future.add_done_callback(lambda f: (box.__setitem__("handle", f.result()), done.set()))
    if not done.wait(60.0):
        raise FrictionIdError("~/run_experiment: the goal was not answered within 60 s")
    handle = box["handle"]
    if not handle.accepted:
        raise FrictionIdError("~/run_experiment refused the goal")
    done.clear()
    result_future = handle.get_result_async()
    result_future.add_done_callback(lambda _: done.set())
    end = time.monotonic() + timeout
    while not done.wait(0.5):
        procs.check()
        if time.monotonic() > end:
            raise FrictionIdError(f"~/run_experiment: no result within {timeout:g} s")
    return result_future.result().result


def held_still_s(record: dict, since_ns: int) -> float | None:
    """Seconds from ``since_ns`` until the arm stood still for good (every joint slower than
    STILL_SPEED from then to the end of the record); None when it never did."""
    stamps, qd = record["stamp_ns"], np.abs(record["qd"])
    after = stamps >= since_ns
    if not after.any():
        return None
    moving = np.flatnonzero(after & (qd.max(axis=1) >= STILL_SPEED))
    if moving.size == 0:
        return 0.0
    last = int(moving[-1])
    if last + 1 >= len(stamps):
        return None
    return (int(stamps[last + 1]) - since_ns) / NS


def hold_figures(record: dict, report: dict) -> dict:
    """How the arm came to rest after an abort: the node's reaction (abort seen → hold sent, its clock),
    the arm's stop (hold taken → every joint slower than STILL_SPEED for good, the arm's clock: a stalled
    simulation's clock lags the wall clock), their sum ``held_still_s`` (a stream's hold, which the arm
    cannot tell from another command: the node's ``stopped_after_s``, abort seen → a joint state at rest
    received); and from the fault's start to rest on the arm's clock."""
    holds = [int(x) for x in np.atleast_1d(record.get("hold_ns", []))]
    reaction = (report["hold_sent_ns"] - report["detected_ns"]) / NS if report.get("hold_sent_ns") else None
    stop = held_still_s(record, holds[0]) if holds else None
    fault_ns = int(record.get("fault_ns", 0))
    # a stream's hold is its last command again, which the arm cannot tell from another: the node's view then
    held = reaction + stop if reaction is not None and stop is not None else report.get("stopped_after_s")
    return {"reaction_s": reaction, "arm_stop_s": stop, "held_still_s": held,
            "fault_to_still_s": held_still_s(record, fault_ns) if fault_ns else None,
            "node_saw_rest_after_s": report.get("stopped_after_s"), "abort_text": report.get("abort_text")}


def relative_difference(a: dict, b: dict) -> float:
    """The largest |a − b| / max(|b|, 1e-12) over the parameters of ``b`` (inf when ``a`` lacks one)."""
    worst = 0.0
    for k, vb in b.items():
        if k not in a:
            return float("inf")
        worst = max(worst, abs(a[k] - vb) / max(abs(vb), 1e-12))
    return worst


def offline(bag: str, result_file: str, out: Path) -> dict:
    """``frictionid identify BAG --request RESULT --json OUT``: the same parameters?"""
    exe = Path(sys.executable).with_name("frictionid")
    cmd = ([str(exe)] if exe.exists() else [sys.executable, "-c", "import sys; from frictionid_core.cli import main; "
                                                                  "sys.exit(main())"])
    target = out / "offline_result.json"
    cmd += ["identify", bag, "--request", result_file, "--json", str(target)]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    entry = {"command": " ".join(["frictionid", *cmd[-6:]]), "exit_code": proc.returncode,
             "wall_s": time.monotonic() - t0}
    if proc.returncode != 0:
        entry.update(error=proc.stderr.strip()[-500:], max_rel_diff=float("inf"))
        return entry
    mine = json.loads(Path(result_file).read_text())["params"]
    again = json.loads(target.read_text())["params"]
    entry.update(result=str(target), max_rel_diff=relative_difference(again, mine))
    return entry


def run(args) -> dict:
    """The experiment → the JSON figures."""
    from frictionid_interfaces.srv import Identify

    from frictionid_core.loop import default_trajectory, hidden_friction, load_robot, truth_errors

    robot = load_robot(args.robot)
    joints = list(robot.joints)
    out = (args.out or args.json.with_name(args.json.stem + "_files")).resolve()
    out.mkdir(parents=True, exist_ok=True)
    if any(out.iterdir()):
        raise FrictionIdError(f"{out}: not empty; give --out an empty or new folder")
    lease = reserve_domain()
    record_file = out / "sim_record.npz"
    procs = Processes(out, lease.id, args.realtime)
    client = None
    q0 = default_trajectory(robot).q0
    fault_state = {"sent": None}
    t0 = time.monotonic()
    try:
        procs.start("node", "frictionid_ros.node", "--params-file", str(node_parameters(args.robot, joints, out)))
        procs.start("sim", "frictionid_ros.loop.sim_node", "--ros-args", "-p", f"robot:={args.robot}",
                    "-p", "command_interface:=position", "-p", f"q0:={[float(x) for x in q0]}",
                    "-p", f"position_noise:={float(args.position_noise)}",
                    "-p", f"effort_noise:={float(args.effort_noise)}", "-p", f"fault_joint:={int(args.fault_joint)}",
                    "-p", f"stream_rate_hz:={DEFAULT_RATES['position']}",
                    "-p", f"record_file:={record_file}")
        client = Client(lease.id)
        client.wait_service(Identify, "/frictionid/identify", procs)
        deadline = time.monotonic() + 60.0
        while float(client.buffer.get("rate_hz", 0.0)) < 500.0:
            procs.check()
            if time.monotonic() > deadline:
                raise FrictionIdError("the frictionid node receives no joint states from the simulated arm")
            time.sleep(0.2)

        def fault(fb) -> None:
            if args.fault and fault_state["sent"] is None and fb.phase == "excitation" and fb.progress >= FAULT_AT:
                fault_state["sent"] = time.time_ns()
                threading.Thread(target=client.set_parameter, args=("frictionid_sim", "fault", args.fault),
                                 daemon=True).start()

        t_ready = time.monotonic()
        res = send_goal(client, goal_of(args), fault, procs)
        t_goal = time.monotonic() - t_ready
        time.sleep(1.0)  # the arm's record covers a second after the answer
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            after = client.call(Identify, "/frictionid/identify",
                                Identify.Request(window_seconds=AFTER_WINDOW_S, dry_run=True),
                                timeout=NODE_MAX_WALL_S + ANSWER_MARGIN_S)
    finally:
        if client is not None:
            client.close()
        procs.stop()
        lease.release()
    report = json.loads(res.json) if res.json else {}
    with np.load(record_file) as z:
        record = {k: z[k] for k in z.files}
    result = {"robot": args.robot, "fault": args.fault, "interface": args.interface,
              "excitation": report.get("excitation", {}), "excitation_file": report.get("excitation_file"),
              "bag": res.bag or None, "result": res.result_file or None,
              "experiment": str(Path(report["folder"]) / "experiment.json") if "folder" in report else None,
              "accepted": bool(res.accepted), "applied": bool(res.applied), "aborted": bool(res.aborted),
              "abort_reason": res.abort_reason or None, "abort_text": report.get("abort_text"),
              "message": res.message, "reason": res.reason or None}
    v = {"relerr_pct": res.validation_relerr_pct, "noise_floor_pct": res.validation_noise_floor_pct}
    v["ratio"] = v["relerr_pct"] / v["noise_floor_pct"] if v["noise_floor_pct"] > 0 else float("nan")
    result["validation"] = v
    params_file = out / "parameters.json"
    result["nothing_applied"] = not res.applied and not params_file.exists()
    if res.aborted:
        result["hold"] = hold_figures(record, report)
        result["held_still_s"] = result["hold"]["held_still_s"]
        result["fault_sent_ns"] = fault_state["sent"]
    if res.result_file:
        params = json.loads(Path(res.result_file).read_text())["params"]
        result["truth_error_pct"] = truth_errors(params, joints, hidden_friction(args.robot, joints),
                                                 np.asarray(robot.model.armature, float)[: robot.nv])
        result["offline_reidentification"] = offline(res.bag, res.result_file, out)
    result["identify_after"] = {"success": bool(after.success), "message": after.message}
    result["monitor"] = report.get("monitor")
    result["wall_s"] = {"setup": t_ready - t0, "goal": t_goal, **{f"node_{k}": x for k, x in
                                                                   report.get("wall_s", {}).items()}}
    return result
