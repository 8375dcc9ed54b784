"""Figures of a loop run from the controller's record (no ROS import).

Record: ``stamp_ns`` (N,), ``error`` q_d − q (N, J) [rad | m], ``latency_ns`` (M,) of the
feed-forward messages, ``joints``. Phases are (start, end) stamps [ns]; every phase's first
``settle_s`` is left out of its RMS (the transient of a switch).

* ratio per joint = RMS(feed-forward on) / RMS(off); the acceptance figure is its median.
* ``rms_at_reversals``: per phase and joint, the RMS tracking error within ±REVERSAL_WINDOW_S of
  each reversal of the desired velocity (where static friction laws have no answer).
* gain = 1 − median over joints of RMS(window) / RMS(off, same friction). The drift's
  ``recovered_fraction`` = gain over the last ``tail_s`` of the ``after_s`` after the drift
  ÷ gain before the drift, against the feed-forward-off RMS measured under the drifted friction
  (phase ``drift_off``); ``recovery_s`` = start of the first ``window_s`` window after the drift
  whose gain reaches ``target`` × the gain before (0: never lost; None: not within ``after_s``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from frictionid_core.errors import FrictionIdError

NS = 1_000_000_000
REVERSAL_WINDOW_S = 0.3  # rms_at_reversals: the error within this of each reversal [s]


def rms(record: dict, start_ns: int, end_ns: int, settle_s: float = 0.0) -> np.ndarray:
    """Per-joint RMS of the tracking error between two stamps [rad | m] (after ``settle_s``)."""
    t = record["stamp_ns"]
    keep = (t >= start_ns + int(settle_s * NS)) & (t < end_ns)
    if np.count_nonzero(keep) < 100:
        raise FrictionIdError(f"too few recorded steps ({np.count_nonzero(keep)}) in a phase of "
                              f"{(end_ns - start_ns) / NS:.3g} s: the loop did not run")
    return np.sqrt(np.mean(record["error"][keep] ** 2, axis=0))


def rms_at_reversals(record: dict, start_ns: int, end_ns: int, settle_s: float = 0.0) -> list[float | None]:
    """Per joint, the RMS tracking error [rad | m] within ±REVERSAL_WINDOW_S of each reversal (a sign
    change of the record's ``desired_velocity``) between two stamps (after ``settle_s``); None for
    a joint without a reversal there."""
    t, v = record["stamp_ns"], record["desired_velocity"]
    keep = (t >= start_ns + int(settle_s * NS)) & (t < end_ns)
    out = []
    for j in range(v.shape[1]):
        flips = t[1:][(np.sign(v[1:, j]) != np.sign(v[:-1, j])) & keep[1:]]
        near = np.zeros(t.size, dtype=bool)
        for at in flips:
            near |= np.abs(t - at) <= int(REVERSAL_WINDOW_S * NS)
        near &= keep
        out.append(float(np.sqrt(np.mean(record["error"][near, j] ** 2))) if near.any() else None)
    return out


def summarize(record: dict, phases: dict[str, tuple[int, int]], *, settle_s: float = 2.0, after_s: float = 20.0,
              window_s: float = 2.0, tail_s: float = 5.0, target: float = 0.8) -> dict:
    """The JSON of ``frictionid loop`` (module docstring); ``phases`` has ``feedforward_off``,
    ``feedforward_on`` and, for the drift figures, ``drift`` (its end is the end of the drift) and ``drift_off``."""
    joints = [str(j) for j in record["joints"]]
    off = rms(record, *phases["feedforward_off"], settle_s)
    on = rms(record, *phases["feedforward_on"], settle_s)
    out = {"rms_tracking_error": {"joints": joints, "feedforward_off": off.tolist(), "feedforward_on": on.tolist()}}
    if "desired_velocity" in record:
        out["rms_at_reversals"] = {"joints": joints, **{name: rms_at_reversals(record, *span, settle_s)
                                                       for name, span in phases.items()}}
    gain0 = 1.0 - float(np.median(on / off))
    if "drift" in phases and "drift_off" in phases:
        ref = rms(record, *phases["drift_off"], settle_s)
        end = phases["drift"][1]

        def gain(a: float, b: float) -> float:
            return 1.0 - float(np.median(rms(record, end + int(a * NS), end + int(b * NS)) / ref))

        recovered = gain(after_s - tail_s, after_s) / gain0 if gain0 > 0 else math.nan
        starts = np.arange(0.0, after_s - window_s + 1e-9, 0.5)
        good = [s for s in starts if gain(s, s + window_s) >= target * gain0]
        out["drift"] = {"recovered_fraction": recovered, "recovery_s": float(good[0]) if good else None}
    lat = np.asarray(record["latency_ns"], dtype=float) * 1e-6
    if lat.size:
        p50, p99 = np.percentile(lat, [50, 99])
        out["feedforward_latency_ms"] = {"p50": float(p50), "p99": float(p99), "max": float(lat.max())}
    return out


def payload_figures(record: dict, phases: dict[str, tuple[int, int]], true_kg: float, identified_kg: float | None,
                    settle_s: float = 2.0) -> dict:
    """The ``payload`` block of ``frictionid loop --payload-kg``: the payload's true and identified
    mass [kg] and the tracking error's RMS over every joint and step [rad | m] with the friction
    feed-forward on: ``rms_before`` the payload was attached (phase ``feedforward_on``),
    ``rms_attached`` (the controller's model without it: ``payload_attached``) and ``rms_after`` its
    rigid-body feed-forward took the identified payload (``payload_updated``); per joint too."""
    def total(per_joint: np.ndarray) -> float:
        return float(np.sqrt(np.mean(per_joint**2)))

    per_joint = {name: rms(record, *phases[phase], settle_s) for name, phase in (
        ("rms_before", "feedforward_on"), ("rms_attached", "payload_attached"), ("rms_after", "payload_updated"))
        if phase in phases}
    out = {"true_kg": float(true_kg), "identified_kg": None if identified_kg is None else float(identified_kg)}
    out.update((name, total(v)) for name, v in per_joint.items())
    out["per_joint"] = {name: v.tolist() for name, v in per_joint.items()}
    return out


def median_ratio(summary: dict) -> float:
    """Median over joints of RMS(on) / RMS(off) of a :func:`summarize` result."""
    r = summary["rms_tracking_error"]
    return float(np.median(np.asarray(r["feedforward_on"]) / np.asarray(r["feedforward_off"])))


def plot(record: dict, phases: dict[str, tuple[int, int]], folder: Path) -> list[Path]:
    """One PNG per phase: tracking error per joint over time [s from the phase start]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    t, err, joints = record["stamp_ns"], record["error"], [str(j) for j in record["joints"]]
    paths = []
    for name, (a, b) in phases.items():
        keep = (t >= a) & (t < b)
        fig, ax = plt.subplots(figsize=(9, 4.5))
        x = (t[keep] - a) * 1e-9
        for k, j in enumerate(joints):
            ax.plot(x, err[keep, k] * 1e3, lw=0.8, label=j)
        ax.set(xlabel="time in phase [s]", ylabel="q_d − q [mrad | mm]", title=f"tracking error: {name}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=min(len(joints), 6))
        fig.tight_layout()
        path = folder / f"loop_{name}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
