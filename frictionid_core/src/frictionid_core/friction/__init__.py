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
would declare ``states`` and, instead of ``dip``, a scalar ``force(v, sign, p, o, i, z, z_rate,
ops)`` that reads member i's state ``z[:, i]``, writes its time derivative into ``z_rate[:, i]``
and returns the force (LuGre: ż = v − σ0·|v|·z/g(v), F = σ0·z + σ1·ż + σ2·v with g a dip law's
level). The kernels keep their shape: :func:`~frictionid_core.friction.kernels.members_friction`
calls ``force`` where it now composes the dip, with the (ns, m) state arrays that the EMPS
simulator carries through its RK4 stages beside the velocity; ``FrictionModel.torque`` integrates
z along the samples (it then needs their times); the identification takes such a law through
the simulator (output error), since the dip sums exist for dip laws only.
"""

from frictionid_core.friction.laws import DEFAULT_BOUNDS, FRICTIONS, LAWS, UNITS, FrictionLaw
from frictionid_core.friction.model import FrictionModel, all_models, get_model, smooth_sign

__all__ = ["DEFAULT_BOUNDS", "FRICTIONS", "LAWS", "UNITS", "FrictionLaw", "FrictionModel", "all_models", "get_model",
           "smooth_sign"]
