"""docs/: every reference-page anchor the code and the READMEs cite is an anchor of the page."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "docs" / "reference.md"
CODE_DIRS = ("frictionid_core", "frictionid_ros", "bench", "tools", "tests", "examples")
CITATION = re.compile(r"docs/reference\.md#([a-z0-9-]+)")


def anchors() -> set[str]:
    ids = re.findall(r'<a id="([a-z0-9-]+)"></a>', REFERENCE.read_text())
    assert len(ids) == len(set(ids)), "duplicate anchors"
    return set(ids)


def cited() -> dict[str, set[str]]:
    """{anchor: files citing it} over the code, the configuration files and the READMEs."""
    out: dict[str, set[str]] = {}
    paths = [p for d in CODE_DIRS for ext in ("*.py", "*.yaml", "*.md") for p in (ROOT / d).rglob(ext)]
    for path in paths + [ROOT / "README.md"]:
        for anchor in CITATION.findall(path.read_text()):
            out.setdefault(anchor, set()).add(str(path.relative_to(ROOT)))
    return out


def test_code_cites_the_reference_page_not_an_outside_document():
    refs = cited()
    assert len(refs) >= 8, refs  # the models, protocols and reference numbers the code relies on
    missing = {a: sorted(f) for a, f in refs.items() if a not in anchors()}
    assert not missing, missing


def test_page_links_point_to_existing_anchors():
    links = set(re.findall(r"\]\(#([a-z0-9-]+)\)", REFERENCE.read_text()))
    assert links and links <= anchors(), sorted(links - anchors())
