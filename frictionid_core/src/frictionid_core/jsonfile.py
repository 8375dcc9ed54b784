"""Result files: one atomic writer (JSON, or any text) and one reader (JSON, or YAML by suffix) with clear errors."""

from __future__ import annotations

import json
import os
from pathlib import Path

from frictionid_core.errors import FrictionIdError


def _plain(obj):
    """numpy scalars and arrays as plain Python values (``default`` of :func:`json.dumps`)."""
    if hasattr(obj, "tolist"):
        return obj.tolist()
    if hasattr(obj, "item"):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def write_json(path: str | Path, data, *, durable: bool = False) -> Path:
    """Write ``data`` as indented JSON to ``path`` atomically (:func:`write_text`).

    NaN/inf are written as the JSON extensions ``NaN``/``Infinity`` that Python's reader
    accepts. Returns the absolute path.
    """
    text = json.dumps(data, indent=2, allow_nan=True, default=_plain, ensure_ascii=False) + "\n"
    return write_text(path, text, durable=durable)


def write_text(path: str | Path, text: str, *, durable: bool = False) -> Path:
    """Write ``text`` to ``path`` atomically: a temporary file beside it, then ``os.replace``, so
    a reader never sees half a file and a crash never loses the old one.

    ``durable``: also fsync the file and its folder (files a restart must find, such as the
    node's active parameters). Folders are created as needed. Returns the absolute path.
    """
    path = Path(path).expanduser().absolute()
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
            if durable:
                f.flush()
                os.fsync(f.fileno())
        os.replace(tmp, path)
        if durable:
            try:  # make the rename itself durable
                fd = os.open(path.parent, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
            except OSError:
                pass
    except OSError as exc:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise FrictionIdError(f"{path}: cannot write ({exc.strerror or exc})") from None
    return path


YAML_SUFFIXES = (".yaml", ".yml")


def read_json(path: str | Path, what: str = "JSON") -> dict:
    """The JSON object in ``path`` (or the YAML mapping of a ``.yaml``/``.yml`` file, such as
    ``frictionid export --yaml``); FrictionIdError naming the file and ``what`` it should hold."""
    path = Path(path).expanduser()
    if path.suffix.lower() in YAML_SUFFIXES:
        from frictionid_core.yamlfile import read_yaml

        return read_yaml(path, what)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FrictionIdError(f"{path}: no such file (expected {what})") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise FrictionIdError(f"{path}: cannot read {what} ({exc})") from None
    if not isinstance(data, dict):
        raise FrictionIdError(f"{path}: not {what} (expected a JSON object)")
    return data

