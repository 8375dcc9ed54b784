"""What the node's input callbacks do with a message, without ROS (messages are read by field).

One thread (the input executor's) calls :class:`Inputs`: it is the only writer of the ring
buffers and of the feed-forward velocity. Others read copies (:meth:`JointRing.snapshot`)
or counters.
"""

from __future__ import annotations

import math
import time

import numpy as np

from frictionid_ros.inputs.buffer import (
    NO_EFFORT,
    NO_POSITION,
    NO_VELOCITY,
    JointRing,
    NameMap,
    long_fields,
    put,
    stamp_ns,
)
from frictionid_ros.inputs.feedforward import FeedForward
from frictionid_ros.joint_names import name_problem

LATENCY_WINDOW = 4096  # feed-forward latencies kept for the percentiles [samples]


def _stamp_ns(msg) -> int:
    """Header stamp of ``msg`` [ns], or now (system clock) when it is zero."""
    return stamp_ns(msg.header.stamp) or time.time_ns()


class Inputs:
    """Ring buffers, feed-forward velocity and input counters of the node.

    Buffers are created when the joints are known (:meth:`setup`: from the configuration or the
    first joint state). ``v`` is the velocity of the feed-forward [rad/s | m/s], ``ff_stamp`` the
    stamp of the message that set it [ns]. ``settings()`` returns the node's current
    :class:`~frictionid_ros.parameters.Config`; ``warn`` logs a rejected message (once per reason);
    ``clamp(joints, per_joint)``: the feed-forward's clamp per joint (default: ``feedforward_max``).
    """

    def __init__(self, settings, warn, clamp=None):
        self._settings = settings
        self._warn = warn
        self._clamp = clamp or (lambda joints, per_joint: self._settings().feedforward_max)
        self.ring: JointRing | None = None
        self.effort_ring: JointRing | None = None
        self._map = self._effort_map = self._ref_map = None
        self.ff: FeedForward | None = None
        self._per_joint: dict = {}
        self.v = self.tau = self._ref_pos = self._ref_prev = None
        self._ref_t = self.ff_stamp = 0
        self.have_v = False
        self.received = self.rejected = self.effort_received = self.ff_published = 0
        self._last_reject = ""
        self._lat = np.zeros(LATENCY_WINDOW)
        self._n_lat = 0
        self._rate_mark = (time.monotonic(), 0)

    @property
    def joints(self) -> list[str]:
        """Buffered joints (the configured ones before the first message)."""
        return self.ring.joints if self.ring is not None else list(self._settings().joints)

    def setup(self, joints: list[str]) -> None:
        """Create the buffers, name maps and feed-forward of ``joints`` (in this order)."""
        cfg = self._settings()
        nj = len(joints)
        self._map = NameMap(joints)
        if cfg.effort_topic:
            self.effort_ring = JointRing(joints, cfg.capacity)
            self._effort_map = NameMap(joints)
        if cfg.velocity_source == "reference":
            self._ref_map = NameMap(joints)
            self._ref_pos = np.full(nj, np.nan)
            self._ref_prev = np.full(nj, np.nan)
        self.v = np.zeros(nj)
        self.tau = np.zeros(nj)
        ff = FeedForward(joints, cfg.smoothing_eps, cfg.drive, self._clamp(joints, self._per_joint),
                         cfg.feedforward_ramp_s)
        for problem in ff.set_params(self._per_joint):
            self._warn(f"feed-forward: {problem}")
        self.ff = ff
        self.ring = JointRing(joints, cfg.capacity)  # last: the callbacks test it to know the setup is complete

    def set_params(self, per_joint: dict) -> list[str]:
        """Feed forward the friction of ``per_joint`` (store.JointParams by joint); returns problems."""
        self._per_joint = per_joint
        ff = self.ff
        if ff is None:
            return []
        limit = np.broadcast_to(np.asarray(self._clamp(ff.joints, per_joint), dtype=float), ff.limit.shape)
        ff.limit = np.minimum(ff.limit, limit)  # the lower clamp while the parameters change (another thread reads)
        problems = ff.set_params(per_joint)
        ff.limit = limit
        return problems

    def reject(self, what: str) -> None:
        self.rejected += 1
        if what != self._last_reject:  # log each new reason once, not 1000 times a second
            self._last_reject = what
            self._warn(f"ignored message: {what}")

    def joint_state(self, msg, t_rx: int) -> bool:
        """Buffer a sensor_msgs/JointState received at ``t_rx`` [ns]; True if it set the feed-forward velocity."""
        ring = self.ring
        names = msg.name
        n = len(names)
        if ring is None:
            problem = "JointState without joint names" if not names else name_problem(names)
            if problem:
                self.reject(f"'{self._settings().joint_states_topic}': {problem}")
                return False
            self.setup(list(names))
            ring = self.ring
        try:
            idx = self._map.index(names)
        except KeyError as exc:
            self.reject(f"'{self._settings().joint_states_topic}': {exc.args[0]}")
            return False
        problem = long_fields(msg, n)
        if problem:
            self.reject(f"'{self._settings().joint_states_topic}': {problem}")
            return False
        t_ns = _stamp_ns(msg)
        flags = 0
        with ring.lock:
            k = ring.head
            ring.t_ns[k] = t_ns
            ring.rx_ns[k] = t_rx
            if not put(ring.position[k], msg.position, idx, n):
                flags |= NO_POSITION
            if not put(ring.velocity[k], msg.velocity, idx, n):
                flags |= NO_VELOCITY
            if self.effort_ring is None and not put(ring.effort[k], msg.effort, idx, n):
                flags |= NO_EFFORT
            ring.flags[k] = flags
            ring.commit()
        if self.effort_ring is None:  # the feed-forward's measured effort (a load-dependent Coulomb level)
            self.ff.effort[:] = np.nan if flags & NO_EFFORT else ring.effort[k]
        self.received += 1
        if self._ref_map is not None:
            return False
        v = self.v
        if not flags & NO_VELOCITY:
            v[:] = ring.velocity[k]
        else:  # finite difference of the two newest buffered positions
            prev = ring.last_row(1)
            dt = (t_ns - int(ring.t_ns[prev])) * 1e-9 if prev is not None else 0.0
            if dt > 0.0:
                np.subtract(ring.position[k], ring.position[prev], out=v)
                v /= dt
            else:
                v.fill(np.nan)  # unknown velocity → zero torque
        self.ff_stamp = t_ns
        self.have_v = True
        self.ff.advance(v, t_ns)  # a dynamic law's states, at the input rate
        return True

    def effort(self, msg, t_rx: int) -> None:
        """Buffer a JointState (by stamp) or an unstamped Float64MultiArray (by receipt ``t_rx`` [ns]) effort."""
        ring = self.effort_ring
        topic = self._settings().effort_topic
        if ring is None:
            return self.reject(f"'{topic}': effort before the joint names are known")
        if hasattr(msg, "name"):  # JointState
            try:
                idx = self._effort_map.index(msg.name)
            except KeyError as exc:
                return self.reject(f"'{topic}': {exc.args[0]}")
            problem = long_fields(msg, len(msg.name), ("effort",))
            if problem:
                return self.reject(f"'{topic}': {problem}")
            t_ns, n, src = _stamp_ns(msg), len(msg.name), msg.effort
        else:  # no stamp: paired with the joint states by receipt time (same clock, same path)
            t_ns, idx, src, n = t_rx, None, msg.data, len(ring.joints)
            if len(src) != n:
                return self.reject(f"'{topic}': {len(src)} values for {n} joints {ring.joints}")
        with ring.lock:
            k = ring.head
            ring.t_ns[k] = t_ns
            ring.flags[k] = 0 if put(ring.effort[k], src, idx, n) else NO_EFFORT
            ring.commit()
        self.ff.effort[:] = ring.effort[k] if ring.flags[k] == 0 else np.nan
        self.effort_received += 1

    def reference(self, msg) -> bool:
        """Take the desired velocity of a reference JointState (else differentiate its positions);
        True if it set the feed-forward velocity."""
        topic = self._settings().reference_topic
        if self._ref_map is None:
            self.reject(f"'{topic}': reference before the joint names are known")
            return False
        try:
            idx = self._ref_map.index(msg.name)
        except KeyError as exc:
            self.reject(f"'{topic}': {exc.args[0]}")
            return False
        n = len(msg.name)
        problem = long_fields(msg, n, ("position", "velocity"))
        if problem:
            self.reject(f"'{topic}': {problem}")
            return False
        t_ns = _stamp_ns(msg)
        v = self.v
        if not put(v, msg.velocity, idx, n):  # no desired velocity: differentiate the desired position
            pos, prev = self._ref_pos, self._ref_prev
            prev[:] = pos
            if not put(pos, msg.position, idx, n):
                self.reject(f"'{topic}': neither velocity nor position")
                return False
            dt = (t_ns - self._ref_t) * 1e-9 if self._ref_t else 0.0
            if dt > 0.0:
                np.subtract(pos, prev, out=v)
                v /= dt
            else:
                v.fill(np.nan)
        self._ref_t = t_ns
        self.ff_stamp = t_ns
        self.have_v = True
        self.ff.advance(v, t_ns)  # a dynamic law's states, driven by the reference velocity
        return True

    def clear(self) -> int:
        """Empty the buffers; returns the joint-state samples dropped."""
        n = self.ring.count if self.ring is not None else 0
        for ring in (self.ring, self.effort_ring):
            if ring is not None:
                ring.clear()
        return n

    def published(self, t_rx: int = 0) -> None:
        """Count a feed-forward publication; ``t_rx``: receipt of the trigger [ns] (0: timer)."""
        if t_rx:
            self._lat[self._n_lat % LATENCY_WINDOW] = (time.time_ns() - t_rx) * 1e-9
            self._n_lat += 1
        self.ff_published += 1

    def latency_percentiles(self) -> tuple[float, float, float]:
        """Feed-forward latency, receipt of the trigger → both messages published: p50, p99, max over
        the last LATENCY_WINDOW messages [s]."""
        n = min(self._n_lat, LATENCY_WINDOW)
        if n == 0:
            return (math.nan,) * 3
        lat = self._lat[:n]
        p50, p99 = np.percentile(lat, [50, 99])
        return float(p50), float(p99), float(lat.max())

    def buffer_status(self) -> tuple[bool, str, dict]:
        """(ok, message, values) of the joint buffer since the previous call: ok = joint states arrived."""
        now = time.monotonic()
        t_prev, n_prev = self._rate_mark
        rate = (self.received - n_prev) / (now - t_prev) if now > t_prev else 0.0
        self._rate_mark = (now, self.received)
        ring = self.ring
        count = ring.count if ring else 0
        cap = ring.capacity if ring else self._settings().capacity
        span = 0.0
        if ring is not None and count > 1:
            span = (int(ring.t_ns[ring.last_row(0)]) - int(ring.t_ns[ring.last_row(count - 1)])) * 1e-9
        message = (f"{count}/{cap} samples ({100.0 * count / cap:.1f} %), {rate:.1f} Hz" if rate > 0
                   else f"no joint states in the last period ({count}/{cap} samples)")
        return rate > 0, message, {
            "joints": ",".join(ring.joints) if ring else "", "samples": count, "capacity": cap,
            "fill_pct": f"{100.0 * count / cap:.2f}", "buffered_seconds": f"{span:.3f}", "rate_hz": f"{rate:.2f}",
            "received": self.received, "rejected": self.rejected, "effort_received": self.effort_received,
            "buffer_bytes": ring.nbytes if ring else 0}

    def feedforward_values(self) -> dict:
        """Feed-forward counters and latency percentiles [µs] for the diagnostics."""
        p50, p99, pmax = self.latency_percentiles()
        return {"ff_published": self.ff_published, "ff_latency_p50_us": f"{p50 * 1e6:.1f}",
                "ff_latency_p99_us": f"{p99 * 1e6:.1f}", "ff_latency_max_us": f"{pmax * 1e6:.1f}"}
