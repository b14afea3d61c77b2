"""The README's commands still run: every ``dsmpepc`` command line it shows parses with today's
parser, every command of its table exists, and its library example runs on the default solver.
The README stays a user's page: short lines, no commit hashes, no lab-notebook pass names."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from dsmpepc_nlp.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()
PLACEHOLDERS = {"SCENARIO": "hall", "DIR": "/tmp", "OUT_DIR": "/tmp"}


def _block_lines():
    """Every ``dsmpepc ...`` invocation in the README's bash blocks (full command lines)."""
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", README, re.S):
        for line in block.splitlines():
            for part in line.split("#")[0].split("&&"):
                if part.strip().startswith("dsmpepc "):
                    lines.append(part.strip())
    return sorted(set(lines))


def _named_commands():
    """``dsmpepc NAME [SUB]`` named anywhere in the README's text and tables."""
    named = set()
    for line in re.findall(r"`(dsmpepc [^`]+)`", README):
        words = line.replace("\\|", "|").split()[1:]
        if words and words[0].isupper():          # `dsmpepc COMMAND --help`: any command
            continue
        subs = words[1].split("|") if len(words) > 1 and re.match(r"^[a-z|]+$", words[1]) \
            else [None]
        named.update((words[0], sub) for sub in subs)
    return sorted(named, key=str)


def _argv(line):
    return [PLACEHOLDERS.get(w, w) for w in shlex.split(line)[1:]]


@pytest.mark.parametrize("line", _block_lines())
def test_every_readme_command_line_parses(line):
    args = build_parser().parse_args(_argv(line))
    assert callable(args.func), line


@pytest.mark.parametrize(("name", "sub"), _named_commands())
def test_every_command_the_readme_names_exists(name, sub):
    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices
    assert name in commands, f"dsmpepc {name}"
    if sub is not None and commands[name]._subparsers is not None:
        assert sub in commands[name]._subparsers._group_actions[0].choices, f"{name} {sub}"


def test_the_first_command_runs_the_default_solver():
    first = _block_lines()
    block = re.search(r"```bash\n(.*?)```", README, re.S).group(1).splitlines()
    assert "dsmpepc compare narrow-corridor" in block[0] and "--solver" not in block[0]
    assert "python -m pytest" in block[1]
    assert first


def test_the_library_example_runs(tmp_path):
    code = re.search(r"## Library\n\n```python\n(.*?)```", README, re.S).group(1)
    assert "Planner(" in code
    assert "SolverConfig" not in code, "the example plans with the default solver"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip(), "the example prints the plan"


def test_the_readme_is_a_users_page():
    lines = README.splitlines()
    assert len(lines) <= 160
    assert [i + 1 for i, line in enumerate(lines) if len(line) > 100] == []
    assert re.findall(r"\b[0-9a-fA-F]{7,}\b", README) == [], "commit hashes"
    ordinals = (r"(?:first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh"
                r"|twelfth|\w+teenth|\w+tieth|(?:twenty|thirty|forty)-\w+)")
    assert re.findall(rf"\b{ordinals}\s+pass|\bpass(?:es)?\b|\bPass \d+", README,
                      re.I) == [], "pass names"


def test_the_readme_links_every_page_a_user_needs():
    for page in ("method", "usage", "sensing", "embedding", "design", "results",
                 "experiments/README", "glossary", "claims", "benchmarks", "far-goals"):
        assert f"](docs/{page}.md)" in README, page
    assert "## Layout" not in README, "the layout table lives in docs/design.md"
