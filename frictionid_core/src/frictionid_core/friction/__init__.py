"""Friction laws and models (docs/reference.md#friction-models): each law written once.

* :mod:`~frictionid_core.friction.laws` holds every law's single definition: its parameters and
  its dip as plain scalar Python over a few elementary functions (exp, a power, a select) that
  the caller supplies, in the registry :data:`LAWS`. A new law goes there, and only there (plus
  its docs).
* :mod:`~frictionid_core.friction.model`: :class:`FrictionModel` runs those functions on numpy
  arrays (numpy's exp and power: the reference arithmetic).
* :mod:`~frictionid_core.friction.kernels` (numba, imported on first use) compiles the same
  functions into the identification's dip sums (with a vectorised exp) and the friction of the
  EMPS simulator's members (libm's exp), one cached kernel per law.

A law with internal states (LuGre's bristle deflection, the generalized Maxwell-slip elements)
is a *dynamic* law: its level is a dip law's (the Stribeck level with δ = 2, called from
``stribeck_dip``), and its element states, driven by the motion, give the friction through the
scalar functions ``substeps``, ``bristle_advance`` and ``bristle_force`` of
:mod:`~frictionid_core.friction.laws` (each law adds only its elements' ``stiffness`` and its
``damping``). :mod:`~frictionid_core.friction.kernels` compiles them into ``state_rows`` (the
states along a log); :mod:`~frictionid_core.friction.states` runs them under numpy, one sample at
a time (:class:`StateFriction`: the node's feed-forward). ``FrictionModel.torque`` of a dynamic
law takes the samples' times; the identification fits its static part first, then every
parameter on every row (:mod:`frictionid_core.identification.dynamic_fit`). The EMPS simulator
and the dip sums take static laws only.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "dip_ends", "dip_sums", "kernels", "law_parts", "members_friction", "SOURCE_DIGEST",
    ), "frictionid_core.friction.kernels"),
    **dict.fromkeys((
        "DEFAULT_BOUNDS", "FrictionLaw", "FRICTIONS", "LAWS", "LUGRE_DELTA", "parameter_base", "STATIC_FRICTIONS",
        "UNITS",
    ), "frictionid_core.friction.laws"),
    **dict.fromkeys((
        "all_models", "elements_of", "FrictionModel", "get_model", "smooth_sign",
    ), "frictionid_core.friction.model"),
    **dict.fromkeys(("joint_state_rows", "resets", "StateFriction"), "frictionid_core.friction.states"),
}

__all__ = ["DEFAULT_BOUNDS", "FRICTIONS", "FrictionLaw", "FrictionModel", "LAWS", "LUGRE_DELTA", "SOURCE_DIGEST",
           "STATIC_FRICTIONS", "StateFriction", "UNITS", "all_models", "dip_ends", "dip_sums", "elements_of",
           "get_model", "joint_state_rows", "kernels", "law_parts", "members_friction", "parameter_base",
           "resets", "smooth_sign"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
