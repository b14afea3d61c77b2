"""The results page's contents list every section it has, and every relative link and figure
in the docs and the README points at a file that exists."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results.md"


def _anchor(title: str) -> str:
    """The anchor a Markdown renderer gives a heading (GitHub's rule: lower case, punctuation
    dropped, spaces to hyphens)."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def _outside_code(text: str) -> str:
    return re.sub(r"```.*?```", "", text, flags=re.S)


def test_the_results_contents_list_every_section():
    text = _outside_code(RESULTS.read_text())
    sections = [_anchor(t) for t in re.findall(r"^### (.+)$", text, re.M)]
    listed = re.findall(r"^- \[.+\]\(#([^)]+)\)$", text, re.M)
    assert sections and listed == sections


def test_every_relative_link_and_figure_exists():
    missing = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", _outside_code(page.read_text())):
            if "://" in target or target.startswith("mailto:"):
                continue
            if not (page.parent / target).exists():
                missing.append(f"{page.relative_to(ROOT)}: {target}")
    assert missing == []
