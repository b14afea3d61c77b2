"""Two benchmark tables compared case by case: which runs succeed in only one, and a sign test.

Reads the ``.csv`` of two ``--out`` folders of the same benchmark (``dsmpepc benchmark barn``,
``crowd`` or ``crowdnav``) and pairs their rows by case (``world`` for BARN, ``episode``
otherwise; one variant, the first in the table unless ``--variant``; ``--variant-b`` sets
B's apart, to pair two planners run on the same cases, e.g. the product against ORCA). Prints
each table's success rate on the shared cases, the cases only A or only B succeeds in, the
two-sided sign test on those, the collision count of each, the mean time of each table's
successes (``time_to_goal``, or ``time`` where a table has none) and, over the cases both
succeed in, each table's mean time and how many of them B ends sooner and later than A::

    python tools/paired.py BEFORE/crowdnav.csv AFTER/crowdnav.csv
    python tools/paired.py BEFORE/barn.csv AFTER/barn.csv --json
    python tools/paired.py PAPER/barn.csv PRODUCT/barn.csv --cases 1-299:2   # the odd worlds
    python tools/paired.py BASE/crowd.csv PRODUCT/crowd.csv --variant orca --variant-b ds-mpepc

``--cases`` keeps only those cases (the package's index syntax: ``0-5,10``, ``1-299:2``): one
split of tables that hold both.

This is how docs/results.md counts "only before / only with" and its p-values.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys

from dsmpepc_nlp.bench.results import parse_indices


def sign_test(only_a: int, only_b: int) -> float:
    """Two-sided exact sign test of ``only_a`` against ``only_b`` discordant cases."""
    n = only_a + only_b
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(min(only_a, only_b) + 1))
    return min(1.0, 2.0 * tail / 2 ** n)


def load(path: str, variant: str | None, cases=None) -> dict:
    """``{case: row}`` of one table, for ``variant`` (the first row's when None); only the
    ``cases`` given (ints), when given."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        raise SystemExit(f"{path}: no rows")
    key = "world" if "world" in rows[0] else "episode"
    variant = variant or rows[0].get("variant")
    kept = None if cases is None else {str(c) for c in cases}
    return {row[key]: row for row in rows if row.get("variant") == variant
            and (kept is None or row[key] in kept)}


def _time(row: dict) -> float | None:
    """A successful row's time (``time_to_goal``, else ``time``); None otherwise."""
    value = row.get("time_to_goal") or row.get("time")
    return float(value) if row["outcome"] == "success" and value else None


def _mean(values: list) -> float:
    return sum(values) / len(values) if values else math.nan


def _mean_time(table: dict, cases) -> float:
    return _mean([t for t in (_time(table[case]) for case in cases) if t is not None])


def _shared_times(a: dict, b: dict, cases) -> dict:
    """Over the cases both tables succeed in: each one's mean time and how many B ends
    sooner and later than A."""
    pairs = [(_time(a[c]), _time(b[c])) for c in cases]
    pairs = [(ta, tb) for ta, tb in pairs if ta is not None and tb is not None]
    return {"shared": len(pairs), "shared_time_a": _mean([ta for ta, _ in pairs]),
            "shared_time_b": _mean([tb for _, tb in pairs]),
            "sooner_b": sum(tb < ta for ta, tb in pairs),
            "later_b": sum(tb > ta for ta, tb in pairs)}


def compare(a: dict, b: dict) -> dict:
    """The paired comparison of two loaded tables on their shared cases."""
    cases = sorted(set(a) & set(b), key=lambda c: (len(c), c))
    if not cases:
        raise SystemExit("the two tables share no case")
    won = {name: [c for c in cases if t[c]["outcome"] == "success"] for name, t in
           (("a", a), ("b", b))}
    only_a = [c for c in won["a"] if c not in set(won["b"])]
    only_b = [c for c in won["b"] if c not in set(won["a"])]
    collisions = {name: sum(t[c]["outcome"] == "collision" for c in cases)
                  for name, t in (("a", a), ("b", b))}
    return {"cases": len(cases),
            "success_a": len(won["a"]) / len(cases), "success_b": len(won["b"]) / len(cases),
            "only_a": only_a, "only_b": only_b, "p": sign_test(len(only_a), len(only_b)),
            "collisions_a": collisions["a"], "collisions_b": collisions["b"],
            "time_a": _mean_time(a, cases), "time_b": _mean_time(b, cases),
            **_shared_times(a, b, cases)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("a", help="table A (.csv of a benchmark's --out)")
    parser.add_argument("b", help="table B, the same benchmark")
    parser.add_argument("--variant", help="the variant to compare (default: each table's first)")
    parser.add_argument("--variant-b", help="table B's variant, where it differs from A's "
                        "(default: --variant)")
    parser.add_argument("--cases", help="only these cases, e.g. 1-299:2 (BARN's odd worlds)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    try:
        cases = None if args.cases is None else parse_indices(args.cases, "--cases")
    except ValueError as error:
        parser.error(str(error))
    result = compare(load(args.a, args.variant, cases),
                     load(args.b, args.variant_b or args.variant, cases))
    if args.json:
        json.dump(result, sys.stdout)
        print()
        return 0
    print(f"{result['cases']} cases: success A {result['success_a']:.3f}, B "
          f"{result['success_b']:.3f}; only A {len(result['only_a'])}, only B "
          f"{len(result['only_b'])} (sign test p = {result['p']:.3g}); collisions A "
          f"{result['collisions_a']}, B {result['collisions_b']}; mean time of successes A "
          f"{result['time_a']:.2f} s, B {result['time_b']:.2f} s")
    print(f"{result['shared']} shared successes: mean time A {result['shared_time_a']:.2f} s, "
          f"B {result['shared_time_b']:.2f} s; B sooner in {result['sooner_b']}, later in "
          f"{result['later_b']}")
    print("only A:", " ".join(result["only_a"]) or "-")
    print("only B:", " ".join(result["only_b"]) or "-")
    return 0


if __name__ == "__main__":
    sys.exit(main())
