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

A law with internal state (LuGre's bristle deflection z, the generalized Maxwell-slip elements)
is not a dip law: its force is not Fv·v + level(|v|)·sign(v) with a dip linear in Fc, Fs. It
would declare ``states`` (refused today) and, instead of ``dip``, a scalar ``force(v, sign, p,
o, z, z_rate, exp, ratio_power, where)`` that reads one member's state ``z`` (its column of a
state table), writes its time derivative into ``z_rate`` and returns the force. LuGre:
ż = v − σ0·|v|·z/g(|v|), F = σ0·z + σ1·ż + σ2·v, with g the level of a dip law above (called,
not copied). The kernels keep their shape: ``members_friction`` calls ``force`` for each member
where it now composes the dip, with (ns, m) state tables that the EMPS simulator carries
through its RK4 stages beside the velocity; ``FrictionModel.torque`` integrates z along the
samples (it then needs their times); the identification fits such a law through the simulator
(output error), since the dip sums and the variable projection exist for dip laws only.
"""

from frictionid_core.friction.laws import DEFAULT_BOUNDS, FRICTIONS, LAWS, UNITS, FrictionLaw
from frictionid_core.friction.model import FrictionModel, all_models, get_model, smooth_sign

__all__ = ["DEFAULT_BOUNDS", "FRICTIONS", "LAWS", "UNITS", "FrictionLaw", "FrictionModel", "all_models", "get_model",
           "smooth_sign"]
