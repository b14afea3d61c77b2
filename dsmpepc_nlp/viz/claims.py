"""The claim map's figure: outcome rates of each variant against the geometry, per family.

A view over the per-cell summary rows of :mod:`dsmpepc_nlp.bench.claims` (one solver): one
column per family, one row per outcome (success, deadlock, collision); a line per variant, its
line style telling the values of the family's second axis apart. With several parameter
settings (``claims --set``), :func:`setting_figure` draws one line per variant and setting.
Written atomically and closed.
"""

from __future__ import annotations

import matplotlib.pyplot as plt

from ..core.files import atomic_savefig

VARIANT_COLOURS = {"mpepc": "tab:red", "ds-mpepc": "tab:blue", "pc-only": "tab:orange",
                   "terminal-only": "tab:green"}
OUTCOMES = ("success_rate", "deadlock_rate", "collision_rate", "timeout_rate")
STYLES = ("-", "--", ":", "-.")


def _rate_grid(rows, rates, path, title, draw, *, height, legend_size, dpi):
    """One column per family, one row per rate in ``rates``; ``draw(ax, mine, rate)`` draws a
    family's rows on one panel. Axes labelled, legend on the top row, saved atomically, closed."""
    names = list(dict.fromkeys(r["family"] for r in rows)) or ["(no runs)"]
    fig, axes = plt.subplots(len(rates), len(names), figsize=(4.2 * len(names), height),
                             squeeze=False, sharey=True)
    for j, name in enumerate(names):
        mine = [r for r in rows if r["family"] == name]
        for i, rate in enumerate(rates):
            ax = axes[i, j]
            draw(ax, mine, rate)
            ax.set_ylim(-0.05, 1.05)
            if j == 0:
                ax.set_ylabel(rate.replace("_", " "))
            if i == 0:
                ax.set_title(name)
            if i == len(rates) - 1 and mine:
                ax.set_xlabel(f"{mine[0]['axis']} (m)")
        if mine:
            axes[0, j].legend(fontsize=legend_size)
    fig.suptitle(title)
    fig.tight_layout()
    try:
        return atomic_savefig(fig, path, dpi=dpi)
    finally:
        plt.close(fig)


def claim_map_figure(rows, path, title: str = "claim map"):
    """Rates against the first geometry axis; ``rows`` are per-cell summary rows of one solver
    (``family``, ``axis``, ``x``, ``axis2``, ``y``, ``variant`` and the rates)."""

    def draw(ax, mine, rate):
        ys = sorted({r["y"] for r in mine})
        for n, variant in enumerate(dict.fromkeys(r["variant"] for r in mine)):
            for k, y in enumerate(ys):
                line = sorted((r["x"], r[rate]) for r in mine
                              if r["variant"] == variant and r["y"] == y)
                label = variant if len(ys) == 1 else f"{variant}, {mine[0]['axis2']} {y:g}"
                ax.plot([p[0] for p in line], [p[1] for p in line], marker="o",
                        ms=max(2.0, 7.0 - 1.6 * n), lw=max(0.8, 4.0 - 1.0 * n), alpha=0.85,
                        ls=STYLES[k % len(STYLES)], label=label,
                        color=VARIANT_COLOURS.get(variant, "black"))

    return _rate_grid(rows, OUTCOMES, path, title, draw, height=9.0, legend_size=6, dpi=110)


def setting_figure(rows, path, title: str = "parameter settings"):
    """Success and deadlock rate against the first geometry axis, one line per variant and
    parameter setting (``params``), one column per family; cells of every second-axis value
    are drawn as separate points of their line's colour."""
    lines = list(dict.fromkeys((r["variant"], r.get("params", "{}")) for r in rows))
    colours = plt.get_cmap("tab10")

    def draw(ax, mine, rate):
        for n, (variant, params) in enumerate(lines):
            for k, y in enumerate(sorted({r["y"] for r in mine})):
                line = sorted((r["x"], r[rate]) for r in mine if r["variant"] == variant
                              and r.get("params", "{}") == params and r["y"] == y)
                ax.plot([p[0] for p in line], [p[1] for p in line], marker="o", ms=4,
                        lw=1.5, alpha=0.85, color=colours(n % 10),
                        ls=STYLES[k % len(STYLES)],
                        label=f"{variant} {params}" if k == 0 else None)

    return _rate_grid(rows, ("success_rate", "deadlock_rate"), path, title, draw, height=5.6,
                      legend_size=5, dpi=100)
