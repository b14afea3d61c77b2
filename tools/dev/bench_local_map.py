"""What one lidar scan costs the local map: ``LocalMap.update`` plus ``grid()``, timed.

720 beams over 270 degrees, hits uniform in 1-10 m, into the default window (20 x 20 m at
0.05 m: 400 x 400 cells). The sensor walks 0.1 m and turns 0.01 rad per scan, so the window
rolls on most scans. After ``--warmup`` untimed scans (numba's compile or cache load), prints
the median and the 95th percentile over ``--scans`` scans::

    python tools/dev/bench_local_map.py
    DSMPEPC_NO_COMPILE=1 python tools/dev/bench_local_map.py   # the numpy path
    python tools/dev/bench_local_map.py --scans 500 --json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from dsmpepc_nlp.perception import LaserScan, LocalMap, LocalMapConfig
from dsmpepc_nlp.perception.raycast import compile_enabled

BEAMS = 720
FIELD_OF_VIEW = 1.5 * np.pi
"""270 degrees (rad)."""
HIT_RANGE = (1.0, 10.0)
"""Hits drawn uniformly in this range (m)."""
STEP = np.array([0.1, 0.0, 0.01])
"""The sensor's move per scan along its heading (m), sideways (m), and turn (rad)."""


def scans(count: int, seed: int):
    """``count`` random scans along a walk, 0.1 s apart."""
    rng = np.random.default_rng(seed)
    angles = np.linspace(-FIELD_OF_VIEW / 2, FIELD_OF_VIEW / 2, BEAMS)
    pose = np.zeros(3)
    for i in range(count):
        heading = pose[2]
        pose = pose + [STEP[0] * np.cos(heading), STEP[0] * np.sin(heading), STEP[2]]
        ranges = rng.uniform(*HIT_RANGE, BEAMS)
        yield LaserScan.from_angles(ranges, angles, 0.1, 30.0, pose, 0.1 * i)


def timed(count: int, warmup: int, seed: int) -> dict:
    """Milliseconds of ``update`` + ``grid()`` per scan: median and 95th percentile."""
    local_map = LocalMap(LocalMapConfig())
    times = []
    for i, scan in enumerate(scans(warmup + count, seed)):
        started = time.perf_counter()
        local_map.update(scan)
        local_map.grid()
        if i >= warmup:
            times.append(time.perf_counter() - started)
    ms = 1e3 * np.array(times)
    return {"path": "numba" if compile_enabled() else "numpy", "scans": count,
            "median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95)),
            "cells": list(local_map.shape)}


def main(argv=None) -> None:
    """Run the benchmark and print its numbers."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=200, help="timed scans (default 200)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed scans first (default 5)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    result = timed(args.scans, args.warmup, args.seed)
    if args.json:
        print(json.dumps(result))
    else:
        print(f"update + grid(), {result['path']} path, {BEAMS} beams, "
              f"{result['cells'][0]} x {result['cells'][1]} cells, {result['scans']} scans: "
              f"median {result['median_ms']:.3f} ms, p95 {result['p95_ms']:.3f} ms")


if __name__ == "__main__":
    main()
