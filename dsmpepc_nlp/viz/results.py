"""Figures of benchmark results: views over result rows and grids computed by the benchmarks.

BARN's outcome-by-world plot and a sweep's rate heatmaps. Both are written atomically (a
benchmark that is interrupted never leaves half a PNG) and closed.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..core.files import atomic_savefig

OUTCOME_COLOURS = {"success": "tab:green", "collision": "tab:red", "timeout": "tab:orange",
                   "deadlock": "tab:purple", "error": "black"}


def outcome_figure(rows, path, title="BARN") -> Path:
    """Outcome and score of every world against its index (the difficulty order).

    ``rows`` are BARN result rows (``world``, ``outcome``, ``score``).
    """
    colours = OUTCOME_COLOURS
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(9, 4.5), sharex=True,
                                 gridspec_kw={"height_ratios": [1, 2]})
    for outcome, colour in colours.items():
        sel = [r for r in rows if r["outcome"] == outcome]
        if not sel:
            continue
        idx = [r["world"] for r in sel]
        ax.scatter(idx, [list(colours).index(outcome)] * len(sel), c=colour, s=14,
                   label=f"{outcome} ({len(sel)})")
        bx.scatter(idx, [r.get("score") or 0.0 for r in sel], c=colour, s=14)
    ax.set_yticks(range(len(colours)), list(colours))
    ax.set_ylim(-0.5, len(colours) - 0.5)
    ax.legend(loc="upper left", fontsize=7, ncol=5, bbox_to_anchor=(0, 1.45))
    bx.set_ylabel("score")
    bx.set_ylim(-0.02, 0.52)
    bx.set_xlabel("world index (roughly increasing difficulty)")
    ax.set_title(title, pad=28)
    fig.tight_layout()
    try:
        return atomic_savefig(fig, path, dpi=120)
    finally:
        plt.close(fig)


def heatmap_figure(x_name: str, y_name: str, grids, path) -> Path:
    """One heatmap per ``(value, xs, ys, grid[y, x])`` in ``grids``, side by side, annotated.

    Values are rates in [0, 1]; NaN cells (no run) stay blank.
    """
    cmaps = ("viridis", "magma", "cividis")
    fig, axes = plt.subplots(1, len(grids), figsize=(4.5 * len(grids), 3.8), squeeze=False)
    for k, (ax, (value, xs, ys, grid)) in enumerate(zip(axes[0], grids)):
        image = ax.imshow(grid, origin="lower", vmin=0, vmax=1, cmap=cmaps[k % len(cmaps)],
                          aspect="auto")
        ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs])
        ax.set_yticks(range(len(ys)), [f"{y:g}" if isinstance(y, float) else
                                       Path(str(y)).stem for y in ys])
        ax.set_xlabel(x_name)
        ax.set_ylabel(y_name)
        ax.set_title(value.replace("_", " "))
        for j in range(len(ys)):
            for i in range(len(xs)):
                if np.isfinite(grid[j, i]):
                    ax.text(i, j, f"{grid[j, i]:.2f}", ha="center", va="center",
                            color="white" if grid[j, i] < 0.6 else "black", fontsize=8)
        fig.colorbar(image, ax=ax, fraction=0.046)
    fig.tight_layout()
    try:
        return atomic_savefig(fig, path, dpi=110)
    finally:
        plt.close(fig)
