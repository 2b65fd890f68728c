"""The documentation stands on its own: every relative link of README.md and docs/*.md resolves
to a file inside the repository (and every #anchor to a heading of its page), every repository
path a page names in code exists, and no page points outside the repository."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md")])
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
CODE_PATH = re.compile(r"`((?:service|tests|deploy|bench|robots|clients|docs|\.ci)/[^`\s]*)`")
EXTERNAL = re.compile(r"^[a-z][a-z0-9+.-]*:", re.I)  # http:, https:, mailto:, ...


def _without_code_blocks(text: str) -> str:
    return re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)


def _anchors(page: Path) -> set[str]:
    """GitHub's anchors of the page's headings: lower case, punctuation dropped, spaces → -."""
    out = set()
    for line in _without_code_blocks(page.read_text()).splitlines():
        heading = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if heading:
            text = re.sub(r"[`*_]|\[([^\]]*)\]\([^)]*\)", r"\1", heading.group(1)).lower()
            out.add(re.sub(r"[^\w\- ]", "", text).replace(" ", "-"))
    return out


def _inside(path: Path) -> bool:
    return path.resolve().is_relative_to(ROOT)


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_every_relative_link_resolves_inside_the_repository(page: Path) -> None:
    text = _without_code_blocks(page.read_text())
    broken = []
    for target in LINK.findall(text):
        if EXTERNAL.match(target):
            continue
        file_part, _, anchor = target.partition("#")
        linked = (page.parent / file_part) if file_part else page
        if not _inside(linked):
            broken.append(f"{target}: outside the repository")
        elif not linked.exists():
            broken.append(f"{target}: no such file")
        elif anchor and linked.suffix == ".md" and anchor not in _anchors(linked):
            broken.append(f"{target}: no heading with that anchor in {linked.name}")
    assert not broken, broken


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_no_page_points_outside_the_repository(page: Path) -> None:
    text = page.read_text()
    assert "../shared" not in text and "shared/tools" not in text
    assert not re.search(r"\]\(\s*/", text), "a link to an absolute path"
    for target in LINK.findall(_without_code_blocks(text)):
        assert not target.startswith("file:"), target


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_every_repository_path_named_in_code_exists(page: Path) -> None:
    missing = []
    for named in CODE_PATH.findall(page.read_text()):
        path = named.split("::")[0].rstrip(".,;:")
        if any(ch in path for ch in "<>*{}$") or "artifacts" in path:
            continue  # a pattern or a generated directory, not a file of the repository
        if not (ROOT / path).exists():
            missing.append(named)
    assert not missing, missing


def test_the_readme_is_an_entry_page() -> None:
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) < 300  # an entry page: one short section per job
    linked = {target.partition("#")[0] for target in LINK.findall(readme)}
    for doc in (
        "http-api.md",
        "performance.md",
        "deployment.md",
        "architecture.md",
        "security.md",
        "uploads.md",
        "explorer.md",
        "contacts.md",
        "binary-format.md",
        "python-client.md",
    ):
        assert f"docs/{doc}" in linked, doc


def test_the_readme_test_command_is_the_one_ci_runs() -> None:
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    command = next(
        line.strip()
        for line in ci.splitlines()
        if line.strip().endswith("-m pytest") and "pip install" in line
    )
    assert command in readme
