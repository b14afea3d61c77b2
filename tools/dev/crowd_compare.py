"""One ETH/UCY replay driven by several planners, side by side: paths, people and outcomes.

Re-runs crossing ``--episode`` of ``dsmpepc benchmark crowd``'s seeded set (the same draw for
every variant, as the benchmark makes it) with each ``--variants`` entry (``ds-mpepc``,
``mpepc``, and the baselines ``orca`` and ``cv``), and draws the last frame of each beside the
others (:func:`~dsmpepc_nlp.viz.plots.compare_figure`): the robot's whole path, every person's
path, the outcome. It prints each run's outcome, time and nearest gap to anyone. The benchmark
keeps only the episodes that fail; this shows how a run another planner wins went::

    python tools/dev/crowd_compare.py --data DIR --scene univ --episode 27 --out univ-27.png
    python tools/dev/crowd_compare.py --data DIR --scene zara2 --episode 18 --variants ds-mpepc orca

``--preset`` and ``--set`` configure the DS-MPEPC and MPEPC planners as the benchmark's do.
"""

from __future__ import annotations

import argparse
import sys

from dsmpepc_nlp.bench import crowds
from dsmpepc_nlp.bench.params import overrides
from dsmpepc_nlp.sim.metrics import episode_metrics
from dsmpepc_nlp.viz import figures

VARIANTS = ("ds-mpepc", "mpepc", "orca", "cv")


def run(settings: crowds.CrowdSettings, episode: int, seed: int, variants) -> dict:
    """``{variant: Episode}`` of replay ``episode`` of ``seed``, one run a variant."""
    return {variant: crowds.simulate_episode(settings, variant, episode, seed)[0]
            for variant in variants}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", required=True, help="the ETH/UCY folder (FORMAT.md's layout)")
    parser.add_argument("--scene", required=True, help="eth, hotel, zara1, zara2 or univ")
    parser.add_argument("--episode", type=int, required=True, help="the benchmark's episode")
    parser.add_argument("--seed", type=int, default=0, help="the benchmark's --seed (0)")
    parser.add_argument("--variants", nargs="+", choices=VARIANTS,
                        default=["ds-mpepc", "orca", "cv"])
    parser.add_argument("--preset", choices=("product", "paper"), default="product")
    parser.add_argument("--set", dest="sets", action="append", default=[],
                        metavar="NAME=VALUE", help="a planner field, as the benchmark's --set")
    parser.add_argument("--out", help="the figure's path (.png); none: no figure")
    args = parser.parse_args(argv)
    try:
        pairs = overrides(args.sets)
    except ValueError as error:
        parser.error(str(error))
    settings = crowds.CrowdSettings(data=args.data, scene=args.scene, preset=args.preset,
                                    overrides=pairs)
    episodes = run(settings, args.episode, args.seed, args.variants)
    for variant, episode in episodes.items():
        m = episode_metrics(episode)[0]
        print(f"{variant}: {m['outcome']} at {m['outcome_time']:.1f} s, nearest gap to a "
              f"person {m['min_dynamic_clearance']:.2f} m, path {m['path_length']:.2f} m")
    if args.out:
        print("figure:", figures().compare_figure(episodes, path=args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
