"""Files written atomically: JSON (NaN/inf kept), text or bytes, through a temporary file beside the target."""

from __future__ import annotations

import json
import os
import re
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
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`write_bytes`); returns the absolute path."""
    return write_bytes(path, text.encode("utf-8"), durable=durable)


def write_bytes(path: str | Path, data: bytes, *, durable: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically: a temporary file beside it (:func:`temporary_name`),
    then ``os.replace``, so a reader never sees half a file and a crash or an interruption never
    loses the old one (the temporary file is removed on any failure, Ctrl-C included; one left
    by a killed process is removed by the next write into its folder: :func:`remove_orphans`).

    ``durable``: also fsync the file and its folder (files a restart must find, such as the
    node's active parameters). Folders are created as needed. Returns the absolute path.
    """
    path = Path(path).expanduser().absolute()
    tmp = path.with_name(temporary_name(path.name))
    moved = False
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_orphans(path.parent)
        with open(tmp, "wb") as f:
            f.write(data)
            if durable:
                f.flush()
                os.fsync(f.fileno())
        os.replace(tmp, path)
        moved = True
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
        raise FrictionIdError(f"{path}: cannot write ({exc.strerror or exc})") from None
    finally:
        if not moved:
            try:
                tmp.unlink()
            except OSError:
                pass
    return path


_TEMPORARY = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.tmp$")


def temporary_name(name: str, pid: int | None = None) -> str:
    """The name of the writer's temporary file for ``name``: ``.NAME.<pid>.tmp`` (``pid``: this process)."""
    return f".{name}.{os.getpid() if pid is None else pid}.tmp"


def remove_orphans(folder: str | Path) -> list[Path]:
    """Remove the temporary files of :func:`write_bytes` in ``folder`` whose process is gone (killed
    during a write); returns them."""
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = _TEMPORARY.match(entry.name)
        if match is None or not entry.is_file(follow_symlinks=False) or _alive(int(match["pid"])):
            continue
        try:
            os.unlink(entry.path)
            removed.append(Path(entry.path))
        except OSError:
            pass
    return removed


def _alive(pid: int) -> bool:
    """False only when no process ``pid`` exists (another user's process, or a pid the system
    cannot have, counts as alive: its file is left alone)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):
        return True
    return True
