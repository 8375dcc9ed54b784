"""What a parameter's name says: its kind (``joint_2/Fc_pos`` → ``Fc``), whether it can be
negative, and the names a user may give it by (``--fix``, ``--bounds``)."""

from __future__ import annotations

# Parameters that cannot be negative, by the last component of their name (after "/" and ".",
# without _pos/_neg): viscous, Coulomb and static friction, a mass (EMPS M, a link's exact m), an
# inertia (J, the TX40 joint-2 ZZ) and a rotor inertia (``<joint>.Ia``, not a regrouped ``IaR``).
NONNEGATIVE = ("Fv", "Fc", "Fs", "M", "m", "J", "ZZ", "Ia")


def parameter_kind(name: str) -> str:
    """The last component of a parameter name without branch suffix: ``joint_2/Fc_pos`` → ``Fc``,
    ``joint_3.Ia`` → ``Ia``."""
    return name.rsplit("/", 1)[-1].rsplit(".", 1)[-1].removesuffix("_pos").removesuffix("_neg")


def cannot_be_negative(name: str) -> bool:
    """True for a parameter that is physically ≥ 0 (see :data:`NONNEGATIVE`)."""
    return parameter_kind(name) in NONNEGATIVE


def parameter_keys(name: str) -> list[str]:
    """The names a user may give parameter ``name`` by, most specific first: the full name, the
    base name (``joint_2/vs_pos`` → ``vs_pos``) and the family (``vs``); a robot's rigid-body
    parameter ``<joint>.<p>`` (``R``-suffixed when others regroup into it) also as ``<joint>/<p>``,
    without the ``R``, and ``<p>`` for that parameter of every body."""
    base = name.rsplit("/", 1)[-1]
    keys = [name, base, base.removesuffix("_pos").removesuffix("_neg")]
    joint, dot, p = name.rpartition(".")
    if dot and "/" not in name:
        from frictionid_core.robots import BODY_PARAMS, ROTOR_PARAM

        stems = [p] + ([p[:-1]] if p.endswith("R") and p[:-1] in (*BODY_PARAMS, ROTOR_PARAM) else [])
        keys += [f"{joint}{sep}{stem}" for stem in stems for sep in "./"] + stems
    return list(dict.fromkeys(keys))
