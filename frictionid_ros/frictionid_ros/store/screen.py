"""The node's safety screen of every parameter set that would become active, and the feed-forward's
clamp (no ROS import): :class:`Screen`, over :func:`frictionid_core.safety.screen_parameters`."""

from __future__ import annotations

import math

import numpy as np

from frictionid_core import FrictionIdError
from frictionid_core.safety import (
    Limit,
    effort_sign_refusals,
    explicit_bounds,
    payload_refusals,
    robot_limits,
    screen_parameters,
)
from frictionid_ros.parameters import PARAMETERS
from frictionid_ros.store.results import JointParams, Results, shared_parameters


class Screen:
    """The node's safety screen and the feed-forward's clamp.

    A set identified with an effort's sign other than the node's drive gives it is refused
    (:func:`frictionid_core.safety.effort_sign_refusals`). Every parameter set that would become active passes
    :func:`frictionid_core.safety.screen_parameters`
    with ``max_abs`` (gate_max_abs) against a limit per joint: the robot model's (``system``, a robot
    system: :func:`frictionid_core.safety.robot_limits`), else the one recorded with the parameters (the
    data they were identified on), else ``feedforward_max``. The feed-forward of a joint is clamped
    to ±min(feedforward_max, that limit) (:meth:`clamp`).
    """

    def __init__(self, system=None, feedforward_max: float = PARAMETERS["feedforward_max"].default,
                 max_abs: float = PARAMETERS["gate_max_abs"].default, drive=None):
        self.system = system
        self.drive = drive  # the feed-forward's (the node's drive_file): the signs a result must share
        self.feedforward_max = float(feedforward_max)
        self.max_abs = float(max_abs)
        self.default = Limit(self.feedforward_max, math.nan, "the node's feedforward_max")

    @classmethod
    def of(cls, cfg) -> Screen:
        """The screen of a node's :class:`~frictionid_ros.parameters.Config`: its system (with its drive),
        ``feedforward_max`` and ``gate_max_abs``."""
        from frictionid_core.systems import get_system

        try:
            system = get_system(cfg.system, drive=cfg.drive)
        except FrictionIdError:  # a drive that does not fit the system: identifications say so
            system = get_system(cfg.system)
        return cls(system, cfg.feedforward_max, cfg.gate_max_abs, cfg.drive)

    def limits(self, per_joint: dict[str, JointParams]) -> dict[str, Limit]:
        """{joint (or motor): its Limit} of ``per_joint``'s owners."""
        robot = robot_limits(self.system, list(per_joint)) if self.system is not None else {}
        return {j: robot.get(j) or p.limit or self.default for j, p in per_joint.items()}

    def refusals(self, results: Results) -> list[str]:
        """The screen's refusals of ``results`` (its joints' parameters and the shared ones of its
        identification), one line each; empty: accepted."""
        last = results.last
        single = last is not None and len(last.friction_rows()) == 1
        bounds = explicit_bounds(last)
        params, allowed, std = {}, {}, {}
        for j, p in results.per_joint.items():
            std.update((f"{j}/{k}", v) for k, v in p.std.items())
            for k, v in p.params.items():
                params[f"{j}/{k}"] = v
                own = bounds.get(f"{j}/{k}") or (bounds.get(k) if single else None)
                if own is not None:
                    allowed[f"{j}/{k}"] = own
        for k, v, sigma in zip(*shared_parameters(last)):
            params[k], std[k] = v, sigma
            if k in bounds:
                allowed[k] = bounds[k]
        return effort_sign_refusals(last, self.drive) + screen_parameters(
            params, self.limits(results.per_joint), bounds=allowed, max_abs=self.max_abs, default=self.default, std=std)

    def check(self, results: Results) -> None:
        """FrictionIdError naming the parameters at fault and their limits when ``results`` (its
        payload included) is refused."""
        refusals = self.refusals(results)
        if results.payload is not None:
            refusals += payload_refusals(results.payload, self.system, max_abs=self.max_abs)
        if refusals:
            more = f" (and {len(refusals) - 3} more)" if len(refusals) > 3 else ""
            raise FrictionIdError("refused by the safety screen: " + "; ".join(refusals[:3]) + more)

    def clamp(self, joints: list[str], per_joint: dict[str, JointParams], drive=None) -> np.ndarray:
        """The feed-forward's clamp of each of ``joints`` [N·m | N]: feedforward_max, lowered to the
        joint's own effort limit (not under a ``drive``: the feed-forward is then in recorded units)."""
        out = np.full(len(joints), self.feedforward_max)
        if drive is None:
            limits = self.limits({j: per_joint[j] for j in joints if j in per_joint})
            for k, j in enumerate(joints):
                if j in limits:
                    out[k] = min(out[k], limits[j].effort)
        return out
