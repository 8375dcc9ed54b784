"""The node's process: command line, executors and their threads, signals, orderly shutdown."""

from __future__ import annotations

import argparse
import gc
import sys
import threading
import time
import warnings
from pathlib import Path

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor

from frictionid_core import FrictionIdError
from frictionid_ros.runtime.ros_domain import check_domain_id

GIL_SWITCH_INTERVAL = 0.0005  # [s]
SERVICE_THREADS = 9  # identify (service and action), cancel, reset, save, load, online, lifecycle, diagnostics,
# run_experiment (its goal waits for the whole experiment)
NAME_CHECK_S = 4.0  # how long a starting node looks for another node of its name on the graph [s]: longer
# than one discovery announcement period (3 s in Fast DDS), as a first exchange can be missed


def parse_argv(argv: list[str]) -> tuple[list[str], bool]:
    """(rclpy arguments, lifecycle): ``--params-file`` outside ``--ros-args`` turned into a ROS
    argument, ``--lifecycle`` taken out."""
    from rclpy.utilities import remove_ros_args

    parser = argparse.ArgumentParser(prog="frictionid_node", description="Joint friction identification node.")
    parser.add_argument("--params-file", action="append", default=[], type=Path,
                        help="YAML parameters (frictionid: ros__parameters: ...); same as --ros-args --params-file")
    parser.add_argument("--lifecycle", action="store_true",
                        help="a managed node: starts unconfigured, driven by ~/change_state (configure, activate, "
                             "deactivate, cleanup, shutdown); without it the node configures and activates itself")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    extra = []
    for f in opts.params_file:
        if not f.is_file():
            raise FrictionIdError(f"{f}: no such parameters file")
        extra += ["--params-file", str(f.absolute())]
    rest = [a for a in argv[1:] if a != "--lifecycle"]
    # ours first: explicit --ros-args -p/--params-file given later take precedence
    return argv[:1] + (["--ros-args", *extra, "--"] if extra else []) + rest, opts.lifecycle


def check_unique_name(node, seconds: float = NAME_CHECK_S) -> None:
    """FrictionIdError (one line) when another node of ``node``'s name and namespace is on the ROS
    graph: looked for during ``seconds`` (discovery of the others takes a moment; found earlier,
    the answer comes at once). Two nodes started at the same moment may both refuse."""
    me = (node.get_name(), node.get_namespace())
    deadline = time.monotonic() + seconds
    while True:
        if sum(1 for entry in node.get_node_names_and_namespaces() if tuple(entry) == me) > 1:
            domain = node.context.get_domain_id()
            raise FrictionIdError(f"another node named {node.get_fully_qualified_name()} is running on ROS domain "
                                  f"{domain}; not starting a second one (set the parameter unique_name to false to "
                                  "allow it)")
        if time.monotonic() >= deadline:
            return
        time.sleep(0.1)


def make_input_executor(kind: str, log, context=None):
    """The executor of the input node: rclpy's EventsExecutor (C++ event queue: about half the CPU
    per message and a shorter latency tail than the SingleThreadedExecutor, measured in
    bench/ros_load.py) or the SingleThreadedExecutor (the fallback if rclpy lacks the former)."""
    if kind == "events":
        try:
            from rclpy.experimental import EventsExecutor

            return EventsExecutor(context=context)
        except Exception as exc:  # older rclpy: no EventsExecutor
            log.warning(f"EventsExecutor unavailable ({type(exc).__name__}: {exc}); using SingleThreadedExecutor")
    return SingleThreadedExecutor(context=context)


def make_input_node(node, cfg, executor, callbacks: dict):
    """(the hidden helper node ``_<name>_input`` that takes ``node``'s inputs, {input: resolved topic}):
    subscriptions to the joint states, the effort topic and the reference topic of ``cfg`` (those it
    names) and the feed-forward timer, each calling ``callbacks[input](message, receipt time [ns,
    system clock])`` (``callbacks["feedforward"]()`` for the timer); ``executor`` spins it."""
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    inp = Node(f"_{node.get_name()}_input", namespace=node.get_namespace(), context=node.context,
               use_global_arguments=False, start_parameter_services=False)
    reliability = ReliabilityPolicy.BEST_EFFORT if cfg.qos == "sensor_data" else ReliabilityPolicy.RELIABLE
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=cfg.qos_depth, durability=DurabilityPolicy.VOLATILE,
                     reliability=reliability)
    # The SingleThreadedExecutor passes MessageInfo (middleware receipt time); the EventsExecutor
    # passes the message only: receipt = callback entry then.
    events = not isinstance(executor, SingleThreadedExecutor)
    inputs = [("joint_states", JointState, cfg.joint_states_topic)]
    if cfg.effort_topic:
        inputs.append(("effort", JointState if cfg.effort_topic_type == "joint_state" else Float64MultiArray,
                       cfg.effort_topic))
    if cfg.velocity_source == "reference":
        inputs.append(("reference", JointState, cfg.reference_topic))
    topics = {}
    for name, typ, topic in inputs:
        topics[name] = node.resolve_topic_name(topic)
        callback = callbacks[name]
        inp.create_subscription(typ, topics[name], (lambda m, f=callback: f(m, time.time_ns())) if events
                                else (lambda m, info, f=callback: f(m, info["received_timestamp"])), qos)
    if cfg.feedforward_rate_hz > 0.0:
        inp.create_timer(1.0 / cfg.feedforward_rate_hz, callbacks["feedforward"])
    return inp, topics


def spin(executor, node) -> None:
    """Spin until shutdown. SIGINT/SIGTERM shut the context down, and an executor caught between
    two waits then raises RCLError ("context is not valid"): that is a normal end too."""
    context = node.context
    while context.ok():
        try:
            executor.spin_once(timeout_sec=0.1)
        except (KeyboardInterrupt, ExternalShutdownException):
            return
        except Exception as exc:
            if not context.ok():
                return
            node.get_logger().error(f"executor: {type(exc).__name__}: {exc}")


def run(node_class, argv: list[str] | None = None) -> int:
    """Run ``node_class(lifecycle=...)`` until SIGINT/SIGTERM; exit code 0, or 2 with one line for a
    bad configuration. The node's ``input_executor`` spins in a thread of its own, the node in a
    MultiThreadedExecutor."""
    argv = list(sys.argv if argv is None else argv)
    try:
        ros_argv, lifecycle = parse_argv(argv)
        check_domain_id()
        rclpy.init(args=ros_argv)
    except FrictionIdError as exc:  # a missing --params-file, a domain Fast DDS cannot open
        print(f"frictionid_node: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # e.g. an unreadable --params-file given after --ros-args
        print(f"frictionid_node: error: cannot initialise ROS: {exc}", file=sys.stderr)
        return 2
    # A thread waiting for the GIL gets it after at most this long (default 5 ms): bounds how
    # long the services/diagnostics threads can delay the 1 kHz input callback.
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)

    def executors(node):
        services = MultiThreadedExecutor(num_threads=SERVICE_THREADS)
        services.add_node(node)
        return node.input_executor, services

    return serve(lambda: node_class(lifecycle=lifecycle), executors, "frictionid_node",
                 lambda node: node.schedule_input_thread())


def serve(make_node, make_executors, prog: str, input_setup=None) -> int:
    """Spin the node ``make_node()`` until SIGINT/SIGTERM: ``make_executors(node)`` gives (the input
    executor, spun in a thread of its own; the main one, spun here), both with their nodes added.
    Then ``node.close()``, the executors shut down, the node destroyed; exit code 0 (also when a
    signal stopped it while it started), or 2 with one line for a FrictionIdError (a bad
    configuration). ``input_setup(node)``, if given, runs first in the input thread (the node's
    real-time scheduling: :mod:`.realtime`)."""
    node, executors, input_thread = None, [], None
    try:
        node = make_node()
        # The start-up objects (modules, the node: ~90k) are never scanned again by the garbage
        # collector: a full collection then takes ~0.1 ms instead of ~90 ms, a stall of the 1 kHz
        # input thread that bench/ros_load.py showed as ~100 ms feed-forward latency bursts.
        gc.freeze()
        if not rclpy.ok():  # a signal shut ROS down while the node started: a stop, before any executor
            return 0
        executors = list(make_executors(node))

        def spin_input(executor, node):
            if input_setup is not None:
                input_setup(node)
            spin(executor, node)

        input_thread = threading.Thread(target=spin_input, args=(executors[0], node), name=f"{prog}-input",
                                        daemon=True)
        input_thread.start()
        spin(executors[1], node)
    except FrictionIdError as exc:
        if not rclpy.ok():  # SIGINT/SIGTERM while it started (ROS shut down under it): a stop, not an error
            return 0
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if not rclpy.ok():  # a signal shut ROS down while it started: rclpy's objects fail to build, a stop
            return 0
        raise
    finally:
        if node is not None:
            node.close()
        for ex in executors:
            ex.shutdown(timeout_sec=1.0)
        if input_thread is not None:
            input_thread.join(timeout=2.0)  # never destroy a node under a spinning executor
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
