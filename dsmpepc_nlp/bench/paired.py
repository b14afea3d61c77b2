"""``dsmpepc paired A.csv B.csv``: two benchmark tables compared case by case, with a sign test.

Reads the ``.csv`` of two ``--out`` folders of the same benchmark (``dsmpepc benchmark barn``,
``crowd`` or ``crowdnav``) and pairs their rows by case (``world`` for BARN, ``episode``
otherwise; one variant, the first in the table unless ``--variant``; ``--variant-b`` sets
B's apart, to pair two planners run on the same cases, e.g. the product against ORCA). Prints
each table's success rate on the shared cases, the cases only A or only B succeeds in, the
two-sided sign test on those, the collision count of each, the mean time of each table's
successes (``time_to_goal``, or ``time`` where a table has none) and, over the cases both
succeed in, each table's mean time and how many of them B ends sooner and later than A::

    dsmpepc paired BEFORE/crowdnav.csv AFTER/crowdnav.csv
    dsmpepc paired BEFORE/barn.csv AFTER/barn.csv --json
    dsmpepc paired PAPER/barn.csv PRODUCT/barn.csv --cases 1-299:2   # the odd worlds
    dsmpepc paired BASE/crowd.csv PRODUCT/crowd.csv --variant orca --variant-b ds-mpepc

``--cases`` keeps only those cases (the package's index syntax: ``0-5,10``, ``1-299:2``): one
split of tables that hold both. This is how docs/results.md counts "only before / only with"
and its p-values; ``dsmpepc table`` (:mod:`.results_table`) pairs each preset's folders so.
"""

from __future__ import annotations

import csv
import json
import math

from ..core.errors import InputError
from ..core.jsonio import json_clean
from .results import parse_indices

CASE_FIELDS = ("world", "episode")
"""The column that names a case: ``world`` in BARN's table, ``episode`` in the crowds'."""
TIME_FIELDS = ("time_to_goal", "time")
"""The columns a success's time is read from, the first one a row fills."""


def sign_test(only_a: int, only_b: int) -> float:
    """Two-sided exact sign test of ``only_a`` against ``only_b`` discordant cases."""
    n = only_a + only_b
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(min(only_a, only_b) + 1))
    return min(1.0, 2.0 * tail / 2 ** n)


def _read_rows(path) -> list:
    """The rows of the ``.csv`` at ``path``; InputError when it cannot be read or is empty."""
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"table {str(path)!r}: cannot read ({exc}); expected the .csv of a "
                         "benchmark's --out folder") from None
    if not rows:
        raise InputError(f"table {str(path)!r}: no rows; expected the .csv of a benchmark's "
                         "--out folder (dsmpepc benchmark barn, crowd or crowdnav)")
    return rows


def _check_time(path, key: str, row: dict) -> None:
    """InputError unless a successful ``row``'s time (:data:`TIME_FIELDS`) is a number."""
    field = next((f for f in TIME_FIELDS if row.get(f)), None)
    if row["outcome"] == "success" and field is not None:
        try:
            float(row[field])
        except ValueError:
            raise InputError(f"table {str(path)!r}: {key} {row[key]}: {field} = "
                             f"{row[field]!r}; expected a number of seconds") from None


def load(path, variant: str | None = None, cases=None) -> dict:
    """``{case: row}`` of one table, for ``variant`` (the first row's when None); only the
    ``cases`` given (ints), when given. InputError naming the file when it cannot be read, has
    no case column (:data:`CASE_FIELDS`) or outcome, a bad time, or no row of ``variant``."""
    rows = _read_rows(path)
    key = next((f for f in CASE_FIELDS if f in rows[0]), None)
    if key is None or "outcome" not in rows[0]:
        missing = "outcome" if key is not None else " or ".join(CASE_FIELDS)
        raise InputError(f"table {str(path)!r}: no {missing} column (its columns: "
                         f"{', '.join(rows[0])}); expected the .csv of dsmpepc benchmark "
                         "barn, crowd or crowdnav")
    variant = variant or rows[0].get("variant")
    kept = None if cases is None else {str(c) for c in cases}
    table = {row[key]: row for row in rows if row.get("variant") == variant
             and (kept is None or row[key] in kept)}
    if not table:
        variants = sorted({str(row.get("variant")) for row in rows})
        among = "" if cases is None else " among --cases"
        raise InputError(f"table {str(path)!r}: no row with variant = {variant!r}{among} (its "
                         f"variants: {', '.join(variants)}), so the two tables share no case")
    for row in table.values():
        _check_time(path, key, row)
    return table


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
    """The paired comparison of two loaded tables on their shared cases; InputError when they
    share none."""
    cases = sorted(set(a) & set(b), key=lambda c: (len(c), c))
    if not cases:
        raise InputError(f"the two tables share no case (A's cases: {_span(a)}; B's: "
                         f"{_span(b)}); pair two tables of the same benchmark's cases")
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


def _span(table: dict) -> str:
    """A few of a table's cases, for a message."""
    names = sorted(table, key=lambda c: (len(c), c))
    return ", ".join(names[:5]) + (f" ... ({len(names)} in all)" if len(names) > 5 else "")


def text(result: dict) -> str:
    """The comparison as the command prints it."""
    return "\n".join([
        f"{result['cases']} cases: success A {result['success_a']:.3f}, B "
        f"{result['success_b']:.3f}; only A {len(result['only_a'])}, only B "
        f"{len(result['only_b'])} (sign test p = {result['p']:.3g}); collisions A "
        f"{result['collisions_a']}, B {result['collisions_b']}; mean time of successes A "
        f"{result['time_a']:.2f} s, B {result['time_b']:.2f} s",
        f"{result['shared']} shared successes: mean time A {result['shared_time_a']:.2f} s, "
        f"B {result['shared_time_b']:.2f} s; B sooner in {result['sooner_b']}, later in "
        f"{result['later_b']}",
        "only A: " + (" ".join(result["only_a"]) or "-"),
        "only B: " + (" ".join(result["only_b"]) or "-")])


def run(args) -> int:
    """``dsmpepc paired``: load both tables, compare them, print the result."""
    cases = None if args.cases is None else parse_indices(args.cases, "paired --cases")
    result = compare(load(args.a, args.variant, cases),
                     load(args.b, args.variant_b or args.variant, cases))
    if args.json:
        print(json.dumps(json_clean(result), allow_nan=False))
    else:
        print(text(result))
    return 0


def register(sub) -> None:
    """Add ``paired`` to the subparsers ``sub``."""
    p = sub.add_parser("paired", help="two benchmark tables compared case by case: the cases "
                       "only one succeeds in, and the sign test",
                       description="Pair the rows of two benchmark tables (.csv) by case and "
                       "print each one's success rate, the cases only A or only B succeeds in "
                       "with the two-sided sign test, collisions and mean times.")
    p.add_argument("a", metavar="A.csv", help="table A (.csv of a benchmark's --out)")
    p.add_argument("b", metavar="B.csv", help="table B, the same benchmark")
    p.add_argument("--variant", help="the variant to compare (default: each table's first)")
    p.add_argument("--variant-b", help="table B's variant, where it differs from A's "
                   "(default: --variant)")
    p.add_argument("--cases", metavar="RANGE",
                   help="only these cases, e.g. 1-299:2 (BARN's odd worlds)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
