"""mujoco.sysid on a logged arm: damping, frictionloss and armature per joint (bench/.venv-sysid).

    bench/.venv-sysid/bin/python bench/_sysid_worker.py JOB.json OUT.json

Run by ``groundtruth.py``; frictionid_core is not importable here. JOB: ``xml`` (MJCF of the arm
with one motor and one jointpos sensor per joint, rigid body as modelled), ``log`` (.npz: ``t``
(N,), ``position`` (N, J) the recorded positions, ``effort`` (N, J) the torque applied from each
stamp to the next), ``joints``, ``chunk_s``, ``velocity_window`` (samples), ``start`` and ``bounds``
{damping, frictionloss, armature: [lo, hi]}, ``max_iters``.

The log is cut into chunks of ``chunk_s``; each is an open-loop rollout of the logged torque from
the recorded position and a Savitzky–Golay velocity (cubic, ``velocity_window`` samples) at its
first stamp — the arm is unstable open loop, so one rollout of the whole log would drift away.
MuJoCo's state velocity is the one that brought the arm to its position (semi-implicit Euler), so
the smoothed derivative is taken half a step earlier (the central one leaves the rotor inertias
≈ 0.5 % high on the UR5). Residual: recorded minus simulated position [rad], every joint and
sample. MuJoCo's rollout labels the sensors computed during step k (the state before it) with the
time after it, t(k+1): the recorded positions are labelled one step late to match (without it
the UR5's rotor inertias come out 1–2.5 % low and the cost is 45 % higher). mujoco.sysid's
default residual divides each sensor by the norm of its measured values — of absolute joint
angles here, which would weight chunks by where the arm happens to be — so the residual is the
plain difference (``modify_residual``).

OUT: per joint the estimates, σ from ``calculate_intervals`` (95 % half-width / t quantile), the
time of ``optimize`` (``fit_s``), the cost before/after and the package versions.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

KINDS = ("damping", "frictionloss", "armature")


def _setter(kind: str, joint: str):
    def modify(spec, p):
        j = spec.joint(joint)
        if kind == "damping":
            j.damping[0] = p.value[0]  # MuJoCo 4: damping is a polynomial, [0] the linear term
        else:
            setattr(j, kind, p.value[0])
    return modify


def main(job_path: str, out_path: str) -> None:
    import mujoco
    import scipy.signal
    import scipy.special
    from mujoco import sysid

    job = json.load(open(job_path))
    joints = job["joints"]
    spec = mujoco.MjSpec.from_string(job["xml"])
    model = spec.compile()
    z = np.load(job["log"])
    t, q, tau = z["t"], z["position"], z["effort"]
    dt = float(model.opt.timestep)
    if abs(np.median(np.diff(t)) - dt) > 1e-9:
        raise SystemExit(f"log period {np.median(np.diff(t))} s is not the model's step {dt} s")
    # MuJoCo's state velocity at step k is the one that brought q there (q_k = q_(k-1) + dt·v_k):
    # the smoothed derivative half a step earlier
    smooth = {d: scipy.signal.savgol_filter(q, job["velocity_window"], 3, deriv=d, delta=dt, axis=0) for d in (1, 2)}
    qd = smooth[1] - 0.5 * dt * smooth[2]
    n = int(round(job["chunk_s"] / dt))
    starts = range(0, len(t) - n + 1, n)
    states, controls, sensors = [], [], []
    for s in starts:
        x0 = sysid.create_initial_state(model, q[s], qd[s])
        x0[0] = t[s]  # mjSTATE_FULLPHYSICS begins with the time: the rollout's clock is the log's
        states.append(x0)
        controls.append(sysid.TimeSeries(t[s:s + n], tau[s:s + n]))
        sensors.append(sysid.TimeSeries.from_names(t[s:s + n] + dt, q[s:s + n], model))
    seqs = sysid.ModelSequences("arm", spec, [f"chunk{s}" for s in starts], states, controls, sensors)

    params = sysid.ParameterDict()
    for kind in KINDS:
        lo, hi = job["bounds"][kind]
        for j in joints:
            p = sysid.Parameter(f"{j}/{kind}", nominal=job["start"][kind], min_value=lo, max_value=hi,
                                modifier=_setter(kind, j))
            params.add(p)

    def plain_difference(params_, predicted, measured, model_, return_pred_all, state=None, **_):
        measured = sysid.apply_delayed_ts_window(measured, predicted, 0.0, 0.0)
        predicted = predicted.resample(measured.times)
        return measured.data - predicted.data, predicted, measured

    residual_fn = sysid.build_residual_fn(models_sequences=[seqs], modify_residual=plain_difference)
    cost0 = float(np.sum(np.concatenate(residual_fn(params.as_vector(), params.copy())[0]) ** 2))
    t0 = time.perf_counter()
    opt, res = sysid.optimize(initial_params=params, residual_fn=residual_fn, optimizer="mujoco", verbose=False,
                              max_iters=job["max_iters"])
    fit_s = time.perf_counter() - t0
    r_star = residual_fn(opt.as_vector(), opt.copy())[0]
    r = np.concatenate(r_star)
    _, half = sysid.calculate_intervals(r_star, res.jac)
    sigma = half / scipy.special.stdtrit(r.size - res.jac.shape[1], 0.975)
    x = opt.as_vector()
    names = [f"{j}/{kind}" for kind in KINDS for j in joints]  # the order of params above
    out = {"params": {nm: float(v) for nm, v in zip(names, x)}, "std": {nm: float(s) for nm, s in zip(names, sigma)},
           "fit_s": fit_s, "cost_start": cost0, "cost": float(r @ r), "residuals": int(r.size),
           "chunks": len(states), "chunk_s": job["chunk_s"], "mujoco": mujoco.__version__, "numpy": np.__version__}
    json.dump(out, open(out_path, "w"))


if __name__ == "__main__":
    main(*sys.argv[1:3])
