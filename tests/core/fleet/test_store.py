"""The checksummed results store: every damaged line (bad bytes, not JSON, a forged value, a deleted
field, a torn last line) is set aside and reported by line, the sound records kept; one writer at a time."""

from __future__ import annotations

import json

import pytest

from frictionid_core.errors import FrictionIdError
from frictionid_core.fleet.store import RecordStore, checksum, latest_by_key


def _filled(path, n=5) -> list[dict]:
    records = [{"key": f"k{i}", "status": "ok", "value": 1.5 * i, "rows": [["j1", "Fc", 2.0 + i, 0.01]]}
               for i in range(n)]
    with RecordStore(path) as store:
        assert store.check().records == []
        for record in records:
            store.append(record)
    return records


def test_records_round_trip_with_their_checksum(tmp_path):
    records = _filled(tmp_path / "s.jsonl")
    lines = (tmp_path / "s.jsonl").read_text().splitlines()
    assert [json.loads(line)["checksum"] for line in lines] == [checksum(r) for r in records]
    with RecordStore(tmp_path / "s.jsonl") as store:
        found = store.check()
    assert found.records == records and found.set_aside == []


def test_every_damaged_line_is_set_aside_and_reported(tmp_path):
    path = tmp_path / "s.jsonl"
    records = _filled(path, 6)
    lines = path.read_bytes().split(b"\n")[:-1]
    lines[0] = lines[0].replace(b'"value":0.0', b'"value":-7.0')  # forged: checksum no longer matches
    forged_back = json.loads(lines[1])
    del forged_back["rows"]  # a deleted field
    lines[1] = json.dumps(forged_back).encode()
    lines[2] = lines[2][:10] + b"\xff\xfe" + lines[2][12:]  # bad bytes
    lines[3] = b"this is not json"
    torn = lines[5][:20]  # an interrupted write of the last record
    path.write_bytes(b"\n".join(lines[:5]) + b"\n" + torn)
    with RecordStore(path) as store:
        found = store.check()
    assert found.records == [records[4]]
    reasons = "\n".join(found.set_aside)
    for number, reason in ((1, "checksum mismatch"), (2, "checksum mismatch"), (3, "not UTF-8"), (4, "not JSON"),
                           (6, "incomplete last line")):
        assert f"s.jsonl line {number}: {reason}" in reasons, reasons
    assert len(found.set_aside) == 5
    set_aside = [json.loads(line) for line in (tmp_path / "s.set-aside.jsonl").read_text().splitlines()]
    assert [e["line"] for e in set_aside] == [1, 2, 3, 4, 6]
    assert "bytes_base64" in set_aside[2] and set_aside[3]["text"] == "this is not json"
    # the store now holds the sound record only; a new record appends cleanly after it
    with RecordStore(path) as store:
        assert store.check().set_aside == []
        store.append(records[0])
        assert [r["key"] for r in store.check().records] == ["k4", "k0"]


def test_a_record_the_caller_refuses_is_set_aside(tmp_path):
    path = tmp_path / "s.jsonl"
    _filled(path, 2)
    refuse_odd = lambda record: "odd value" if record["value"] == 1.5 else None
    with RecordStore(path, validate=refuse_odd) as store:
        found = store.check()
    assert [r["key"] for r in found.records] == ["k0"] and "line 2: odd value" in found.set_aside[0]


def test_read_leaves_the_file_and_a_second_writer_is_refused(tmp_path):
    path = tmp_path / "s.jsonl"
    _filled(path, 2)
    path.write_bytes(path.read_bytes() + b"[1, 2]\n")
    before = path.read_bytes()
    found = RecordStore(path).read()
    assert len(found.records) == 2 and "line 3: not a record" in found.set_aside[0]
    assert path.read_bytes() == before
    with RecordStore(path), pytest.raises(FrictionIdError, match="in use by another run"):
        with RecordStore(path):
            pass


def test_a_later_record_of_a_key_supersedes_an_earlier_one():
    first, retry = {"key": "a", "attempt": 1}, {"key": "a", "attempt": 2}
    assert latest_by_key([first, {"key": "b"}, retry])["a"] is retry
