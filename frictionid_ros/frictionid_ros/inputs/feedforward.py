"""Friction feed-forward from the active parameters (no ROS import).

τ_ff[j] = FrictionModel.torque(θ_j, v[j], eps) of the core — the identified friction only
(no rigid-body terms, no ``offset``). Joints without parameters get 0.

With the node's drive (``drive_file``) velocities and the feed-forward are on its recorded side,
in the units of joint_states: joint velocities q̇ = R⁻¹·v (motor-side log), the friction of
motor-side parameters (``motor_<k>``) acts on w = C·q̇ and gives the joint torques Cᵀ·f(w),
which are published as recorded efforts (:meth:`Drive.recorded_effort_matrix`).

Rate limit and clamp: new parameters blend in linearly over ``ramp_s`` (τ = (1 − α)·τ_old + α·τ_new,
α from 0 to 1; 0: at once), and every joint's torque is clamped to ±``limit`` (one value, or one per
joint; the node's is always finite: :meth:`frictionid_ros.store.Screen.clamp`).

Load-dependent Coulomb friction (``Fc_load``, joint-side parameters): the Coulomb level is
Fc + Fc_load·|τ_rigid|, τ_rigid the joint's rigid-body torque. The node has no rigid-body model
online; it takes the joint's latest measured effort less the friction it feeds forward for that
(:attr:`FeedForward.effort`, set by the inputs), so τ_rigid includes the offset and the effort's
noise; without a measured effort (NaN) the level is Fc alone. Under a drive the term is not fed
forward (a warning says so).

Dynamic laws (LuGre, Maxwell-slip): their states (:class:`frictionid_core.friction.StateFriction`)
advance with each input sample (:meth:`FeedForward.advance`, at the input rate, whatever the
publication rate; with ``velocity_source: reference`` the reference velocity drives them), and
restart at the sliding values of the current velocity — 0 at rest — when the parameters change, on
the first sample, after a gap longer than :data:`STATE_GAP_S`, a stamp that does not move forward,
or a non-finite velocity (safe: never a stored deflection from another motion).
"""

from __future__ import annotations

import math
import time

import numpy as np

from frictionid_core import FrictionIdError, FrictionModel
from frictionid_core.friction import StateFriction, smooth_sign
from frictionid_ros.store import JointParams

# A dynamic law's states restart after an input gap longer than this [s].
STATE_GAP_S = 0.1


class FeedForward:
    """Friction torque of joints ``joints`` [N·m | N, or the drive's effort unit] at velocities v
    [rad/s | m/s, or the drive's recorded side].

    Owners sharing a friction model are evaluated with one core call: ``torque`` of a (g, k)
    parameter block at the g velocities gives a (g, g) array whose diagonal is the answer.
    """

    def __init__(self, joints: list[str], eps: float = 0.0, drive=None, limit=math.inf, ramp_s: float = 0.0):
        self.joints = list(joints)
        self.eps = float(eps)
        self.drive = drive
        self.limit = limit
        self.ramp_s = float(ramp_s)
        self._ramp: tuple = (None, 0.0)  # (state before the last change, time of the change [s, monotonic])
        # (groups (model, owner indices, parameters), drive maps (order, A, B) or None)
        self._state: tuple[tuple, tuple | None] = ((), None)
        self.active: tuple[str, ...] = ()
        self._t0_ns: int | None = None  # the first stamp of advance()
        self.effort = np.full(len(self.joints), np.nan)  # the latest measured effort (J,) [N·m | N]; NaN: none
        self._load: np.ndarray | None = None  # Fc_load of each joint (J,), None: no joint has one

    @property
    def limit(self) -> np.ndarray:
        """The clamp of each joint's torque [N·m | N, or the drive's effort unit], (J,)."""
        return self._bounds[0]

    @limit.setter
    def limit(self, value) -> None:
        high = np.broadcast_to(np.asarray(value, dtype=float), (len(self.joints),)).copy()
        self._bounds = (high, -high)  # one tuple, swapped at once: torque() never sees half a change

    def set_params(self, per_joint: dict[str, JointParams]) -> list[str]:
        """Use ``per_joint`` (by joint, or by motor under a drive; other names are ignored);
        returns problems found."""
        problems: list[str] = []
        owners, maps = self._owners(per_joint, problems)
        groups: dict[FrictionModel, tuple[list[int], list[list[float]]]] = {}
        active = []
        load = np.zeros(len(owners))
        for i, j in enumerate(owners):
            p = per_joint.get(j)
            if p is None:
                continue
            try:
                model, vec = p.friction_vector()
            except FrictionIdError as exc:
                problems.append(str(exc))
                continue
            if p.params.get("Fc_load"):
                if maps is None:
                    load[i] = p.params["Fc_load"]
                else:
                    problems.append(f"joint '{j}': its load-dependent Coulomb level (Fc_load "
                                    f"{p.params['Fc_load']:.6g}) is not fed forward under a drive: Fc alone")
            idx, rows = groups.setdefault(model, ([], []))
            idx.append(i)
            rows.append(vec)
            active.append(j)
        # One immutable tuple, swapped atomically: readers in other threads never see a half update.
        if self.ramp_s > 0.0 and self.active:
            self._ramp = (self._state, time.monotonic())
        self._state = (tuple((m, np.array(idx, dtype=np.intp), np.array(rows, dtype=float),
                              StateFriction(m, np.array(rows, dtype=float)) if m.is_dynamic else None)
                             for m, (idx, rows) in groups.items()), maps)
        self.active = tuple(active)
        self._load = load if load.any() else None
        return problems

    def _owners(self, per_joint: dict, problems: list[str]) -> tuple[list[str], tuple | None]:
        """Who owns friction parameters, in evaluation order, and the drive maps (None: the
        joints themselves). Maps: ``order`` (the joint of each drive joint), A (velocities of the
        owners = A·v[order]) and B (efforts at ``order`` = B·f)."""
        drive = self.drive
        if drive is None:
            return self.joints, None
        names = list(drive.joints)
        if sorted(self.joints) == sorted(names):
            order = [self.joints.index(j) for j in names]
        elif len(self.joints) == len(names) and not set(self.joints) & set(names):
            order = list(range(len(names)))  # the log's names, in the drive's order
        else:
            problems.append(f"feed-forward: joints {self.joints} do not match drive '{drive.name}' joints {names}")
            return [], None
        A, B = drive.joint_velocity_matrix(), drive.recorded_effort_matrix()
        if any(m in per_joint for m in drive.motor_names()):  # friction on the motors: f(C·q̇) → Cᵀ·f
            return drive.motor_names(), (np.array(order), drive.C @ A, B @ drive.C.T)
        return [self.joints[k] for k in order], (np.array(order), A, B)

    def advance(self, v: np.ndarray, t_ns: int) -> None:
        """Advance the dynamic laws' states to velocities v (J,) stamped ``t_ns`` [ns] (see the
        module docstring for when they restart)."""
        if self._t0_ns is None:
            self._t0_ns = int(t_ns)
        t_s = (int(t_ns) - self._t0_ns) * 1e-9  # from the first stamp: steps exact to the nanosecond
        states = [self._state]
        if self._ramp[0] is not None:
            states.append(self._ramp[0])
        for groups, maps in states:
            dynamic = [(idx, state) for _, idx, _, state in groups if state is not None]
            if not dynamic:
                continue
            owners = self._owner_velocity(maps, v)
            for idx, state in dynamic:
                state.advance(owners[idx], t_s, STATE_GAP_S)

    def _owner_velocity(self, maps, v: np.ndarray) -> np.ndarray:
        """The velocities of the owners of friction parameters (the joints, or the drive's motors)."""
        if maps is None:
            return np.asarray(v, dtype=float)
        order, A, _ = maps
        vd = v[order]
        return A @ np.where(np.isfinite(vd), vd, np.nan)

    def torque(self, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Friction torque (J,) at velocities v (J,); non-finite velocities give 0 (under a drive,
        0 from every owner whose velocity they enter)."""
        out = self._torque(self._state, v, out)
        load = self._load
        if load is not None:  # Fc_load·|τ_rigid|·sign(v), τ_rigid ≈ the measured effort less the friction
            rigid = np.abs(self.effort - out)
            out += np.where(np.isfinite(rigid), load * rigid, 0.0) * smooth_sign(np.nan_to_num(v), self.eps)
        old, t_change = self._ramp
        if old is not None:
            alpha = (time.monotonic() - t_change) / self.ramp_s
            if alpha >= 1.0:
                self._ramp = (None, 0.0)
            else:
                out *= alpha
                out += (1.0 - alpha) * self._torque(old, v)
        high, low = self._bounds
        np.minimum(out, high, out=out)  # np.clip costs twice as much
        np.maximum(out, low, out=out)
        return out

    def _torque(self, state, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        out = np.zeros(len(self.joints)) if out is None else out
        out.fill(0.0)
        groups, maps = state
        if maps is None:
            self._friction(groups, v, out)
        else:
            order, A, B = maps
            vd = v[order]
            bad = ~np.isfinite(vd)
            f = self._friction(groups, A @ np.where(bad, 0.0, vd), np.zeros(len(order)))
            f[(A[:, bad] != 0.0).any(axis=1)] = 0.0
            out[order] = B @ f
        np.nan_to_num(out, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
        return out

    def _friction(self, groups, v: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Each owner's friction at its velocity v[owner] into ``out``."""
        for model, idx, params, state in groups:
            if state is None:
                out[idx] = model.torque_each(params, v[idx], self.eps)
            elif state.started:  # the states of the last input sample
                out[idx] = state.force(v[idx])
            else:  # no input sample since the parameters came: the sliding values
                out[idx] = StateFriction(model, params).reset(v[idx])
        return out
