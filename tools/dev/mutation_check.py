"""How many deliberate bugs in the cost and the control law does the test suite catch?

A small mutation check (no dependency beyond the test extra): every arithmetic operator,
comparison, boolean operator, unary minus and numeric constant inside a function of the target
modules is a candidate mutation (``+`` <-> ``-``, ``*`` <-> ``/``, ``**`` -> ``*``, ``<`` <->
``<=``, ``>`` <-> ``>=``, ``and`` <-> ``or``, ``-x`` -> ``x``, a constant ``c`` -> ``c + 1``).
A seeded sample of them is applied one at a time to a copy of the package, and the targeted
tests run against the copy; a mutant is *killed* when they fail (or time out).

Run from the repository root::

    python tools/dev/mutation_check.py                      # 60 mutants, seed 0
    python tools/dev/mutation_check.py --count 200 --seed 1 --json out/mutation.json

Survivors are listed with their line and the mutated source: each is either a missing test or
an equivalent mutant (a change that cannot alter any result, e.g. in a guard that only keeps a
graph finite); the report does not decide which.
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]     # the checkout: this file is tools/dev/
TARGETS = ("dsmpepc_nlp/core/costs.py", "dsmpepc_nlp/core/exact_cost.py",
           "dsmpepc_nlp/core/control_law.py")
TESTS = ("tests/test_costs.py", "tests/test_control_law.py", "tests/test_cost_terms.py",
         "tests/test_hand_cases.py",
         "tests/test_smooth.py")

_SWAP_BINOP = {ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult,
               ast.Pow: ast.Mult}
_SWAP_CMP = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt,
             ast.Eq: ast.NotEq, ast.NotEq: ast.Eq}


def _docstring_nodes(tree) -> set:
    """ids of the string constants that are docstrings (never mutated)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)):
            body = getattr(node, "body", [])
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                found.add(id(body[0].value))
    return found


def candidates(source: str) -> list[tuple[int, str]]:
    """Every mutation of ``source`` as ``(index, description)``; the index counts the walk."""
    tree = ast.parse(source)
    result = []
    for index, (node, kind) in enumerate(_mutable_nodes(tree)):
        result.append((index, f"line {node.lineno}: {kind}"))
    return result


def _inside_functions(tree):
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield from ast.walk(node)


def _mutable_nodes(tree):
    """(node, description) for each mutation, in a fixed order."""
    docstrings = _docstring_nodes(tree)
    seen = set()
    for node in _inside_functions(tree):
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, ast.BinOp) and type(node.op) in _SWAP_BINOP:
            yield node, f"{type(node.op).__name__} -> {_SWAP_BINOP[type(node.op)].__name__}"
        elif isinstance(node, ast.Compare) and type(node.ops[0]) in _SWAP_CMP:
            yield node, f"{type(node.ops[0]).__name__} -> {_SWAP_CMP[type(node.ops[0])].__name__}"
        elif isinstance(node, ast.BoolOp):
            other = "Or" if isinstance(node.op, ast.And) else "And"
            yield node, f"{type(node.op).__name__} -> {other}"
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            yield node, "drop unary minus"
        elif (isinstance(node, ast.Constant) and type(node.value) in (int, float)
              and id(node) not in docstrings):
            yield node, f"constant {node.value!r} -> {node.value!r} + 1"


class _Apply(ast.NodeTransformer):
    def __init__(self, target: int):
        self.target = target
        self.nodes = None

    def mutate(self, tree):
        self.nodes = {id(node): i for i, (node, _) in enumerate(_mutable_nodes(tree))}
        return ast.fix_missing_locations(self.visit(tree))

    def generic_visit(self, node):
        node = super().generic_visit(node)
        if self.nodes.get(id(node)) != self.target:
            return node
        if isinstance(node, ast.BinOp):
            node.op = _SWAP_BINOP[type(node.op)]()
        elif isinstance(node, ast.Compare):
            node.ops = [_SWAP_CMP[type(node.ops[0])]()] + node.ops[1:]
        elif isinstance(node, ast.BoolOp):
            node.op = ast.Or() if isinstance(node.op, ast.And) else ast.And()
        elif isinstance(node, ast.UnaryOp):
            return node.operand
        elif isinstance(node, ast.Constant):
            node.value = node.value + 1
        return node


def mutate(source: str, index: int) -> str:
    """``source`` with mutation ``index`` applied."""
    return ast.unparse(_Apply(index).mutate(ast.parse(source)))


def run_tests(copy: Path, timeout: float) -> str:
    """``killed``, ``survived`` or ``timeout`` for the package copy at ``copy``."""
    env = dict(os.environ, PYTHONPATH=str(copy), PYTHONDONTWRITEBYTECODE="1")
    command = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
               *[str(copy / t) for t in TESTS]]
    try:
        done = subprocess.run(command, cwd=copy, env=env, capture_output=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timeout"
    return "survived" if done.returncode == 0 else "killed"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=60, help="mutants sampled (default 60)")
    parser.add_argument("--seed", type=int, default=0, help="sampling seed (default 0)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per mutant")
    parser.add_argument("--json", type=Path, help="also write the results here")
    args = parser.parse_args(argv)
    if args.count < 1:
        parser.error(f"--count {args.count}: must be >= 1")

    pool = [(target, index, what) for target in TARGETS
            for index, what in candidates((ROOT / target).read_text())]
    chosen = sorted(random.Random(args.seed).sample(pool, min(args.count, len(pool))))
    print(f"{len(pool)} candidate mutations in {', '.join(TARGETS)}; running {len(chosen)}",
          file=sys.stderr)
    results = []
    with tempfile.TemporaryDirectory() as scratch:
        copy = Path(scratch) / "repo"
        shutil.copytree(ROOT / "dsmpepc_nlp", copy / "dsmpepc_nlp",
                        ignore=shutil.ignore_patterns("__pycache__"))
        shutil.copytree(ROOT / "tests", copy / "tests",
                        ignore=shutil.ignore_patterns("__pycache__"))
        for n, (target, index, what) in enumerate(chosen, 1):
            original = (ROOT / target).read_text()
            (copy / target).write_text(mutate(original, index))
            started = time.perf_counter()
            verdict = run_tests(copy, args.timeout)
            (copy / target).write_text(original)
            results.append({"file": target, "mutation": what, "verdict": verdict})
            print(f"[{n}/{len(chosen)}] {verdict:8s} {target} {what} "
                  f"({time.perf_counter() - started:.1f} s)", file=sys.stderr)
    killed = sum(r["verdict"] != "survived" for r in results)
    print(f"killed {killed} of {len(results)} mutants ({100 * killed / len(results):.0f} %)")
    for r in results:
        if r["verdict"] == "survived":
            print(f"  survived: {r['file']} {r['mutation']}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"seed": args.seed, "results": results}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
