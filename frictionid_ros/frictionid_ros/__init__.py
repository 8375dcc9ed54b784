"""ROS 2 wrapper of frictionid_core: the ``frictionid`` node and the closed-loop demo.

Subpackages, one concern each (their ``__init__`` is the face other subpackages import from):

* :mod:`.node` — the node on ROS 2: :mod:`.node.frictionid_node` (``frictionid_node``, ``python -m
  frictionid_ros.node``), its actions and messages;
* :mod:`.inputs` — the input path without ROS: ring buffers, input callbacks, feed-forward;
* :mod:`.identification` — identification on request without ROS: requests, windows, the
  ``~/identify`` and ``~/identify_payload`` services, online re-identification;
* :mod:`.store` — the active parameters, the results file and the safety screen (no ROS import);
* :mod:`.worker` — the identification worker process and the control of one identification (no ROS import);
* :mod:`.runtime` — what a process runs on: rclpy executors and shutdown (:mod:`.runtime.runner`),
  real-time scheduling, a ROS domain of its own;
* :mod:`.loop` — the closed-loop demo ``frictionid loop``: simulated arm, controller and their driver.

Two modules stand alone: :mod:`.parameters` (every node parameter, declared once; no ROS import
when loaded) and :mod:`.replay` (``frictionid replay``).
"""
