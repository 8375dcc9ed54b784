"""The travel a dynamic friction law's states follow (docs/reference.md#dynamic-friction).

A LuGre or Maxwell-slip element is a spring of a fraction of a milliradian: a micro-radian of
travel is a visible share of its force, and its states follow the *path* travelled, not the
time. The filtered position still carries its noise (a fraction of a micro-radian at rest), and
a noisy velocity at rest makes the states creep: every back-and-forth of noise unloads a
deflected element more than it loads it (ż = v − |v|·z/c), so a held force decays to 0 within
the dwell. The travel the states see is therefore that of the filtered position through a
*play* (a backlash of half-width ε = :data:`PLAY_SIGMAS` × the position noise the filter leaves,
:func:`travel_noise`): the output holds while the position stays within ±ε of it and
follows it otherwise, and is shifted by ε in the direction of its last move (:func:`play`), so
that along a motion it is the position itself and at a reversal it holds until the position has
come back 2ε, then takes that travel at once. Noise below ε moves nothing; a motion loses nothing
but the timing of the 2ε after each reversal (an element's force there is off by at most 2ε·k: a
few hundredths of a newton-metre for LuGre's usual stiffness; giving the held samples the position
back once the reversal is certain gained 2–8 % of the error on synthetic joints and lost 7 % on the
real TX40, whose filtered noise wanders smoothly: not done).

Between two analysis instants the states take the output's path length and net shift
(:func:`row_travel`: one reversal inside a step is split at it; one between two samples, which
they do not show, gets the path the velocities give it), whatever the decimation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from frictionid_core.parallel import run_chunks
from frictionid_core.preprocess.rule import differentiated_noise_var
from frictionid_core.preprocess.settings import Preprocessing, joint_cutoffs

# The play's half-width in σ of the filtered position noise: noise that wide stays within it.
PLAY_SIGMAS = 4.0


@njit(cache=True, nogil=True)
def _play_columns(q, eps, lo, hi, out):  # pragma: no cover - compiled
    """Columns lo..hi−1 of :func:`play`."""
    for j in range(lo, hi):
        e = eps[j]
        held = q[0, j]  # the play's inner position; its output is the position when it moves
        last = q[0, j]
        for k in range(q.shape[0]):
            x = q[k, j]
            if held < x - e:
                held = x - e
                last = x
            elif held > x + e:
                held = x + e
                last = x
            out[k, j] = last


def play(q: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """Each column of q (N, J) through a play of half-width ``eps`` (J,), its output the position
    where it last moved (its inner position shifted by ε in the direction of that move; module
    doc): (N, J)."""
    q = np.ascontiguousarray(q, dtype=float)
    eps = np.ascontiguousarray(np.broadcast_to(np.asarray(eps, dtype=float), (q.shape[1],)))
    out = np.empty_like(q)

    def chunk(lo: int, hi: int) -> None:
        _play_columns(q, eps, lo, hi, out)

    run_chunks(chunk, q.shape[1], min_items=max(1, -(-2_000_000 // max(q.shape[0], 1))))
    return out


def row_travel(position: np.ndarray, rows: np.ndarray, velocity: np.ndarray | None = None, dt: float = 0.0
               ) -> tuple[np.ndarray, np.ndarray]:
    """(path, shift), each (len(rows), J): the distance travelled by each column of ``position``
    (N, J) from the previous row of ``rows`` (ascending sample indices) to each, and its net
    displacement; 0 at the first row. With the samples' ``velocity`` (N, J) and period ``dt``, a
    step between two samples whose velocity changes sign, over which the position moved, travelled
    at least what the velocities taken linear give (out and back: 0.5·(|v0|² + |v1|²)·dt/(|v0| + |v1|));
    the samples do not show that reversal (at 50 Hz it is a fifth of a millimetre at 1 rad/s²)."""
    path, shift = np.zeros((rows.size, position.shape[1])), np.zeros((rows.size, position.shape[1]))
    if rows.size > 1:
        end = rows[-1] + 1
        step = np.abs(np.diff(position[:end], axis=0))  # sums per step: no cancellation
        if velocity is not None and dt > 0.0:
            v0, v1 = np.abs(velocity[: end - 1]), np.abs(velocity[1:end])
            turns = (velocity[: end - 1] * velocity[1:end] < 0.0) & (step > 0.0)
            out_and_back = 0.5 * (v0**2 + v1**2) * dt / np.where(turns, v0 + v1, 1.0)
            step = np.where(turns, np.maximum(step, out_and_back), step)
        path[1:] = np.add.reduceat(step, rows[:-1], axis=0)
        shift[1:] = np.diff(position[rows], axis=0)
    return path, shift


def travel_noise(report: dict, settings: Preprocessing, joints: list[str], fs: float) -> np.ndarray:
    """(J,) σ of the position noise of each of ``joints`` left by the position filter of
    ``settings`` at sample rate ``fs``: the rule's white-noise estimate (``report["position_noise"]``,
    :func:`~frictionid_core.preprocess.choose_preprocessing`) through the forward–backward Butterworth."""
    sigma = np.array([report["position_noise"].get(j) or 0.0 for j in joints], dtype=float)
    cutoffs = None if settings.filter == "none" else joint_cutoffs(settings.cutoff_hz, joints)
    return np.sqrt(differentiated_noise_var(sigma**2 / (fs / 2.0), fs, cutoffs, settings.order, 0))


def travel_rows(position: np.ndarray, rows: np.ndarray, noise: np.ndarray, velocity: np.ndarray | None = None,
                dt: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(path, shift) (len(rows), J) of the full-rate filtered ``position`` (N, J) through the play
    of PLAY_SIGMAS × its ``noise`` (J,) (:func:`travel_noise`), from each row of ``rows`` to the
    next (:func:`row_travel`, with the samples' ``velocity`` and period ``dt`` when given)."""
    return row_travel(play(position, PLAY_SIGMAS * np.asarray(noise, dtype=float)), rows, velocity, dt)
