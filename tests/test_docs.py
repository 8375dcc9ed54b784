"""docs/: every specification section the code cites is mapped to an anchor that exists."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "docs" / "reference.md"
SPEC_MAP = ROOT / "docs" / "spec_map.txt"
CODE_DIRS = ("frictionid_core", "frictionid_ros", "bench", "tools", "tests")
CITATION = re.compile("SPEC" + r" ?§ ?([0-9.]*[0-9](?: step [0-9]+)?)")


def anchors() -> set[str]:
    ids = re.findall(r'<a id="([a-z0-9-]+)"></a>', REFERENCE.read_text())
    assert len(ids) == len(set(ids)), "duplicate anchors"
    return set(ids)


def spec_map() -> dict[str, str]:
    out = {}
    for line in SPEC_MAP.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            section, target = (s.strip() for s in line.split("->"))
            out[CITATION.fullmatch(section).group(1)] = target
    return out


def test_every_cited_section_is_mapped():
    cited = set()
    for d in CODE_DIRS:
        for path in (ROOT / d).rglob("*.py"):
            if path != Path(__file__).resolve():
                cited |= set(CITATION.findall(path.read_text()))
    assert cited <= set(spec_map()), f"unmapped: {sorted(cited - set(spec_map()))}"


def test_map_and_page_links_point_to_existing_anchors():
    ids = anchors()
    for section, target in spec_map().items():
        page, _, anchor = target.partition("#")
        assert page == "docs/reference.md" and anchor in ids, (section, target)
    links = set(re.findall(r"\]\(#([a-z0-9-]+)\)", REFERENCE.read_text()))
    assert links and links <= ids, sorted(links - ids)
