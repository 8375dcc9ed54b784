"""What a fit may claim: never a non-finite or absurd one (:func:`check_fit`, :func:`check_metrics`),
its links against the robot model's (:func:`robot_plausibility`), the speeds it saw
(:func:`velocity_range`) and a known-rigid-body fit in the robot system's terms
(:func:`known_rigid_body_report`)."""

from __future__ import annotations

import numpy as np

from frictionid_core.consistency import link_plausibility, projection, standard_from_record
from frictionid_core.errors import FrictionIdError
from frictionid_core.model import IdentificationModel, check_finite
from frictionid_core.systems import LINK_TORQUE, KnownRigidBody, System

# A fit whose relative error on its own data exceeds this (10 × predicting nothing) is absurd: an error.
ABSURD_RELERR_PCT = 1000.0


def check_fit(model: IdentificationModel, x: np.ndarray, metrics: dict, source: str) -> None:
    """FrictionIdError (one line, exit 2) for a fit with a non-finite parameter or an absurd
    relative error (:func:`check_absurd`): never a silent absurd result. Non-finite metrics are
    the caller's (:func:`frictionid_core.model.metrics.check_finite`)."""
    bad = [n for n, v in zip(model.names, x) if not np.isfinite(v)]
    if bad:
        raise FrictionIdError(f"{source}: the fit ended with non-finite {', '.join(bad[:8])}; check the data and "
                              "the model (--friction coulomb --solver ls is the closed-form reference)")
    check_absurd(metrics, f"{source}: the fit")


def check_absurd(metrics: dict, what: str) -> None:
    """FrictionIdError naming ``what`` for a relative error above :data:`ABSURD_RELERR_PCT`."""
    relerr = metrics.get("relerr_pct")
    if relerr is not None and relerr > ABSURD_RELERR_PCT:
        raise FrictionIdError(f"{what} gives a relative error of {relerr:.4g} %, which exceeds {ABSURD_RELERR_PCT:g} % "
                              "(10 × predicting nothing): an absurd result; check the system, the drive and the effort "
                              "units")


def check_metrics(metrics: dict, what: str) -> None:
    """FrictionIdError naming ``what`` (``"the cross-test of r.json on log"``) for non-finite metrics
    (:func:`~frictionid_core.model.metrics.check_finite`) or an absurd relative error."""
    check_finite(metrics, what)
    check_absurd(metrics, what)


def velocity_range(model: IdentificationModel) -> dict[str, list[float]]:
    """{friction row (joint or motor): [slowest, fastest] |velocity| of its used rows} (rad/s or m/s)."""
    obs, nd = model.obs, model.obs.n_samples
    out = {}
    for j, row in enumerate(obs.joints):
        speed = np.abs(obs.velocity[obs.used[j * nd : (j + 1) * nd], j])
        speed = speed[speed > 0.0]
        if speed.size:
            out[row] = [float(speed.min()), float(speed.max())]
    return out


def known_rigid_body_report(held: KnownRigidBody, model: IdentificationModel, x: np.ndarray, std: dict,
                            std_robust: dict, white: tuple[list[str], np.ndarray | None],
                            robust: tuple[list[str], np.ndarray | None]) -> tuple[dict, dict, dict, dict]:
    """(params, std, std_robust, fixed) of a known-rigid-body fit in the robot system's terms: its
    base parameters (the links' with the identified rotor inertias in them; σ from the rotor
    inertias' covariance), each rotor inertia by its own name, then friction and offsets; fixed:
    the base parameters no rotor inertia enters (at the model's values) and the user's fixed
    values."""
    value = dict(zip(model.names, x))
    rotor = np.array([value[n] for n in held.rotor_names])
    base = held.base_parameters(rotor)
    params = dict(zip(held.system.rigid_names, map(float, base)))

    def base_std(sd: dict, names: list[str], cov: np.ndarray | None) -> dict:
        """σ of each base parameter: 0 where no free rotor inertia enters, NaN where one that does
        has no σ (held at 0, undetermined), else from their covariance."""
        out = {}
        for name, row in zip(held.system.rigid_names, held.rotor_map):
            enters = [(r, a) for r, a in zip(held.rotor_names, row) if a != 0.0 and sd[r] != 0.0]
            if not enters:
                out[name] = 0.0
            elif cov is None or any(r not in names for r, _ in enters):
                out[name] = float("nan")
            else:
                k = [names.index(r) for r, _ in enters]
                a = np.array([c for _, c in enters])
                out[name] = float(np.sqrt(max(a @ cov[np.ix_(k, k)] @ a, 0.0)))
        return out

    rest = [n for n in model.names if n != LINK_TORQUE and n not in held.rotor_names]
    ordered = [*held.system.rigid_names, *(n for n in held.rotor_names if n not in params)]
    params.update((n, float(value[n])) for n in held.rotor_names)
    params.update((n, float(value[n])) for n in rest)
    params = {n: params[n] for n in [*ordered, *rest]}
    stds = []
    for sd, (names, cov) in ((std, white), (std_robust, robust)):
        out = base_std(sd, names, cov)
        out.update((n, float(sd[n])) for n in [*held.rotor_names, *rest])
        stds.append({n: out[n] for n in params})
    fixed = {n: float(v) for n, v in zip(held.system.rigid_names, base) if n in held.held()}
    fixed.update((model.names[i], v) for i, v in model.fixed_values.items() if model.names[i] != LINK_TORQUE)
    return params, stds[0], stds[1], fixed


def robot_plausibility(params: dict[str, float], sys_: System, standard: dict | None, held: tuple | list = ()) -> dict:
    """The ``plausibility`` block of a robot fit (``params`` by name): its links (the consistent fit's standard
    parameters, else those reconstructed from its base parameters: the model's own corrected by
    the least change, the rotor inertias, which URDFs seldom hold, taking up what they can
    first, the links of the ``held`` joints kept as modelled) against the robot model's."""
    info = sys_.robot
    if standard is not None:
        return link_plausibility(info, standard_from_record(info, standard), "the consistent fit's")
    beta = np.array([params[n] for n in sys_.rigid_names])
    pi, _ = projection(info.model, info.base, beta, rotors_first=True, held=held)
    return link_plausibility(info, pi, "reconstructed from the base parameters")
