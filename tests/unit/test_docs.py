"""The README stays short and every relative link in it and in the docs site points at a file that exists.

``make docs`` (``mkdocs build --strict``) checks the links between pages of the site; it cannot see the
README, which GitHub renders from the repository's root, nor links from a page to the repository's files. This
test reads the Markdown itself, so a moved page, image or file breaks it before anyone follows the link.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
README_MAX_LINES = 200

# [text](target) and ![alt](target), with an optional "title"; the target has no spaces.
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
# pymdownx.snippets: --8<-- "path", read from the repository's root (mkdocs.yml base_path).
_SNIPPET = re.compile(r'^--8<--\s+"([^"]+)"\s*$')
_EXTERNAL = re.compile(r"^(?:[a-z][a-z0-9+.-]*:|//|#)", re.IGNORECASE)


def _prose_lines(text: str) -> list[str]:
    """The lines outside fenced code blocks, with inline code spans removed (their brackets are no links)."""
    lines, fenced = [], False
    for line in text.splitlines():
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
            continue
        if not fenced:
            lines.append(re.sub(r"`[^`]*`", "", line))
    return lines


def relative_links(text: str) -> list[str]:
    """The relative link targets of a Markdown text, without their #anchor or ?query."""
    targets = []
    for line in _prose_lines(text):
        for target in _LINK.findall(line):
            if not _EXTERNAL.match(target):
                targets.append(re.split(r"[#?]", target, maxsplit=1)[0])
    return targets


def snippet_paths(text: str) -> list[str]:
    return [m.group(1) for line in text.splitlines() if (m := _SNIPPET.match(line.strip()))]


def _pages() -> list[Path]:
    return [README, *sorted(DOCS.glob("*.md"))]


def test_readme_is_at_most_200_lines() -> None:
    # GIVEN the README a newcomer reads first
    # WHEN its lines are counted
    count = len(README.read_text(encoding="utf-8").splitlines())
    # THEN it fits in five minutes' reading; the rest belongs in docs/
    assert count <= README_MAX_LINES, (
        f"README.md has {count} lines (at most {README_MAX_LINES}): move detail to docs/"
    )


@pytest.mark.parametrize("page", _pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_points_at_an_existing_file(page: Path) -> None:
    # GIVEN a page of the README or the docs site
    text = page.read_text(encoding="utf-8")
    # WHEN each relative link is resolved against the page's own directory
    missing = [t for t in relative_links(text) if t and not (page.parent / t).exists()]
    # THEN every one exists in the repository
    assert not missing, f"{page.relative_to(ROOT)} links to files that do not exist: {missing}"


def test_included_files_exist() -> None:
    # GIVEN the pages that show a repository file as it is (pymdownx.snippets)
    # WHEN each included path is resolved from the repository's root
    missing = [
        f"{page.name}: {path}"
        for page in sorted(DOCS.glob("*.md"))
        for path in snippet_paths(page.read_text(encoding="utf-8"))
        if not (ROOT / path).is_file()
    ]
    # THEN each is there
    assert not missing, f"included files that do not exist: {missing}"


def test_every_image_in_docs_is_shown_by_a_page() -> None:
    # GIVEN the images kept in docs/
    images = {p.name for p in DOCS.iterdir() if p.suffix in {".png", ".jpg", ".svg"}}
    # WHEN the pages' links are collected
    linked = {
        Path(t).name for page in sorted(DOCS.glob("*.md")) for t in relative_links(page.read_text("utf-8"))
    }
    # THEN none is kept for nothing
    assert images <= linked, f"images in docs/ that no page shows: {sorted(images - linked)}"


@pytest.mark.parametrize(
    ("text", "links"),
    [
        (
            "see [the guide](docs/operator-guide.md#configuration) and ![map](map.png)",
            ["docs/operator-guide.md", "map.png"],
        ),
        ("[web](https://example.com) [anchor](#x) [mail](mailto:a@b.c)", []),
        ("`[not a link](nowhere.md)` but [one](here.md)", ["here.md"]),
        ("```\n[in code](nowhere.md)\n```\n[after](after.md)", ["after.md"]),
    ],
)
def test_relative_links_reads_markdown_links(text: str, links: list[str]) -> None:
    # GIVEN a Markdown text WHEN its relative links are read THEN only prose links outside code count
    assert relative_links(text) == links
