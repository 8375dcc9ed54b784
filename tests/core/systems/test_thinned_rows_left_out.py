"""The rows a fit leaves out near standstill, on a thinned observation (a dip refit: every analysis
row near a dip, one in ``thin`` elsewhere): runs and reversals are measured in time, so the uneven
spacing of the rows neither splits the log into stretches nor makes a long run brief."""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import get_system, observe
from frictionid_core.timeseries import JointSeries


def _sweeping_joint(rate: float = 1000.0, seconds: float = 20.0) -> JointSeries:
    """One friction-only joint ('a') swept at 0.5 Hz, q = 0.5·sin(πt) rad: a run of one sign lasts 1 s."""
    t = np.arange(int(seconds * rate)) / rate
    q = 0.5 * np.sin(np.pi * t)
    qd = 0.5 * np.pi * np.cos(np.pi * t)
    tau = 2.0 * qd + np.sign(qd)
    return JointSeries(t, ["a"], q[:, None], tau[:, None], source="sweep")


def test_a_thinned_observation_keeps_its_long_runs():
    """10 Hz cut-off, brief runs below 0.5 period (50 ms), reversals ± 0.2 period: thinned by 10 around
    a dip of 0.05 or 0.2 rad/s, no run of the 1 s sweeps is brief (a 10 ms step among 2 ms ones is no
    seam), and around the 0.05 rad/s dip (every row kept at the reversals) the rows left out at the
    reversals are the unthinned observation's (those within 20 ms of each)."""
    system = get_system("friction-only")
    base = dict(cutoff_hz=10.0, decimate=1, trim_start_s=0.5, trim_end_s=0.5, min_speed={"a": 1e-3},
                brief_periods=0.5, reversal_periods=0.2)
    every = observe(_sweeping_joint(), system, Preprocessing(**base))
    thinned = observe(_sweeping_joint(), system, Preprocessing(**base, thin=10, dip_scale={"a": 0.05}))
    # a wider dip: rows 2 ms apart (decimation 2) over most of the sweep, 10 ms apart elsewhere
    wide = observe(_sweeping_joint(), system, Preprocessing(**base, thin=10, dip_scale={"a": 0.2}))
    assert thinned.y.size < 0.5 * every.y.size and wide.y.size < 0.5 * every.y.size  # thinned indeed
    for obs in (every, thinned, wide):
        assert obs.report["brief_motion_rows"]["a"] == 0
    # reversal rows: 40 ms of each reversal's rows, at the rows' own spacing there (every row near the dip)
    assert every.report["reversal_rows"]["a"] == thinned.report["reversal_rows"]["a"] > 0
