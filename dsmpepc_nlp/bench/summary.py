"""How a benchmark's summary reaches the user: ``key: value`` lines, or one JSON object."""

from __future__ import annotations

import json
import math

from ..core.jsonio import json_clean


def summary_text(summary: dict, indent: str = "") -> str:
    """A benchmark summary as ``key: value`` lines, nested dicts indented (never as JSON text)."""
    lines = []
    for key, value in summary.items():
        if isinstance(value, dict):
            lines.append(f"{indent}{key}:")
            lines.append(summary_text(value, indent + "  "))
        else:
            lines.append(f"{indent}{key}: {fmt(value)}")
    return "\n".join(line for line in lines if line)


def fmt(value) -> str:
    """A number for a summary line: 4 significant digits, "nan" for NaN."""
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def summarised(run):
    """``run(args) -> summary`` as a command: the summary printed, exit status 0."""
    def command(args) -> int:
        summary = run(args)
        if args.json:
            print(json.dumps(json_clean(summary), allow_nan=False, separators=(",", ":")))
        else:
            print(summary_text(summary))
        return 0
    return command
