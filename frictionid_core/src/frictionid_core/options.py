"""Choice lists the pre-processing and the simulator share, and :func:`check_choice`.

What an identification is asked for is :class:`frictionid_core.identification.IdentifyRequest`.
"""

from __future__ import annotations

from frictionid_core.errors import FrictionIdError

# Clocks of the EMPS closed-loop simulation (frictionid_core.emps_simulation): the recorded stamps,
# or the benchmark's constant period.
CLOCKS = ("true", "benchmark")
# Where identification takes q̇ from (frictionid_core.preprocess): the central difference of the
# filtered position, or the logged velocity low-passed the same way.
VELOCITY_SOURCES = ("position", "recorded")


def check_choice(field: str, value: str, choices, what: str | None = None) -> str:
    """``value`` if it is one of ``choices``, else FrictionIdError naming ``field``."""
    if value not in choices:
        raise FrictionIdError(f"{field}: unknown {what or field} '{value}'; choose one of {', '.join(choices)}")
    return value
