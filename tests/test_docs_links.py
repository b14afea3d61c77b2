"""The results page's contents list every section it has; every relative link and figure in the
docs, the experiments and the README points at a file that exists; and the experiments' index
lists every experiment file."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results.md"
EXPERIMENTS = ROOT / "docs" / "experiments"


def _anchor(title: str) -> str:
    """The anchor a Markdown renderer gives a heading (GitHub's rule: lower case, punctuation
    dropped, spaces to hyphens)."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def _outside_code(text: str) -> str:
    return re.sub(r"```.*?```", "", text, flags=re.S)


def _pages():
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
            *sorted(EXPERIMENTS.glob("*.md"))]


def _targets(text: str):
    """Inline link and figure targets, and reference-style link definitions."""
    inline = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    defined = re.findall(r"^\[[^\]]+\]:\s*([^\s#]+)", text, re.M)
    return inline + defined


def test_the_results_contents_list_every_section():
    text = _outside_code(RESULTS.read_text())
    sections = [_anchor(t) for t in re.findall(r"^### (.+)$", text, re.M)]
    listed = re.findall(r"^- \[.+\]\(#([^)]+)\)$", text, re.M)
    assert sections and listed == sections


def test_every_relative_link_and_figure_exists():
    missing = []
    for page in _pages():
        for target in _targets(_outside_code(page.read_text())):
            if "://" in target or target.startswith("mailto:"):
                continue
            if not (page.parent / target).exists():
                missing.append(f"{page.relative_to(ROOT)}: {target}")
    assert missing == []


def test_the_link_check_sees_a_broken_link(tmp_path):
    """The check reads inline links, figures and reference definitions alike."""
    text = "[a](gone.md) ![b](figures/gone.png)\n\n[c]: gone-too.md\n"
    assert _targets(text) == ["gone.md", "figures/gone.png", "gone-too.md"]


def test_the_experiments_index_lists_every_experiment():
    index = (EXPERIMENTS / "README.md").read_text()
    listed = set(re.findall(r"\]\(([0-9]{4}-[0-9]{2}-[0-9]{2}-[a-z0-9-]+\.md)\)", index))
    files = {p.name for p in EXPERIMENTS.glob("*.md") if p.name != "README.md"}
    assert files and listed == files


def test_no_page_links_the_old_nlp_page():
    """docs/nlp.md became docs/design.md; no page points at the old name."""
    stale = [str(p.relative_to(ROOT)) for p in _pages()
             if re.search(r"\]\((?:docs/)?nlp\.md", p.read_text())]
    assert stale == []
