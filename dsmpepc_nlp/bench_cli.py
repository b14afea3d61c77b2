"""The old home of the benchmark commands, kept so ``bench_cli.main`` and
``python -m dsmpepc_nlp.bench_cli`` keep working: everything is in :mod:`dsmpepc_nlp.cli` (one
parser) and :mod:`dsmpepc_nlp.bench.commands` now."""

from __future__ import annotations

import sys

from .bench.commands import overrides as _overrides  # noqa: F401
from .bench.commands import register, summary_text  # noqa: F401
from .cli import main

EXIT_BAD_INPUT = 2

if __name__ == "__main__":
    sys.exit(main())
