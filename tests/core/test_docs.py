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


# The markdown pages a user reads: the README, the docs/ pages and the packages' faces.
PAGES = (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "frictionid_core" / "README.md",
         ROOT / "frictionid_ros" / "README.md", ROOT / "bench" / "README.md")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
CODE_SPAN = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"\[[^\]\n]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*$", re.M)


def prose(path: Path) -> str:
    """The page without its code blocks and code spans (no link lives there)."""
    return CODE_SPAN.sub("", FENCE.sub("", path.read_text()))


def page_anchors(path: Path) -> set[str]:
    """The explicit ``<a id>`` anchors of a page and the anchors GitHub makes of its headings."""
    text = FENCE.sub("", path.read_text())
    slugs = {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-") for h in HEADING.findall(text)}
    return set(re.findall(r'<a id="([^"]+)"></a>', text)) | slugs


def relative_links() -> list[tuple[Path, str]]:
    """(page, link) of every link to a file of the repository, optionally with #anchor."""
    return [(page, link) for page in PAGES for link in LINK.findall(prose(page))
            if not re.match(r"[a-z]+:", link)]


def test_relative_links_point_to_existing_files_and_anchors():
    links = relative_links()
    assert len(links) >= 50, len(links)  # the pages link to each other: a broken pattern finds none
    broken = []
    for page, link in links:
        target, _, anchor = link.partition("#")
        path = (page.parent / target).resolve() if target else page
        if not path.exists():
            broken.append(f"{page.relative_to(ROOT)}: {link} (no such file)")
        elif anchor and (path.suffix != ".md" or anchor not in page_anchors(path)):
            broken.append(f"{page.relative_to(ROOT)}: {link} (no such anchor)")
    assert not broken, "\n".join(broken)


def test_readme_stays_a_page_for_users():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 250
