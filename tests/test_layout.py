"""The house rules, checked: one-way imports (pyproject's import-linter contracts), module and
function sizes. A rule broken on purpose says why where it is broken."""

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "dsmpepc_nlp"

MAX_MODULE_LINES = 400
"""Lines of a module, docstring and all: no exception."""
MAX_FUNCTION_LINES = 80
"""Lines of a function's body, its docstring left out."""


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "scenarios" not in p.parts)


def test_import_contracts_hold():
    importlinter_cli = pytest.importorskip("importlinter.cli")
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        status = importlinter_cli.lint_imports(config_filename=str(ROOT / "pyproject.toml"))
    finally:
        os.chdir(here)
    assert status == 0, "an import contract is broken: run `lint-imports` for the details"


def test_no_module_of_the_package_is_git_ignored():
    """A module the checkout ignores is missing from every clean checkout (CI's, a user's clone)
    while it still runs here: `build/` once swallowed a package's __init__.py."""
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    modules = [str(p.relative_to(ROOT)) for p in _modules()]
    found = subprocess.run(["git", "check-ignore", "--no-index", *modules], cwd=ROOT,
                           capture_output=True, text=True)
    ignored = found.stdout.split()
    assert not ignored, f"git ignores these modules of the package: {ignored}"


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_module_is_small(path):
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_MODULE_LINES, f"{path.name} has {lines} lines: split it by idea"


def _body_lines(node) -> int:
    body = node.body
    first = body[0]
    has_docstring = (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
                     and isinstance(first.value.value, str))
    start = first.end_lineno + 1 if has_docstring and len(body) > 1 else first.lineno
    return node.end_lineno - start + 1


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_functions_are_short(path):
    tree = ast.parse(path.read_text())
    long = [(node.name, node.lineno, _body_lines(node)) for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and _body_lines(node) > MAX_FUNCTION_LINES]
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines in {path.name}: {long}"


def test_the_rules_can_fail(tmp_path):
    """The size rules see a long function and a long module without a reason."""
    long_function = "def f():\n    '''doc'''\n" + "    x = 1\n" * (MAX_FUNCTION_LINES + 1)
    node = ast.parse(long_function).body[0]
    assert _body_lines(node) == MAX_FUNCTION_LINES + 1
    short_function = "def f():\n    '''doc'''\n" + "    x = 1\n" * MAX_FUNCTION_LINES
    assert _body_lines(ast.parse(short_function).body[0]) == MAX_FUNCTION_LINES


def test_ruff_is_clean():
    """``ruff check`` with pyproject's rules (E, F, W, B, I) passes on the whole tree."""
    pytest.importorskip("ruff")
    done = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", str(ROOT)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-2000:]


def test_design_layout_table_names_every_module():
    """The layout table of docs/design.md and the tree agree, module for module."""
    design = (ROOT / "docs" / "design.md").read_text()
    table = design[design.index("\n## Layout\n"):]
    end = table.find("\n## ", 1)
    table = table if end < 0 else table[:end]
    # A module of a sub-package is named with its folder (`graph/layout.py`); tools and tests
    # named beside the table are not modules.
    named = set(re.findall(r"`(?:(?!tools/|tests/)[a-z_]+/)?([a-z_]+\.py)`", table))
    modules = {p.name for p in _modules() if p.name != "__init__.py"}
    assert modules - named == set(), "modules the design's layout table does not name"
    assert named - modules == set(), "names in the design's layout table with no module"
