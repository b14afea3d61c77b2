"""How long one people-tracker update takes: 20 walkers and 5 false detections a cycle.

The walkers start at random in a 16 m square and walk at random constant velocities (1.2 m/s
typical), seen every 0.2 s with 0.1 m Gaussian noise; the 5 false detections fall anywhere in
a 20 m square. The detections are made first (seeded), then each
:meth:`~dsmpepc_nlp.perception.tracker.PeopleTracker.update` is timed, ``Detections``'s
checks included; the first ``--warmup`` cycles (tracks not yet confirmed) are left out of the
statistics. Prints the median and the 95th percentile (ms) and how many tracks were
confirmed at the end::

    python tools/dev/bench_tracker.py
    python tools/dev/bench_tracker.py --cycles 2000 --people 50 --json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from dsmpepc_nlp.perception import Detections, PeopleTracker

PERIOD = 0.2
"""Seconds between cycles."""


def scene(people: int, false: int, cycles: int, seed: int) -> list[tuple[np.ndarray, float]]:
    """Each cycle's detected positions (people first, then false ones) and stamp."""
    rng = np.random.default_rng(seed)
    starts = rng.uniform(-8.0, 8.0, (people, 2))
    headings = rng.uniform(0.0, 2.0 * np.pi, people)
    speeds = rng.normal(1.2, 0.2, people)
    velocities = speeds[:, None] * np.stack([np.cos(headings), np.sin(headings)], axis=1)
    out = []
    for k in range(cycles):
        seen = starts + PERIOD * k * velocities + rng.normal(0.0, 0.1, (people, 2))
        out.append((np.vstack([seen, rng.uniform(-10.0, 10.0, (false, 2))]), PERIOD * k))
    return out


def timed(cycles: list, warmup: int) -> dict:
    """Times of each update (ms) after ``warmup`` cycles, summarized."""
    tracker = PeopleTracker()
    times = []
    for positions, stamp in cycles:
        started = time.perf_counter()
        tracker.update(Detections(positions, stamp))
        times.append(time.perf_counter() - started)
    times = 1e3 * np.array(times[warmup:])
    return {"cycles": len(times), "median_ms": float(np.median(times)),
            "p95_ms": float(np.percentile(times, 95)), "max_ms": float(times.max()),
            "confirmed_at_end": len(tracker.obstacles()),
            "tracks_at_end": len(tracker.tracks)}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=500, help="timed cycles (500)")
    parser.add_argument("--people", type=int, default=20, help="walkers (20)")
    parser.add_argument("--false", type=int, default=5, help="false detections a cycle (5)")
    parser.add_argument("--warmup", type=int, default=10, help="cycles left out first (10)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    cycles = scene(args.people, args.false, args.cycles + args.warmup, args.seed)
    result = timed(cycles, args.warmup)
    if args.json:
        print(json.dumps(result))
        return
    print(f"{result['cycles']} updates, {args.people} people + {args.false} false detections: "
          f"median {result['median_ms']:.3f} ms, p95 {result['p95_ms']:.3f} ms, "
          f"max {result['max_ms']:.3f} ms; {result['confirmed_at_end']} confirmed tracks "
          f"({result['tracks_at_end']} in all) at the end")


if __name__ == "__main__":
    main()
