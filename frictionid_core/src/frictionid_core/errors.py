"""Errors that reach the user as one clear line, and :func:`check_choice`."""


class FrictionIdError(Exception):
    """Base class of every error frictionid reports to a user (CLI exit code 2)."""


class InputError(FrictionIdError):
    """Bad input data: file, topic, joint, field or sample problems."""


class OptimError(FrictionIdError):
    """Bad optimiser request: unknown method, bad bounds or budget."""


def check_choice(field: str, value: str, choices, what: str | None = None) -> str:
    """``value`` if it is one of ``choices``, else FrictionIdError naming ``field``."""
    if value not in choices:
        raise FrictionIdError(f"{field}: unknown {what or field} '{value}'; choose one of {', '.join(choices)}")
    return value
