"""Errors that reach the user as one clear line."""


class FrictionIdError(Exception):
    """Base class of every error frictionid reports to a user (CLI exit code 2)."""


class InputError(FrictionIdError):
    """Bad input data: file, topic, joint, field or sample problems."""


class OptimError(FrictionIdError):
    """Bad optimiser request: unknown method, bad bounds or budget."""
