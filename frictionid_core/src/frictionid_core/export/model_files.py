"""Export a robot identification result: URDF, MuJoCo MJCF and a YAML parameters file.

The standard parameters exported are the result's own (``identify --consistent``) or, for an
unconstrained result, the consistent witness :func:`~frictionid_core.consistency.check.report_for_result`
finds; when it has none that is consistent and plausible, the consistent links whose base parameters lie
within :data:`WITHIN_SIGMAS` of the result's calibrated σ, the directions those σ do not determine held at
the model's (:func:`~frictionid_core.consistency.links_within_sigma`); a result with neither is refused
unless forced (the error names the link).

* URDF: a ``urdf:PATH`` robot's own file with each moving joint's child link given the
  identified inertial (mass, centre of mass, inertia about it, in the link = joint frame) and
  the inertials of links fixed to it removed (Pinocchio merges them into the same body); the
  built-in TX40 gets a URDF written from its Pinocchio model. Every moving joint gets
  ``<dynamics damping="Fv" friction="Fc"/>``.
* MJCF: MuJoCo's compilation of that URDF (visual and collision geometry left out) with joint
  ``damping`` = Fv (N·m·s/rad), ``frictionloss`` = Fc (N·m), ``armature`` = rotor inertia (kg·m²).
* YAML: the result itself (what ``frictionid validate`` and the node read), plus ``export``.

With friction on the motors (a coupled drive) each joint gets the friction of its own motor
(the motor with that joint's ratio). MuJoCo and URDF joints have viscous + Coulomb friction only:
a Stribeck, Tustin or Threlfall law (or an asymmetric one) exports the damping and frictionloss
≥ 0 that match it best in least squares over the speeds of its data (the result's
``velocity_range``, both branches alike), and the export says how much of the law that loses
(the RMS difference over those speeds relative to the law's RMS, %); a symmetric Coulomb law
exports its Fv and Fc as they are. A dynamic law (LuGre, Maxwell-slip) exports the match of its
sliding limit (the Stribeck law with δ = 2) and its pre-sliding states are lost (``lost``: MuJoCo
and URDF hold no friction state), as is a load-dependent Coulomb level (``Fc_load``).

Links far from the robot model's (:func:`~frictionid_core.consistency.check.link_plausibility`)
are refused like inconsistent ones unless forced.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from frictionid_core.consistency import (
    body_report,
    link_plausibility,
    links_within_sigma,
    report_for_result,
    standard_record,
)
from frictionid_core.drive import friction_rows
from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import elements_of, get_model
from frictionid_core.robots import PAYLOAD, Payload, link_frame, link_name, payload_link
from frictionid_core.safety import payload_refusals, result_refusals
from frictionid_core.systems import result_system

# Links reconstructed for a result without --consistent reproduce each base parameter within this many of
# its calibrated σ (a robot has ~40: 4 σ leaves a right fit out 1 time in 400), or the result is refused
# as its data show it (its exact witness's problems).
WITHIN_SIGMAS = 4.0
# MuJoCo joint attribute ← friction parameter
MUJOCO_FRICTION = {"damping": "Fv", "frictionloss": "Fc"}
# Speeds a law is matched over: this many, evenly spread over the data's range; without a range in
# the result (written before it was recorded), DEFAULT_SPEEDS (rad/s or m/s).
MATCH_SPEEDS = 2000
DEFAULT_SPEEDS = (0.0, 1.0)


@dataclass
class ExportData:
    """What the exporters write.

    Attributes:
        robot: the RobotModel.
        links: per moving joint :func:`standard_record` entry (mass, com, inertia, rotor_inertia).
        friction: {joint: {"Fv", "Fc"}} (N·m·s/rad, N·m): what MuJoCo and the URDF get.
        match: {joint: {law, speeds [lo, hi], loss_pct}}: how ``friction`` matches the fitted law.
        plausibility: the exported links against the robot model's (thresholds included).
        feasible: the consistency and plausibility verdict; ``problems`` the failing links/parameters.
        source: ``urdf:PATH`` file of the robot, or None (built-in model).
        payload: a payload fixed to one of its links (a fixed link ``payload`` in the URDF and
            MuJoCo model, the ``payload`` block of the YAML), or None.
        note: how the links were built when not from an exact witness (:func:`export_data`), or None.
    """

    robot: object
    links: dict
    friction: dict
    feasible: bool
    problems: list[str]
    source: str | None
    result: dict
    match: dict
    plausibility: dict
    payload: Payload | None = None
    note: str | None = None


def export_data(result: dict, system, force: bool = False, payload: Payload | None = None) -> ExportData:
    """Standard parameters and friction of ``result`` (an identification of the robot ``system``)
    and ``payload`` (on one of its links); FrictionIdError for an inconsistent result or payload
    unless ``force``, and for a payload on a link the robot lacks."""
    if system.robot is None:
        raise FrictionIdError(f"system '{system.name}' is not a robot system (tx40, urdf:PATH): nothing to export")
    info = system.robot
    rep = report_for_result(result, system)
    names = (info.rows or info.model).parameter_names()
    pi = np.array([rep["standard_parameters"][n] for n in info.model.parameter_names()])
    problems, plausibility = _link_problems(info, pi)
    note = None
    if problems and not result.get("standard_parameters"):  # no exact witness: the links within the result's σ
        try:
            within, worst = links_within_sigma(info, *_base_and_sigma(result, system))
        except FrictionIdError:  # the solver found none: the exact witness's problems stand
            within, worst = pi, np.inf
        again, checked = _link_problems(info, within)
        if not again and worst <= WITHIN_SIGMAS:
            pi, problems, plausibility = within, again, checked
            note = (f"links reconstructed within {worst:.2g} calibrated σ (std_robust) of the base parameters: no "
                    "consistent, plausible links reproduce them exactly; the directions they do not determine at "
                    "the model's")
    links = standard_record(info, names, pi)
    friction, match = _joint_friction(result, info)
    for j, f in match.items():
        problems += [f"joint '{j}' {k} {v:.4g} < 0" for k, v in f["fitted"].items() if v < 0]
    if payload is not None:
        link_frame(info.model, payload.link)  # a link of this robot
        if not payload.feasible:
            problems.append(f"payload on '{payload.link}' (mass {payload.mass:.4g} kg): its pseudo-inertia is not "
                            "positive definite")
    if problems and not force:
        way_out = ("the consistent fit holds at the model only what the data do not determine, so the data put these "
                   "links there: check the robot model against the robot (a tool or payload on the arm, the URDF's "
                   "units), or export anyway with --force" if result.get("standard_parameters")
                   else "identify with --consistent, or export anyway with --force")
        raise FrictionIdError("refused to export an inconsistent or implausible result: " + "; ".join(problems)
                              + f" ({way_out})")
    source = system.name.split(":", 1)[1] if system.name.startswith("urdf:") else None
    return ExportData(info.model, links, friction, not problems, problems, source, result, match, plausibility,
                      payload, note)


def _link_problems(info, pi: np.ndarray) -> tuple[list[str], dict]:
    """(what keeps standard parameters ``pi`` of the robot ``info`` from export: links not physically
    consistent, negative rotor inertias, links implausible against the model; the plausibility block)."""
    nb = info.model.model.njoints - 1
    problems = []
    for k, joint in enumerate(info.model.joints[:nb]):
        body = body_report(pi[10 * k : 10 * k + 10])
        if not body["consistent"]:
            problems.append(f"link '{joint}' (mass {body['mass']:.4g} kg, pseudo-inertia λmin "
                            f"{body['pseudo_inertia_min_eig']:.3g})")
    problems += [f"rotor of '{j}' (Ia {a:.4g} kg·m²)" for j, a in zip(info.model.joints, pi[10 * nb :]) if a < -1e-12]
    plausibility = link_plausibility(info, pi, "exported")
    problems += [f"link of joint '{j}' implausible against the model ("
                 + "; ".join(plausibility["links"][j]["problems"]) + ")" for j in plausibility["implausible"]]
    return problems, plausibility


def _base_and_sigma(result: dict, system) -> tuple[np.ndarray, np.ndarray]:
    """(the base parameters of ``result``, their calibrated σ (``std_robust``, else ``std``; NaN where
    none: not determined))."""
    sigma = result.get("std_robust") or result.get("std") or {}
    beta = np.array([result["params"][n] for n in system.rigid_names], dtype=float)
    return beta, np.array([float(sigma.get(n, np.nan)) for n in system.rigid_names], dtype=float)


def _joint_friction(result: dict, info) -> tuple[dict, dict]:
    """({joint: {Fv, Fc}} of a result: per joint, or per motor mapped to each motor's own joint;
    {joint: {law, speeds, loss_pct, fitted: the law's own Fv and Fc}}): see the module doc."""
    params = result["params"]
    rows = friction_rows(result)
    owner = dict(zip(info.rows.motors, info.model.joints)) if info.rows is not None else {}
    law = get_model(result["friction"], bool(result["asymmetric"]), elements_of(result["friction"], result["params"]))
    ranges = result.get("velocity_range") or {}
    out, match = {}, {}
    for row in rows:
        joint = owner.get(row, row)
        prefix = f"{row}/" if len(rows) > 1 else ""
        values = np.array([params[prefix + n] for n in law.names], dtype=float)
        fitted = {k: float(np.mean([params[prefix + n] for n in law.names if n.split("_")[0] == k]))
                  for k in ("Fv", "Fc", "Fs") if k in law.branch_names}
        speeds = [float(v) for v in ranges.get(row, DEFAULT_SPEEDS)]
        entry = {"law": law.label, "speeds": speeds, "speeds_from": "data" if row in ranges else "assumed",
                 "fitted": fitted}
        lost = [f"{law.label}'s pre-sliding states ({', '.join(law.branch_names[4:])}): the sliding limit is "
                "matched"] if law.is_dynamic else []
        if prefix + "Fc_load" in params:
            lost.append(f"its load-dependent Coulomb level (Fc_load {params[prefix + 'Fc_load']:.6g})")
        if lost:
            entry["lost"] = "; ".join(lost)
        if law.is_dynamic:
            out[joint] = _match(*law.static_equivalent(values), speeds)
            entry["loss_pct"] = _loss(*law.static_equivalent(values), speeds, out[joint])
        elif law.name == "coulomb" and not law.asymmetric:
            out[joint] = {"Fv": max(fitted["Fv"], 0.0), "Fc": max(fitted["Fc"], 0.0)}
            entry["loss_pct"] = 0.0 if min(fitted.values()) >= 0 else _loss(law, values, speeds, out[joint])
        else:
            out[joint] = _match(law, values, speeds)
            entry["loss_pct"] = _loss(law, values, speeds, out[joint])
        match[joint] = entry
    return out, match


def _law_magnitudes(law, values: np.ndarray, speeds) -> tuple[np.ndarray, np.ndarray]:
    """(speeds (2n,), the law's friction magnitude at +v and at −v over the speeds (2n,))."""
    v = np.linspace(speeds[0], speeds[1], MATCH_SPEEDS)
    v = v[v > 0.0] if np.any(v > 0.0) else np.array([speeds[1] or 1.0])
    return np.concatenate([v, v]), np.concatenate([law.torque(values, v), -law.torque(values, -v)])


def _match(law, values: np.ndarray, speeds) -> dict:
    """The Fv, Fc ≥ 0 whose viscous + Coulomb friction matches the law best (least squares over
    both branches at the speeds)."""
    from scipy.optimize import nnls

    v, f = _law_magnitudes(law, values, speeds)
    (fv, fc), _ = nnls(np.column_stack([v, np.ones_like(v)]), f)
    return {"Fv": float(fv), "Fc": float(fc)}


def _loss(law, values: np.ndarray, speeds, linear: dict) -> float:
    """RMS of (law − Fv·|v| − Fc) over both branches at the speeds, % of the law's RMS."""
    v, f = _law_magnitudes(law, values, speeds)
    scale = float(np.sqrt(np.mean(f**2))) or 1.0
    return 100.0 * float(np.sqrt(np.mean((f - linear["Fv"] * v - linear["Fc"]) ** 2))) / scale


# ------------------------------------------------------------------------------------------ URDF
def _fmt(x) -> str:
    return " ".join(repr(float(v)) for v in np.atleast_1d(x))


def _inertial(link: dict) -> ET.Element:
    el = ET.Element("inertial")
    ET.SubElement(el, "origin", xyz=_fmt(link["com"]), rpy="0 0 0")
    ET.SubElement(el, "mass", value=_fmt(link["mass"]))
    ET.SubElement(el, "inertia", **{k: _fmt(v) for k, v in link["inertia"].items()})
    return el


def _set_dynamics(joint: ET.Element, friction: dict) -> None:
    for old in joint.findall("dynamics"):
        joint.remove(old)
    ET.SubElement(joint, "dynamics", damping=_fmt(max(friction["Fv"], 0.0)), friction=_fmt(max(friction["Fc"], 0.0)))


def urdf_text(data: ExportData) -> str:
    """The URDF of :mod:`this module's doc <frictionid_core.export.model_files>`."""
    root = _urdf_from_file(data) if data.source else _urdf_from_model(data)
    if data.payload is not None:
        if any(el.get("name") == PAYLOAD for el in root.findall("link")):
            raise FrictionIdError(f"the robot's URDF has a link named '{PAYLOAD}' already: cannot add the payload's")
        root.extend(payload_link(data.payload, data.payload.link))
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def _urdf_from_file(data: ExportData) -> ET.Element:
    try:
        root = ET.parse(data.source).getroot()
    except (OSError, ET.ParseError) as exc:
        raise FrictionIdError(f"{data.source}: cannot read the robot's URDF ({exc})") from None
    joints = {j.get("name"): j for j in root.findall("joint")}
    links = {lk.get("name"): lk for lk in root.findall("link")}
    children: dict[str, list[ET.Element]] = {}
    for j in joints.values():
        children.setdefault(j.find("parent").get("link"), []).append(j)
    for name, link in data.links.items():
        joint = joints.get(name)
        if joint is None:
            raise FrictionIdError(f"{data.source}: no joint '{name}' in the URDF")
        child = links[joint.find("child").get("link")]
        for el in child.findall("inertial"):
            child.remove(el)
        child.insert(0, _inertial(link))
        _set_dynamics(joint, data.friction.get(name, {"Fv": 0.0, "Fc": 0.0}))
        stack = list(children.get(child.get("name"), []))
        while stack:  # links fixed to this body: Pinocchio merges them into it, the export holds the sum
            j = stack.pop()
            if j.get("type") != "fixed":
                continue
            fixed = links[j.find("child").get("link")]
            for el in fixed.findall("inertial"):
                fixed.remove(el)
            stack += children.get(fixed.get("name"), [])
    return root


def _urdf_from_model(data: ExportData) -> ET.Element:
    """A URDF of a fixed-base Pinocchio model of revolute/prismatic joints along x, y or z."""
    import pinocchio as pin

    robot = data.robot
    m = robot.model
    root = ET.Element("robot", name=robot.name)
    ET.SubElement(root, "link", name="base_link")
    axes = {"X": "1 0 0", "Y": "0 1 0", "Z": "0 0 1"}
    for i in range(1, m.njoints):
        name = m.names[i]
        short = m.joints[i].shortname()  # JointModelRZ, JointModelPX, …
        kind, axis = short[-2], short[-1]
        if kind not in "RP" or axis not in axes:
            raise FrictionIdError(f"joint '{name}' ({short}): only revolute/prismatic joints along x, y or z export "
                                  "to a URDF from a built-in model")
        link = ET.SubElement(root, "link", name=link_name(name))
        link.append(_inertial(data.links[name]))
        k = i - 1
        j = ET.SubElement(root, "joint", name=name, type="revolute" if kind == "R" else "prismatic")
        M = m.jointPlacements[i]
        ET.SubElement(j, "origin", xyz=_fmt(M.translation), rpy=_fmt(pin.rpy.matrixToRpy(M.rotation)))
        ET.SubElement(j, "parent", link="base_link" if m.parents[i] == 0 else link_name(m.names[m.parents[i]]))
        ET.SubElement(j, "child", link=link_name(name))
        ET.SubElement(j, "axis", xyz=axes[axis])
        ET.SubElement(j, "limit", lower=_fmt(robot.lower[k]), upper=_fmt(robot.upper[k]),
                      effort=_fmt(m.effortLimit[k]), velocity=_fmt(robot.velocity_limit[k]))
        _set_dynamics(j, data.friction.get(name, {"Fv": 0.0, "Fc": 0.0}))
    return root


# ----------------------------------------------------------------------------------------- MuJoCo
def mujoco_text(data: ExportData, urdf: str | None = None) -> str:
    """MJCF of the URDF (:func:`urdf_text`) compiled by MuJoCo, joint damping/frictionloss/armature set."""
    import mujoco

    root = ET.fromstring(urdf or urdf_text(data))
    for link in root.findall("link"):
        for tag in ("visual", "collision"):
            for el in link.findall(tag):
                link.remove(el)
    for el in root.findall("transmission") + root.findall("gazebo"):
        root.remove(el)
    mj = root.find("mujoco")
    mj = ET.SubElement(root, "mujoco") if mj is None else mj
    ET.SubElement(mj, "compiler", fusestatic="false", discardvisual="true")
    try:
        spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
        for j in spec.joints:
            if j.name not in data.links:
                continue
            f = data.friction.get(j.name, {"Fv": 0.0, "Fc": 0.0})
            j.damping = [max(f["Fv"], 0.0), 0.0, 0.0]  # MuJoCo 4: linear damping, then polynomial terms
            j.frictionloss = max(f["Fc"], 0.0)
            j.armature = max(float(data.links[j.name]["rotor_inertia"]), 0.0)
        spec.compile()
        text = _exact_values(spec.to_xml(), data)
        mujoco.MjModel.from_xml_string(text)  # what we write compiles
        return text
    except Exception as exc:  # mujoco raises ValueError with its compiler's message
        raise FrictionIdError(f"MuJoCo could not compile the exported model: {' '.join(str(exc).split())}") from None


def _exact_values(xml: str, data: ExportData) -> str:
    """MJCF ``xml`` with each identified body's inertial (pos, mass, fullinertia) and joint
    damping/frictionloss/armature written at full precision (MuJoCo's writer keeps 6 digits)."""
    root = ET.fromstring(xml)
    for body in root.iter("body"):
        if data.payload is not None and body.get("name") == PAYLOAD:
            _set_inertial(body, data.payload.com, data.payload.mass, data.payload.inertia)
        joint = body.find("joint")
        if joint is None or joint.get("name") not in data.links:
            continue
        name = joint.get("name")
        link, f = data.links[name], data.friction.get(name, {"Fv": 0.0, "Fc": 0.0})
        t = link["inertia"]
        joint.set("damping", _fmt(max(f["Fv"], 0.0)))
        joint.set("frictionloss", _fmt(max(f["Fc"], 0.0)))
        joint.set("armature", _fmt(max(float(link["rotor_inertia"]), 0.0)))
        _set_inertial(body, link["com"], link["mass"], [[t["ixx"], t["ixy"], t["ixz"]], [t["ixy"], t["iyy"], t["iyz"]],
                                                        [t["ixz"], t["iyz"], t["izz"]]])
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def _set_inertial(body: ET.Element, com, mass: float, inertia) -> None:
    """The MJCF ``<inertial>`` of ``body`` at full precision: centre of mass, mass, inertia (3×3) about it."""
    old = body.find("inertial")
    if old is not None:
        body.remove(old)
    I = np.asarray(inertia, dtype=float)
    body.insert(0, ET.Element("inertial", pos=_fmt(com), mass=_fmt(mass),
                              fullinertia=_fmt([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])))


# ------------------------------------------------------------------------------------------- YAML
def yaml_text(data: ExportData) -> str:
    """The result as YAML (readable by ``frictionid validate`` and the node) with an ``export`` note;
    FrictionIdError naming the parameter and the limit when the safety screen refuses its
    parameters (:func:`frictionid_core.safety.result_refusals`: the robot's effort and velocity limits)
    or its payload (:func:`frictionid_core.safety.payload_refusals`)."""
    refused = result_refusals(data.result)
    if not refused and data.payload is not None:
        refused = payload_refusals(data.payload, result_system(data.result))
    if refused:
        raise FrictionIdError("refused to export the parameters: the safety screen refuses them: "
                              + "; ".join(refused))
    import json

    import yaml

    plain = json.loads(json.dumps(data.result, default=float))
    plain["export"] = {"feasible": data.feasible, "problems": data.problems,
                       "joint_friction": data.friction, "friction_match": data.match,
                       "plausibility": data.plausibility,
                       "rotor_inertia": {j: v["rotor_inertia"] for j, v in data.links.items()}}
    if data.note:
        plain["export"]["links_note"] = data.note
    if data.payload is not None:
        plain["payload"] = data.payload.to_dict()
    return yaml.safe_dump(plain, sort_keys=False, allow_unicode=True)
