"""Joint names as the node takes them and shows them in messages: the checks of a message's or a
parameter's names (:func:`name_problem`) and their display (:func:`shown_names`), shortened so
that a client's oversized name never reaches a log."""

from __future__ import annotations

MAX_NAME_CHARS = 256  # longest joint name the node takes in [characters]
SHOWN_NAME_CHARS = 40  # a longer name is shortened in messages and logs [characters]
SHOWN_NAMES = 20  # names listed in a message, the others counted


def shown(name: str) -> str:
    """``name`` quoted for a message, shortened past SHOWN_NAME_CHARS (a client's 1 MB name never
    reaches a log)."""
    name = str(name)
    if len(name) <= SHOWN_NAME_CHARS:
        return repr(name)
    return repr(name[:SHOWN_NAME_CHARS]) + f"…({len(name)} characters)"


def shown_names(names) -> str:
    """A list of joint names for a message: each :func:`shown`, at most SHOWN_NAMES of them."""
    names = list(names)
    more = f", … {len(names) - SHOWN_NAMES} more" if len(names) > SHOWN_NAMES else ""
    return "[" + ", ".join(shown(n) for n in names[:SHOWN_NAMES]) + more + "]"


def name_problem(names) -> str:
    """Why joint names are refused as the node's joints — none, an empty one, one over
    MAX_NAME_CHARS characters, one named twice — ""; when they are fine."""
    names = list(names)
    if not names:
        return "no joint names"
    if any(not n for n in names):
        return f"an empty joint name in {shown_names(names)}"
    long = [n for n in names if len(n) > MAX_NAME_CHARS]
    if long:
        return f"joint name {shown(long[0])} is longer than {MAX_NAME_CHARS} characters"
    return repeated_names(names)


def repeated_names(names) -> str:
    """Why a message naming a joint more than once is refused; "" when every name is unique."""
    if len(set(names)) == len(names):
        return ""
    repeated = [n for n in dict.fromkeys(names) if list(names).count(n) > 1]
    return f"message names joint(s) {shown_names(repeated)} more than once (it has {shown_names(names)})"
