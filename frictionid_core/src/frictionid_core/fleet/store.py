"""Result stores that check themselves: append-only JSON lines, one record per line, each with its checksum.

A line is one JSON object: the record's fields and ``checksum`` = ``sha256:`` + the SHA-256 of the
record's canonical JSON (:func:`canonical`: keys sorted, no spaces, the checksum left out). Records are
appended and flushed to disk one at a time, so an interruption loses at most the line being written.

:meth:`RecordStore.check` reads the file and sets aside every line that is not a sound record: bytes
that are not UTF-8, text that is not a JSON object, a missing or wrong checksum (a field changed,
deleted or forged), a record the caller's ``validate`` refuses, an incomplete last line (an interrupted
write). Each goes to ``<name>.set-aside.jsonl`` beside the store with its line number and reason, the
store is rewritten without it, and the check returns one line per record set aside: the caller
recomputes what they held, so a damaged store costs the work of its damaged records, never a wrong
number or an internal error. :meth:`RecordStore.read` finds the same without changing the file.

One store serves the fleet (``fits.jsonl``) and the EMPS study (``runs.jsonl``). One run at a time
writes a store: :class:`RecordStore` holds an exclusive lock on ``.<name>.lock`` while it is open.
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from frictionid_core.errors import FrictionIdError

CHECKSUM = "checksum"
_PREFIX = "sha256:"

# validate(record) -> None when the record is sound, else what is wrong with it (one line).
Validator = Callable[[dict], "str | None"]


def canonical(record: dict) -> str:
    """The JSON text a checksum is taken of: keys sorted, no spaces, ASCII, NaN/Infinity allowed."""
    return json.dumps(record, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=True)


def checksum(record: dict) -> str:
    """``sha256:<hex>`` of the record's canonical JSON without its ``checksum`` field."""
    body = {k: v for k, v in record.items() if k != CHECKSUM}
    return _PREFIX + hashlib.sha256(canonical(body).encode("ascii")).hexdigest()


def sealed_line(record: dict) -> str:
    """The store line of ``record``: its canonical JSON with the checksum, and a newline."""
    if CHECKSUM in record:
        raise ValueError(f"a record may not carry its own '{CHECKSUM}' field")
    return canonical({**record, CHECKSUM: checksum(record)}) + "\n"


@dataclass
class StoreCheck:
    """What :meth:`RecordStore.check` found: the sound records in file order (without their
    checksum) and one line per record set aside."""

    records: list[dict] = field(default_factory=list)
    set_aside: list[str] = field(default_factory=list)


class RecordStore:
    """An append-only, checksummed JSON-lines file of records (see the module doc).

    Use it as a context manager: ``with RecordStore(path) as store: found = store.check(); …;
    store.append(record)``. ``required``: fields every record must have; ``validate``: a further
    check of a record's fields (returns None or what is wrong).
    """

    def __init__(self, path: str | Path, required: tuple[str, ...] = ("key",),
                 validate: Validator | None = None) -> None:
        self.path = Path(path).absolute()
        self.set_aside_path = self.path.with_name(self.path.stem + ".set-aside.jsonl")
        self.required = tuple(required)
        self.validate = validate
        self._lock_fd: int | None = None
        self._sink = None

    # -------------------------------------------------------------------- open / close
    def __enter__(self) -> RecordStore:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        lock_path = self.path.with_name(f".{self.path.name}.lock")
        try:
            import fcntl

            fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise FrictionIdError(f"{self.path}: in use by another run (lock {lock_path}); wait for it to "
                                      "finish") from None
        except OSError as exc:
            raise FrictionIdError(f"{self.path}: cannot lock ({exc.strerror or exc})") from None
        self._lock_fd = fd
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the append handle and release the lock."""
        if self._sink is not None:
            self._sink.close()
            self._sink = None
        if self._lock_fd is not None:
            os.close(self._lock_fd)  # closing the descriptor releases the flock
            self._lock_fd = None

    # -------------------------------------------------------------------- reading
    def read(self) -> StoreCheck:
        """The sound records, and one line per unsound one (left out), leaving the file as it is."""
        records, _, bad, _ = self._scan()
        return StoreCheck(records, [f"{self.path.name} line {n}: {problem}; left out" for n, _, problem in bad])

    def check(self) -> StoreCheck:
        """The sound records; every other line set aside (module doc) and reported. Inside ``with``."""
        if self._lock_fd is None:
            raise RuntimeError("RecordStore.check outside 'with RecordStore(…)'")
        records, kept, bad, torn = self._scan()
        if bad or torn:
            self._rewrite(kept, [_rejected(n, raw, problem) for n, raw, problem in bad])
        return StoreCheck(records, [f"{self.path.name} line {n}: {problem}; set aside in {self.set_aside_path.name}, "
                                    "its work will be redone" for n, _, problem in bad])

    def _scan(self) -> tuple[list[dict], list[bytes], list[tuple[int, bytes, str]], bool]:
        """(sound records, their lines, [(line number, bytes, problem)] of the others, whether the file
        ends without a newline)."""
        try:
            data = self.path.read_bytes()
        except FileNotFoundError:
            return [], [], [], False
        except OSError as exc:
            raise FrictionIdError(f"{self.path}: cannot read ({exc.strerror or exc})") from None
        records, kept, bad = [], [], []
        lines = data.split(b"\n")
        torn = lines.pop()  # the bytes after the last newline: an interrupted write
        numbered = [(n, raw, False) for n, raw in enumerate(lines, 1)]
        if torn.strip():
            numbered.append((len(lines) + 1, torn, True))
        for number, raw, is_torn in numbered:
            if not raw.strip():
                continue
            record, problem = self._parse(raw, is_torn)
            if problem is None:
                kept.append(raw)
                records.append(record)
            else:
                bad.append((number, raw, problem))
        return records, kept, bad, bool(torn)

    def _parse(self, raw: bytes, torn: bool) -> tuple[dict | None, str | None]:
        """(record without its checksum, None), or (None, what is wrong with the line)."""
        if torn:
            return None, "incomplete last line (a write was interrupted)"
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            return None, f"not UTF-8 text (byte {exc.start}: {raw[exc.start:exc.start + 1]!r})"
        try:
            record = json.loads(text)
        except ValueError as exc:
            return None, f"not JSON ({exc.msg} at column {exc.colno})"
        if not isinstance(record, dict):
            return None, f"not a record (a JSON {type(record).__name__}, not an object)"
        stated = record.pop(CHECKSUM, None)
        if stated is None:
            return None, "no checksum"
        if stated != checksum(record):
            return None, "checksum mismatch (a field was changed, removed or added)"
        missing = [k for k in self.required if k not in record]
        if missing:
            return None, f"lacks field(s) {missing}"
        problem = self.validate(record) if self.validate is not None else None
        if problem:
            return None, problem
        return record, None

    def _rewrite(self, kept: list[bytes], rejected: list[dict]) -> None:
        """Append ``rejected`` to the set-aside file, then replace the store by the ``kept`` lines."""
        from frictionid_core.files import write_text

        if rejected:
            try:
                with open(self.set_aside_path, "a", encoding="utf-8") as fh:
                    fh.write("".join(json.dumps(r, ensure_ascii=False) + "\n" for r in rejected))
                    fh.flush()
                    os.fsync(fh.fileno())
            except OSError as exc:
                raise FrictionIdError(f"{self.set_aside_path}: cannot write ({exc.strerror or exc})") from None
        write_text(self.path, "".join(raw.decode("utf-8") + "\n" for raw in kept), durable=True)

    # -------------------------------------------------------------------- writing
    def append(self, record: dict) -> None:
        """Append ``record`` (plain JSON values) with its checksum, flushed to disk."""
        if self._lock_fd is None:
            raise RuntimeError("RecordStore.append outside 'with RecordStore(…)'")
        line = sealed_line(record)
        try:
            if self._sink is None:
                self._sink = open(self.path, "a", encoding="utf-8")
            self._sink.write(line)
            self._sink.flush()
            os.fsync(self._sink.fileno())
        except OSError as exc:
            raise FrictionIdError(f"{self.path}: cannot append ({exc.strerror or exc})") from None


def _rejected(number: int, raw: bytes, problem: str) -> dict:
    """The set-aside entry of line ``number``: its reason and its text (or bytes, base64)."""
    entry = {"line": number, "reason": problem}
    try:
        entry["text"] = raw.decode("utf-8")
    except UnicodeDecodeError:
        entry["bytes_base64"] = base64.b64encode(raw).decode("ascii")
    return entry


def latest_by_key(records: list[dict]) -> dict[str, dict]:
    """{key: the last record of that key}: a later record (a retry, a refit) supersedes an earlier one."""
    return {r["key"]: r for r in records}
