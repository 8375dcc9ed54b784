"""Where a bench leaves its figures: ``bench/results/NAME.txt`` (the printed summary) and, when it
has them, ``bench/results/NAME.json`` (every figure)."""

from __future__ import annotations

from pathlib import Path

from frictionid_core.files import write_json, write_text

RESULTS = Path(__file__).resolve().parent / "results"


def publish(name: str, text: str, data: dict | None = None) -> None:
    """Print ``text`` and keep it as RESULTS/NAME.txt, with ``data`` as RESULTS/NAME.json."""
    if data is not None:
        write_json(RESULTS / f"{name}.json", data)
    write_text(RESULTS / f"{name}.txt", text + "\n")
    print(text)
