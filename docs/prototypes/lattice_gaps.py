"""Would a richer set of ways give the last resort a clear one? (twenty-ninth pass; runs on 04d5b33)

For every CrowdNav collision of a benchmark's ``--out`` folder that ``dsmpepc failures OUT
--escape`` found a way out of, this replays the episode and, at every cycle where the last
resort acted (``last_resort.clearest``, status ``clearing``), sets the widest predicted gap over the
next second of its ways (the plan, 96 dodges, 3 reverses) beside the widest of a lattice of
9**4 = 6561 command sequences within the robot's limits: each of the first four plan periods
changes the speed by -1, 0 or +1 period's acceleration (speeds -0.3 to ``v_limit`` m/s) and the
turn rate likewise, then holds. It prints one line a cycle and a count::

    python docs/prototypes/lattice_gaps.py OUT --scene square --robot invisible --seed 1

Not part of the package; docs/results.md, "The report scenes at 200 replays, and what limits
the last resort", quotes it.
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

from dsmpepc_nlp.bench import crowdnav
from dsmpepc_nlp.bench.crowdnav import CrowdNavSettings
from dsmpepc_nlp.core.control_law import clamp_measured, commanded
from dsmpepc_nlp.solve.behaviours import last_resort, passive
from dsmpepc_nlp.solve.behaviours import ways as moves

DECIDE = 4
"""Plan periods in which the lattice's commands change; they hold after."""
V_LOW = -0.3
"""m/s: the lattice's slowest speed (the back-up rung's reverse)."""


def lattice(state, config):
    """The 9**DECIDE trajectories of the lattice from ``state``."""
    robot, dt, n = config.robot, config.horizon.dt, config.horizon.n_steps
    v0, w0 = clamp_measured(state, config)
    choice = np.array(list(itertools.product(range(9), repeat=DECIDE)))
    dv = (choice // 3 - 1) * robot.accel_limit * dt
    dw = (choice % 3 - 1) * robot.alpha_limit * dt
    commands = np.empty((len(choice), n, 2))
    v, w = np.full(len(choice), v0), np.full(len(choice), w0)
    for k in range(n):
        if k < DECIDE:
            v = np.clip(v + dv[:, k], V_LOW, robot.v_limit)
            w = np.clip(w + dw[:, k], -robot.omega_limit, robot.omega_limit)
        commands[:, k, 0], commands[:, k, 1] = v, w
    return commanded(state, config, commands)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--scene", default="square")
    parser.add_argument("--robot", default="invisible")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    report = json.loads((args.out / "failures.json").read_text())
    episodes = [int(f["label"].split("episode=")[1].split()[0]) for f in report["failures"]
                if f["evidence"].get("escape") in ("forward", "rung", "full")]
    rows = []
    original = last_resort.clearest

    def watched(plan, state, cycle, arrival=float("inf"), ways=None):
        chosen = original(plan, state, cycle, arrival, ways)
        if chosen is not None:
            within = cycle.config.stall.clearance_within
            ways = moves.stacked([plan.trajectory, moves.Ways(state, cycle.config).dodges,
                                   moves.Ways(state, cycle.config).reverses])
            now = np.nanmax(passive.clearance(ways, cycle, within))
            rich = np.nanmax(passive.clearance(lattice(state, cycle.config), cycle, within))
            rows.append((episode, float(now), float(rich)))
            print(f"episode {episode}: widest gap {now:.3f} m (its ways), {rich:.3f} m (lattice)")
        return chosen

    last_resort.clearest = watched
    settings = CrowdNavSettings(scene=args.scene, setting=args.robot)
    for episode in episodes:
        crowdnav.simulate_episode(settings, "ds-mpepc", episode, args.seed)
    clear_only = [r for r in rows if r[2] > 0.0 >= r[1]]
    print(f"{len(rows)} cycles of {len(episodes)} collisions with a way out; the lattice alone "
          f"keeps a positive gap in {len(clear_only)} (episodes "
          f"{sorted({r[0] for r in clear_only})}); wider by over 2 cm in "
          f"{sum(r[2] > r[1] + 0.02 for r in rows)}")


if __name__ == "__main__":
    main()
