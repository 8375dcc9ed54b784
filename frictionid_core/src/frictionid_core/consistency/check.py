"""Physical consistency of identified base parameters (no SDP solver).

Base parameters β are combinations of the standard parameters π (β = A·π, A from
:class:`~frictionid_core.robots.base.BaseParameters`); they alone cannot say whether each body
is physically realisable. This module asks: *is there a π with A·π = β̂ whose every body is
physically consistent?* and answers it in two honest steps:

1. the weighted least-squares correction of a prior π₀ (the model's own, e.g. CAD/URDF,
   parameters; or a generic one) onto {π : A·π = β̂} (closed form);
2. if a body fails, a small SLSQP search in the null space of A (A·π stays = β̂) for a π
   meeting the inequalities, as close as possible to step 1.

Checked per body (Wensing et al. 2017 density realisability): mass m > 0 and the 4×4
pseudo-inertia J = [[½tr(I)·1 − I, h], [hᵀ, m]] positive definite (I: inertia about the joint
frame origin, h = m·c), which implies the inertia about the centre of mass is positive
definite and satisfies the triangle inequalities (both reported); and rotor inertias Ia ≥ 0.
A positive answer proves feasibility (a witness π is returned); a negative answer of step 2
is strong evidence, not a proof (the search is local).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import FrictionIdError

EIG_TOL = 1e-9


def _basis() -> np.ndarray:
    """E_i with J(p) = Σ p_i·E_i for p = [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]."""
    E = np.zeros((10, 4, 4))
    E[0, 3, 3] = 1.0
    for i, a in enumerate((0, 1, 2)):
        E[1 + i, a, 3] = E[1 + i, 3, a] = 1.0
    for i, (a, b) in zip((4, 5, 6, 7, 8, 9), ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))):
        if a == b:
            E[i, :3, :3] = 0.5 * np.eye(3)
            E[i, a, a] -= 1.0
        else:
            E[i, a, b] = E[i, b, a] = -1.0
    return E


def body_matrices(p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(m, h = m·c (3,), I about the origin (3, 3)) of [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]."""
    m, hx, hy, hz, xx, xy, yy, xz, yz, zz = p
    I_o = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return float(m), np.array([hx, hy, hz]), I_o


def pseudo_inertia(p: np.ndarray) -> np.ndarray:
    m, h, I_o = body_matrices(p)
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(I_o) * np.eye(3) - I_o
    J[:3, 3] = J[3, :3] = h
    J[3, 3] = m
    return J


PSEUDO_INERTIA_BASIS = _basis()


def body_report(p: np.ndarray) -> dict:
    """Mass, pseudo-inertia smallest eigenvalue, COM inertia eigenvalues, triangle inequalities."""
    m, h, I_o = body_matrices(p)
    lam_j = float(np.linalg.eigvalsh(pseudo_inertia(p))[0])
    out = {"mass": m, "pseudo_inertia_min_eig": lam_j}
    if m > 0:
        c = h / m
        Ic = I_o - m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
        ev = np.linalg.eigvalsh(Ic)
        out["com"] = c.tolist()
        out["com_inertia_eigs"] = ev.tolist()
        out["triangle_inequalities"] = bool(ev[0] + ev[1] >= ev[2] - 1e-12)
    out["consistent"] = bool(m > 0 and lam_j > EIG_TOL * max(1.0, abs(m)))
    return out


@dataclass
class ConsistencyReport:
    feasible: bool
    method: str
    bodies: dict
    rotors: dict
    base_residual: float
    standard: dict

    def to_dict(self) -> dict:
        return {"feasible": self.feasible, "method": self.method, "bodies": self.bodies, "rotors": self.rotors,
                "base_residual_max": self.base_residual, "standard_parameters": self.standard,
                "checked": ["mass > 0", "pseudo-inertia positive definite (⇒ COM inertia PD + triangle inequalities)",
                            "rotor inertia Ia ≥ 0", "A·π reproduces the identified base parameters"]}


def generic_prior(robot) -> np.ndarray:
    """A robot-agnostic prior: 1 kg at each joint origin, I = 0.01·1 kg·m², no rotor inertia."""
    body = np.array([1.0, 0, 0, 0, 0.01, 0, 0.01, 0, 0, 0.01])
    return np.concatenate([np.tile(body, robot.model.njoints - 1), np.zeros(robot.nv)])


# Scale of the rotor inertias in :func:`projection` with ``rotors_first``: so large against the links'
# (kg, kg·m, kg·m²) that a change the rotor inertias can make goes to them.
ROTORS_FIRST_SCALE = 1e3
# A held link's scale in the projection, relative to its own: it keeps the prior's values (the data
# see it only summed into its moving parent).
HELD_LINK_SCALE = 1e-6


def projection(robot, base, beta_hat: np.ndarray, prior: np.ndarray | None = None,
               rotors_first: bool = False, held: Sequence[str] = ()) -> tuple[np.ndarray, np.ndarray]:
    """(the standard parameters nearest ``prior`` (default: the model's own) that reproduce the base
    parameters ``beta_hat``: the weighted least-squares correction, each parameter measured
    relative to its scale (kg, kg·m, kg·m²); those scales (P,)). ``rotors_first``: the rotor
    inertias (which URDFs seldom hold) take up what they can before the links change. ``held``:
    joints held still in the fit: their links move rigidly with their parents, the data see only
    the sum, so the change goes to the moving links (a held link keeps the prior's values)."""
    A = base.combination_matrix()
    beta_hat = np.asarray(beta_hat, dtype=float)
    if beta_hat.shape != (A.shape[0],):
        raise FrictionIdError(f"expected {A.shape[0]} base parameters, got {beta_hat.shape}")
    pi0 = robot.parameters() if prior is None else np.asarray(prior, dtype=float)
    nb = robot.model.njoints - 1
    floor = np.concatenate([np.tile([1.0, 0.1, 0.1, 0.1] + [0.01] * 6, nb), np.full(robot.nv, 0.01)])
    D = np.maximum(np.abs(pi0), floor)
    if rotors_first:
        D[10 * nb :] = ROTORS_FIRST_SCALE
    for joint in held:
        k = robot.joints.index(joint)
        D[10 * k : 10 * k + 10] *= HELD_LINK_SCALE
    return pi0 + D * (np.linalg.pinv(A * D) @ (beta_hat - A @ pi0)), D


def check_consistency(robot, base, beta_hat: np.ndarray, prior: np.ndarray | None = None,
                      margin: float = 1e-6, prior_label: str = "given prior",
                      held: Sequence[str] = ()) -> ConsistencyReport:
    """Search standard parameters consistent with the identified base parameters ``beta_hat``
    (module doc). ``prior``: standard parameters to stay close to (default: the model's own),
    named ``prior_label`` in the report's method; ``held``: joints held still in the fit
    (:func:`projection`)."""
    from scipy.linalg import null_space
    from scipy.optimize import minimize

    A = base.combination_matrix()
    beta_hat = np.asarray(beta_hat, dtype=float)
    pi, D = projection(robot, base, beta_hat, prior, held=held)
    AD = A * D
    nb = robot.model.njoints - 1
    method = "least-squares projection of the " + ("model's parameters" if prior is None else prior_label)

    def margins(x: np.ndarray) -> np.ndarray:
        eig = [np.linalg.eigvalsh(pseudo_inertia(x[10 * k : 10 * k + 10]))[0] for k in range(nb)]
        return np.concatenate([np.array(eig) - margin, x[10 * nb :]])

    def margins_jac(x: np.ndarray) -> np.ndarray:
        """d margins / d π: ∂λ_min(J)/∂p_i = vᵀ·E_i·v (J is linear in p, v its eigenvector)."""
        G = np.zeros((nb + robot.nv, x.size))
        for k in range(nb):
            _, vecs = np.linalg.eigh(pseudo_inertia(x[10 * k : 10 * k + 10]))
            v = vecs[:, 0]
            G[k, 10 * k : 10 * k + 10] = np.einsum("i,kij,j->k", v, PSEUDO_INERTIA_BASIS, v)
        G[nb:, 10 * nb :] = np.eye(robot.nv)
        return G

    if np.any(margins(pi) < 0):
        N = D[:, None] * null_space(AD)  # A·(π + N·z) = A·π
        if N.shape[1]:
            W = N / D[:, None]
            H = W.T @ W
            res = minimize(lambda z: float(z @ H @ z), np.zeros(N.shape[1]), jac=lambda z: 2.0 * H @ z,
                           method="SLSQP",
                           constraints=[{"type": "ineq", "fun": lambda z: margins(pi + N @ z),
                                         "jac": lambda z: margins_jac(pi + N @ z) @ N}],
                           options={"maxiter": 300, "ftol": 1e-14})
            cand = pi + N @ res.x
            if np.sum(np.minimum(margins(cand), 0)) >= np.sum(np.minimum(margins(pi), 0)):
                pi = cand
            method += " + SLSQP repair in the null space of the base map"
    bodies = {j: body_report(pi[10 * k : 10 * k + 10]) for k, j in enumerate(robot.joints[:nb])}
    rotors = {j: {"Ia": float(pi[10 * nb + k]), "consistent": bool(pi[10 * nb + k] >= -1e-12)}
              for k, j in enumerate(robot.joints)}
    feasible = all(b["consistent"] for b in bodies.values()) and all(r["consistent"] for r in rotors.values())
    names = robot.parameter_names()
    return ConsistencyReport(feasible, method, bodies, rotors, float(np.max(np.abs(A @ pi - beta_hat))),
                             dict(zip(names, map(float, pi))))


def standard_record(robot, names: list[str], pi: np.ndarray) -> dict:
    """Per link {mass (kg), com (m, joint frame), inertia about the com (kg·m², joint frame axes:
    ixx ixy ixz iyy iyz izz), rotor, rotor_inertia (kg·m²)} of standard parameters ``pi``."""
    nb = robot.model.model.njoints - 1
    out = {}
    for k in range(nb):
        m, h, I_o = body_matrices(pi[10 * k : 10 * k + 10])
        c = h / m if m > 0 else np.zeros(3)
        Ic = I_o - m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
        rotor = names[10 * nb + k] if 10 * nb + k < len(names) else None
        out[robot.model.joints[k]] = {
            "mass": m, "com": c.tolist(),
            "inertia": {"ixx": Ic[0, 0], "ixy": Ic[0, 1], "ixz": Ic[0, 2], "iyy": Ic[1, 1], "iyz": Ic[1, 2],
                        "izz": Ic[2, 2]},
            "rotor": rotor.rsplit(".", 1)[0] if rotor else None,
            "rotor_inertia": float(pi[10 * nb + k]) if rotor else 0.0,
        }
    return out


def link_parameters(link: dict) -> np.ndarray:
    """[m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] (inertia about the link origin) of a
    :func:`standard_record` entry (mass, com, inertia about the com)."""
    m, c = float(link["mass"]), np.asarray(link["com"], dtype=float)
    t = link["inertia"]
    Ic = np.array([[t["ixx"], t["ixy"], t["ixz"]], [t["ixy"], t["iyy"], t["iyz"]], [t["ixz"], t["iyz"], t["izz"]]],
                  dtype=float)
    I_o = Ic + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    return np.array([m, *(m * c), I_o[0, 0], I_o[0, 1], I_o[1, 1], I_o[0, 2], I_o[1, 2], I_o[2, 2]])


def standard_from_record(robot, record: dict) -> np.ndarray:
    """Standard parameters π (P,) of a :func:`standard_record` (FrictionIdError when a link lacks)."""
    pi, rot = [], []
    for j in robot.model.joints[: robot.model.model.njoints - 1]:
        try:
            pi.append(link_parameters(record[j]))
            rot.append(float(record[j].get("rotor_inertia", 0.0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise FrictionIdError(f"standard parameters of link '{j}': missing or malformed {exc}") from None
    return np.concatenate(pi + [np.array(rot)])


def report_for_result(result: dict, system, prior: str = "model") -> dict:
    """Consistency report of an identification result (``IdentifyResult.to_dict()``) of a robot
    system; ``system``: its System (:func:`frictionid_core.systems.result_system`)."""
    if system.robot is None:
        raise FrictionIdError(f"system '{system.name}' is not a robot system (tx40, urdf:PATH): "
                              "no body parameters to check")
    info = system.robot
    try:
        beta = np.array([result["params"][n] for n in system.rigid_names])
    except KeyError as exc:
        raise FrictionIdError(f"result lacks base parameter {exc}") from None
    pri, label = (None, "") if prior == "model" else (generic_prior(info.model), "generic bodies")
    rows = info.rows or info.model
    rotors = rows.parameter_names()[-info.model.nv :]
    request = result.get("request") or {}
    if prior == "model" and result.get("standard_parameters"):  # a consistent fit's own witness
        pri, prior = standard_from_record(info, result["standard_parameters"]), "result"
        label = "result's own standard parameters (identify --consistent)"
    elif prior == "model" and request.get("known_rigid_body") and all(n in result["params"] for n in rotors):
        pri = np.array(rows.parameters(), dtype=float)  # the model's links and the identified rotor inertias
        pri[-info.model.nv :] = [result["params"][n] for n in rotors]
        prior, label = "result", "model's links with the result's rotor inertias (identify --known-rigid-body)"
    held = [j for j in (result.get("held_joints") or {}) if j in info.model.joints]
    rep = check_consistency(info.model, info.base, beta, pri, prior_label=label, held=held)
    return dict(rep.to_dict(), system=system.name, prior=prior)



# A link found from the data (fitted, or reconstructed from base parameters) is implausible against
# the robot model's when its mass is not positive or outside mass_ratio × the model's, its centre of
# mass lies further from the model's than com_offset_share_of_reach × the link's reach (the farthest
# child joint origin or the model's centre of mass; at least com_offset_min_m), or the trace of its
# inertia about the centre of mass is outside inertia_trace_ratio × the model's by more than
# inertia_trace_min_kgm2; a rotor inertia is implausible below 0 (by more than round-off,
# rotor_inertia_roundoff_kgm2: a reconstruction gives −1e-17 for 0). Recorded in the result's and the
# export's "plausibility" blocks.
PLAUSIBILITY = {"mass_ratio": [0.5, 2.0], "com_offset_share_of_reach": 0.5, "com_offset_min_m": 0.1,
                "inertia_trace_ratio": [0.2, 5.0], "inertia_trace_min_kgm2": 0.01,
                "rotor_inertia_roundoff_kgm2": 1e-9}


def link_reach(robot) -> dict[str, float]:
    """{moving joint: distance to its farthest child joint's origin (m), 0 without a child} of a RobotModel."""
    m = robot.model
    return {m.names[i]: max((float(np.linalg.norm(m.jointPlacements[c].translation))
                             for c in range(1, m.njoints) if m.parents[c] == i), default=0.0)
            for i in range(1, m.njoints)}


def link_plausibility(info, pi: np.ndarray, source: str) -> dict:
    """The ``plausibility`` block of standard parameters ``pi`` (the fit rows' order) of the robot
    ``info`` (a RobotInfo) against its model's own: {source, thresholds, links: {joint: {mass,
    model_mass, com_offset_m, com_limit_m, inertia_trace, model_inertia_trace, rotor_inertia,
    problems}}, implausible: [joint, …]}."""
    rows = info.rows or info.model
    names = rows.parameter_names()
    got = standard_record(info, names, np.asarray(pi, dtype=float))
    ref = standard_record(info, names, rows.parameters())
    reach = link_reach(info.model)
    t = PLAUSIBILITY
    links = {}
    for joint, link in got.items():
        model = ref[joint]
        problems = []
        m, m0 = float(link["mass"]), float(model["mass"])
        if m <= 0.0:
            problems.append(f"mass {m:.4g} kg ≤ 0 (the model's {m0:.4g} kg)")
        elif m0 > 0.0 and not t["mass_ratio"][0] <= m / m0 <= t["mass_ratio"][1]:
            problems.append(f"mass {m:.4g} kg vs the model's {m0:.4g} kg (outside ×{t['mass_ratio'][0]:g}–"
                            f"{t['mass_ratio'][1]:g})")
        offset = float(np.linalg.norm(np.subtract(link["com"], model["com"])))
        limit = max(t["com_offset_min_m"], t["com_offset_share_of_reach"]
                    * max(reach.get(joint, 0.0), float(np.linalg.norm(model["com"]))))
        if m > 0.0 and offset > limit:
            problems.append(f"centre of mass {offset:.3g} m from the model's (> {limit:.3g} m)")
        trace = sum(float(link["inertia"][k]) for k in ("ixx", "iyy", "izz"))
        trace0 = sum(float(model["inertia"][k]) for k in ("ixx", "iyy", "izz"))
        low, high = t["inertia_trace_ratio"]
        if abs(trace - trace0) > t["inertia_trace_min_kgm2"] and not low * trace0 <= trace <= high * trace0:
            problems.append(f"inertia about its centre of mass (trace) {trace:.3g} kg·m² vs the model's {trace0:.3g} "
                            f"(outside ×{low:g}–{high:g})")
        if link["rotor"] and link["rotor_inertia"] < -t["rotor_inertia_roundoff_kgm2"]:
            problems.append(f"rotor inertia {link['rotor_inertia']:.4g} kg·m² < 0")
        links[joint] = {"mass": m, "model_mass": m0, "com_offset_m": offset, "com_limit_m": limit,
                        "inertia_trace": trace, "model_inertia_trace": trace0,
                        "rotor_inertia": float(link["rotor_inertia"]), "problems": problems}
    return {"source": source, "thresholds": dict(t), "links": links,
            "implausible": [j for j, v in links.items() if v["problems"]]}


def plausibility_warnings(block: dict, prior: str | None = None, prior_weight: float = 1.0) -> list[str]:
    """One warning per implausible link of a :func:`link_plausibility` block, naming it, and the
    way out its fit has not taken: ``--consistent`` for links reconstructed from base parameters; a
    consistent fit holds at the model what the data do not determine (and, with ``prior`` ``urdf``,
    pulls every link toward it with ``prior_weight``), so its implausible link is one the data put
    there: the warning names the model to check, no flag that would bring it back."""
    what = block["source"]
    if what.startswith("the consistent fit"):
        under = f" even under --prior urdf (weight {prior_weight:g})" if prior == "urdf" else ""
        way = (f"the data determine it{under} (the consistent fit holds at the model only what they do not): check "
               "the robot model against the robot (a tool or payload on the arm, the URDF's units)")
    else:
        way = ("base parameters the data do not determine, or a model (URDF) far from the robot; --consistent holds "
               "what the data do not determine at the model")
    return [f"link of joint '{j}' ({what}) is implausible against the robot model: "
            + "; ".join(block["links"][j]["problems"]) + f" — {way}" for j in block["implausible"]]
