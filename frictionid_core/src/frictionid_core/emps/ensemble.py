"""Grey + black-box ensembles of the EMPS position (thesis §6.2, docs/reference.md#ensembles).

* GBM  ŷ1: the grey-box closed-loop simulation (:mod:`frictionid_core.emps.simulation`).
* BGBM ŷ2 = ŷ1 + ê1: a neural NARX-type model of the simulation residual e1 = y − ŷ1,
  driven by the exogenous signals available in simulation — the drive force (the input) and
  the grey-box simulated velocity — over ``lags`` past samples ``step`` apart. It has no
  output feedback, so it simulates free-running (it never sees the measured position).
* EGBB ŷ3 = c + w1·ŷ1 + w2·ŷ2, least squares on the estimation run.
The black box is the mean of ``members`` scikit-learn MLPRegressors (one tanh hidden layer,
different initial weights), fitted on the estimation run only: one network's validation gain
varies by ±6 points with its seed, the mean of five is steadier.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.emps.simulation import EmpsSimulator
from frictionid_core.model import improvement_pct, relerr_pct


@dataclass
class Ensemble:
    """Relative errors (%) of ŷ1, ŷ2, ŷ3 on both runs, the ensemble weights and the settings."""

    friction: str
    asymmetric: bool
    errors: dict[str, dict[str, float]]
    weights: dict[str, float]
    settings: dict

    def to_dict(self) -> dict:
        gain = {k: improvement_pct(self.errors[k]["val"], self.errors["gbm"]["val"]) for k in ("bgbm", "egbb")}
        return {"friction": self.friction, "asymmetric": self.asymmetric, "errors_pct": self.errors,
                "improvement_val_pct": gain, "weights": self.weights, "settings": self.settings}


def _features(force: np.ndarray, velocity: np.ndarray, lags: int, step: int) -> tuple[np.ndarray, int]:
    """Lagged exogenous regressors (N − k0, 2·lags) and the first usable sample k0."""
    n = force.size
    k0 = (lags - 1) * step
    cols = [sig[k0 - i * step : n - i * step] for sig in (force, velocity) for i in range(lags)]
    return np.column_stack(cols), k0


def grey_black_ensemble(estimation, validation, params: dict, friction: str = "coulomb", asymmetric: bool = False,
                        *, clock: str = "true", lags: int = 10, step: int = 2, hidden: int = 12,
                        seed: int = 0, members: int = 5) -> Ensemble:
    """Fit the BGBM and EGBB on ``estimation`` for the grey-box ``params``; score both runs.

    Args:
        estimation, validation: EMPS runs (EmpsData, bag or MAT path).
        params: grey-box parameters {name: value} (e.g. an identification's ``params``).
        lags, step: exogenous lags and their spacing, samples.
        hidden: neurons of the hidden layer.
        seed: initialisation seed of the first network (members use seed, seed + 1, …).
        members: networks averaged.
    """
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor

    runs = {}
    for tag, data in (("est", estimation), ("val", validation)):
        sim = EmpsSimulator(data, friction, asymmetric, clock=clock, offset="offset" in params)
        out = sim.simulate(params)
        runs[tag] = (sim, out.q.ravel(), sim.data.force, out.velocity.ravel())
    sim, y1, force, vel = runs["est"]
    X, k0 = _features(force, vel, lags, step)
    mu, sd = X.mean(axis=0), X.std(axis=0) + 1e-300
    e1 = sim.q_ref - y1
    target = e1[k0:]
    tm, ts = target.mean(), target.std()
    nets = [MLPRegressor(hidden_layer_sizes=(hidden,), activation="tanh", max_iter=500, random_state=seed + m)
            for m in range(members)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        for net in nets:
            net.fit((X - mu) / sd, (target - tm) / ts)

    def y2_of(tag: str) -> np.ndarray:
        s, y1_, f_, v_ = runs[tag]
        Xr, _ = _features(f_, v_, lags, step)
        y2 = y1_.copy()
        Z = (Xr - mu) / sd
        y2[k0:] += np.mean([net.predict(Z) for net in nets], axis=0) * ts + tm
        return y2

    skip = max(sim.skip, k0)
    y2_est = y2_of("est")
    A = np.column_stack([np.ones(y1.size - skip), y1[skip:], y2_est[skip:]])
    c, w1, w2 = np.linalg.lstsq(A, sim.q_ref[skip:], rcond=None)[0]
    errors: dict[str, dict[str, float]] = {"gbm": {}, "bgbm": {}, "egbb": {}}
    for tag in ("est", "val"):
        s, y1_, _, _ = runs[tag]
        y2 = y2_est if tag == "est" else y2_of(tag)
        y3 = c + w1 * y1_ + w2 * y2
        ref = s.q_ref[skip:]
        for key, yhat in (("gbm", y1_), ("bgbm", y2), ("egbb", y3)):
            errors[key][tag] = relerr_pct(ref, yhat[skip:])
    return Ensemble(friction, asymmetric, errors, {"c": float(c), "w1": float(w1), "w2": float(w2)},
                    {"clock": clock, "lags": lags, "step": step, "hidden": hidden, "seed": seed, "members": members,
                     "inputs": ["force", "grey-box velocity"]})
