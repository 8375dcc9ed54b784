"""Files a user gives: result files (JSON, or YAML by suffix: :func:`read_json`) and YAML files (drive
models, log layouts: :func:`read_yaml` and the checks they share), each refused with one clear line."""

from __future__ import annotations

import json
from pathlib import Path

from frictionid_core.errors import FrictionIdError, InputError


def read_yaml(path: str | Path, what: str) -> dict:
    """The YAML mapping in ``path``; InputError naming the file and ``what`` it should hold."""
    import yaml

    path = Path(path).expanduser()
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: no such file (expected {what})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read {what} ({exc})") from None
    except RecursionError:  # the YAML composer recurses once per nesting level
        raise InputError(f"{path}: cannot read {what} (its values are nested too deeply)") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise InputError(f"{path}: not valid YAML{where} ({getattr(exc, 'problem', None) or exc})") from None
    if not isinstance(data, dict):
        raise InputError(f"{path}: not {what} (expected a YAML mapping of keys)")
    return data


def check_keys(data: dict, known, where: str, required=()) -> None:
    """InputError naming ``where`` when ``data`` has a key outside ``known`` or lacks one of ``required``."""
    unknown = [str(k) for k in data if k not in known]
    if unknown:
        raise InputError(f"{where}: unknown key(s) {unknown}; known keys: {', '.join(known)}")
    missing = [k for k in required if k not in data]
    if missing:
        raise InputError(f"{where}: required key(s) {missing} missing")


def joint_names(value, where: str) -> tuple[str, ...]:
    """Key ``joints``: a non-empty list of distinct names, as a tuple; else InputError naming ``where``."""
    if (not isinstance(value, (list, tuple)) or not value
            or not all(isinstance(j, str) and j for j in value)):
        raise InputError(f"{where}: key 'joints' must be a non-empty list of joint names, got {value!r}")
    dup = sorted({j for j in value if value.count(j) > 1})
    if dup:
        raise InputError(f"{where}: key 'joints' repeats {dup}")
    return tuple(value)


YAML_SUFFIXES = (".yaml", ".yml")


def read_json(path: str | Path, what: str = "JSON") -> dict:
    """The JSON object in ``path`` (or the YAML mapping of a ``.yaml``/``.yml`` file, such as
    ``frictionid export --yaml``); FrictionIdError naming the file and ``what`` it should hold."""
    path = Path(path).expanduser()
    if path.suffix.lower() in YAML_SUFFIXES:
        return read_yaml(path, what)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FrictionIdError(f"{path}: no such file (expected {what})") from None
    except RecursionError:  # the json module recurses once per nesting level
        raise FrictionIdError(f"{path}: cannot read {what} (its values are nested too deeply)") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise FrictionIdError(f"{path}: cannot read {what} ({exc})") from None
    if not isinstance(data, dict):
        raise FrictionIdError(f"{path}: not {what} (expected a JSON object)")
    return data

