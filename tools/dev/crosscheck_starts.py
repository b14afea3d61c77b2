"""The NLP's starts against the cross-check: which cycles it misses, with which starts it would not.

Replays the sampling episode of ``dsmpepc crosscheck SCENARIO`` (seed 0, DS-MPEPC, the product's
defaults), plans every cycle with the NLP and with the 4096-sample reference as the command does
(docking and the stall ladder off), and prints the misses (gap over 0.01: cycle, the robot's
speed and distance to its goal, gap, both z).
Options change the NLP's starts only; the episode and the reference stay the command's::

    python tools/dev/crosscheck_starts.py t-corridor                  # the defaults
    python tools/dev/crosscheck_starts.py t-corridor --oracle         # + the reference's own z
    python tools/dev/crosscheck_starts.py hall --n-screen 512 --n-solved 4 --time
    python tools/dev/crosscheck_starts.py hall --extra edges          # theta-delta edge starts
    python tools/dev/crosscheck_starts.py t-corridor --r-power 2      # a screen denser at small r
    python tools/dev/crosscheck_starts.py hall --r-power 3 --r-power-share 0.5   # half of it
    python tools/dev/crosscheck_starts.py hall --distinct 0.3         # starts kept farther apart
    python tools/dev/crosscheck_starts.py hall --polish-starts 10     # more candidates polished
    python tools/dev/crosscheck_starts.py hall --polish-starts 16 --polish-scouts 0 --walk-ranks 5
    python tools/dev/crosscheck_starts.py hall --rolling --memory 4   # a screen spread over cycles
    python tools/dev/crosscheck_starts.py hall --episode paper        # the paper preset's states

``--rolling`` screens the next ``n_screen`` points of the screen's 4096-point sequence each
cycle (the reference's sequence is another seed's); ``--memory M`` adds the last plan's M
cheapest distinct ends (solved or screened) as named starts, unchanged in the new frame.

``--walk-ranks K`` records every polish walk's exact cost after each of its rounds and prints in
how many plans the best walk came from a seed ranked after the K-th (cheapest first) and beat the
first K walks by more than 0.01, the ranks of those seeds, and after which round each of them
already led the walks ranked after the K-th (docs/experiments/2026-11-29-scouts-in-the-polish.md:
with 16 seeds and no scouts, how many rounds tell which low-ranked seed is worth walking).

``--time`` also plans every cycle with the default NLP beside it and prints both plan-time
medians and their ratio (the same process, alternating cycle by cycle). ``--time-episodes``
times whole passes over the cycles instead, the setting's NLP (its screen and solves; not
``--extra``, ``--oracle``, ``--memory`` or ``--rolling``) and the default's, twice, each
first once (the figures of docs/experiments/2026-11-28-univ-wandering-and-crosscheck-states.md
and docs/benchmarks.md were timed with the setting first both times); on the hall the two ways
disagree (a 1024-point screen 1.97x cycle by cycle, 1.1-1.3x by passes), so both are printed.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

os.environ.setdefault("DSMPEPC_COMPILE", "wait")

import numpy as np  # noqa: E402

import dsmpepc_nlp.solve.planner as planner_module  # noqa: E402
from dsmpepc_nlp import Planner, PlannerConfig, SolverConfig  # noqa: E402
from dsmpepc_nlp.sim.scenario import load_scenario  # noqa: E402
from dsmpepc_nlp.sim.simulate import simulate  # noqa: E402

EXTRA = {
    # far, wide turns at the box's delta edge
    "wide": lambda b, v: [np.array([0.7 * b.r_max, 0.0, s * 0.95 * b.delta_max, v])
                          for s in (-1.0, 1.0)],
    # theta and delta at their edges, the same side, slow and fast
    "edges": lambda b, v: [np.array([3.0, s * b.theta_max, s * 0.85 * b.delta_max, f * v])
                           for s in (-1.0, 1.0) for f in (0.3, 1.0)],
}


def record_walks(polish) -> list:
    """Make ``polish`` (one planner's :class:`~dsmpepc_nlp.solve.optimize.polish.Polish`) keep every
    walk's exact cost after each of its own rounds (those run ahead on the idle thread too);
    the list that gets, per plan, one ``{round: cost}`` per walk of the final polish, in its
    seeds' order (cheapest first)."""
    log, costs = [], {}
    walk_round, finish, reset = polish.round, polish.finish, polish.reset

    def round_(walks, evaluator, one_thread=False):
        walk_round(walks, evaluator, one_thread)
        for walk in walks:
            costs.setdefault(id(walk), {})[walk.rounds] = walk.cost

    def finish_(walks, evaluator):
        finish(walks, evaluator)
        log.append([dict(costs.get(id(walk), {})) for walk in walks])

    def reset_():
        costs.clear()
        reset()

    polish.round, polish.finish, polish.reset = round_, finish_, reset_
    return log


def rank_lines(log: list, k: int) -> list:
    """The lines of ``--walk-ranks``: which seeds past the ``k``-th won, and after which of its
    own rounds the winner led the seeds past the ``k``-th."""
    ranks, leads = {}, {}
    for walks in log:
        if len(walks) <= k or not all(walks):
            continue
        final = np.array([w[max(w)] for w in walks])
        winner = int(np.argmin(final))
        if winner < k or not final[winner] < final[:k].min() - 0.01:
            continue
        ranks[winner + 1] = ranks.get(winner + 1, 0) + 1
        for round_ in sorted(walks[winner]):
            if int(np.argmin([w[round_] for w in walks[k:]])) + k == winner:
                leads[round_] = leads.get(round_, 0) + 1
                break
    return [f"plans polished: {len(log)}; won by a seed ranked after the {k}th by more than "
            f"0.01: {sum(ranks.values())}",
            "  its rank (1: cheapest) -> plans: " + str(dict(sorted(ranks.items()))),
            f"  its own round after which it led the seeds ranked after the {k}th -> plans: "
            + str(dict(sorted(leads.items())))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--n-screen", type=int, default=256)
    parser.add_argument("--n-solved", type=int, default=3)
    parser.add_argument("--solver", choices=("nlp", "fast"), default="nlp",
                        help="the method whose starts are changed (the timing's default is "
                             "the product's, IPOPT)")
    parser.add_argument("--max-iter", type=int, default=None,
                        help="local.max_iter: the solver's iteration cap for every start")
    parser.add_argument("--polish-starts", type=int, default=None,
                        help="candidates the exact polish walks from (default: the solver's)")
    parser.add_argument("--polish-margin", type=float, default=None,
                        help="how far behind the best a candidate may trail and be polished")
    parser.add_argument("--polish-rounds", type=int, default=None)
    parser.add_argument("--polish-scouts", type=int, default=None,
                        help="candidates after the polished ones walked a round or two")
    parser.add_argument("--polish-scout-rounds", type=int, default=None)
    parser.add_argument("--polish-promoted", type=int, default=None,
                        help="scouts, the cheapest after their rounds, walked to the end")
    parser.add_argument("--walk-ranks", type=int, default=None, metavar="K",
                        help="which polish seeds ranked after the K-th win, and when they lead")
    parser.add_argument("--distinct", type=float, default=None,
                        help="multistart.distinct: how far apart (share of the box) starts are")
    parser.add_argument("--oracle", action="store_true",
                        help="give the NLP the reference's best z as one more named start")
    parser.add_argument("--extra", choices=sorted(EXTRA), action="append", default=[])
    parser.add_argument("--r-power", type=float, default=1.0,
                        help="screen r as r_min + (r_max - r_min) * u ** P (1: uniform)")
    parser.add_argument("--r-power-share", type=float, default=1.0,
                        help="the share of the screen (its last points) that --r-power draws")
    parser.add_argument("--memory", type=int, default=0,
                        help="the last plan's M cheapest distinct starts' ends as named starts")
    parser.add_argument("--rolling", action="store_true",
                        help="screen the next n_screen points of a 4096-point sequence each cycle")
    parser.add_argument("--episode", choices=("product", "paper"), default="product",
                        help="replay the episode the sampler drives under this preset (the "
                             "planners compared keep the product's defaults)")
    parser.add_argument("--time", action="store_true")
    parser.add_argument("--time-episodes", action="store_true",
                        help="also time whole passes over the cycles, the setting's NLP and "
                             "the default's one after the other, twice")
    args = parser.parse_args()
    if args.rolling and args.r_power != 1.0:
        parser.error("--rolling draws its own screen: it does not combine with --r-power")

    episode = simulate(load_scenario(args.scenario),
                       (PlannerConfig.paper if args.episode == "paper" else
                        PlannerConfig.variant)("ds-mpepc"),
                       SolverConfig.sampling(), np.random.default_rng(0),
                       record_trajectories=False)
    cycles = episode.planning_inputs(0)
    config = dataclasses.replace(PlannerConfig.variant("ds-mpepc"), robot=episode.config().robot)
    config = dataclasses.replace(config, stall=dataclasses.replace(config.stall, levels=0))
    reference = Planner(config, SolverConfig.sampling(n_samples=4096, seed=0))
    best = [reference.plan(state, world, goal, dock=False) for state, world, goal in cycles]

    extra = {}
    structured = planner_module.structured_starts

    def with_extra(state, goal, config, previous_target=None, solver=None):
        starts = structured(state, goal, config, previous_target, solver)
        starts.update({name: np.clip(z, config.z_lower, config.z_upper)
                       for name, z in extra.items()})
        return starts

    planner_module.structured_starts = with_extra
    solver = SolverConfig.named(args.solver).replace(n_screen=args.n_screen,
                                                     n_solved=args.n_solved)
    if args.distinct is not None:
        solver = solver.replace(distinct=args.distinct)
    if args.max_iter is not None:
        solver = solver.replace(max_iter=args.max_iter)
    for name in ("polish_starts", "polish_margin", "polish_rounds", "polish_scouts",
                 "polish_scout_rounds", "polish_promoted"):
        if getattr(args, name) is not None:
            solver = solver.replace(**{name: getattr(args, name)})
    nlp = Planner(config, solver)
    nlp.prepare()
    walk_log = None if args.walk_ranks is None else record_walks(nlp.nlp.polish)
    if args.r_power != 1.0:
        inner = nlp.nlp
        unit = (inner.screen - inner.lower) / (inner.upper - inner.lower)
        first = int(round((1.0 - args.r_power_share) * len(unit)))
        unit[first:, 0] **= args.r_power
        inner.use_screen(inner.lower + unit * (inner.upper - inner.lower))
    default = None
    if args.time:
        default = Planner(config, SolverConfig())
        default.prepare()
    times, default_times, misses = [], [], []
    memory = []
    if args.rolling:
        from dsmpepc_nlp.solve.optimize.starts import box_samples
        pool = box_samples(config, 4096, solver.seed + 1)   # the screen's sequence
    for k, ((state, world, goal), ref) in enumerate(zip(cycles, best)):
        extra.clear()
        for name in args.extra:
            bounds, v_limit = config.bounds, config.robot.v_limit
            extra.update({f"{name}-{i}": z for i, z in enumerate(EXTRA[name](bounds, v_limit))})
        if args.oracle:
            extra["oracle"] = np.asarray(ref.z, dtype=float)
        extra.update({f"memory-{i}": z for i, z in enumerate(memory)})
        if args.rolling:
            n = len(nlp.nlp.screen)
            nlp.nlp.use_screen(pool[np.arange(k * n, (k + 1) * n) % len(pool)])
        started = time.perf_counter()
        plan = nlp.plan(state, world, goal, dock=False)
        times.append(time.perf_counter() - started)
        if args.memory:
            ends = sorted((r for r in plan.starts if np.isfinite(r.exact_cost)),
                          key=lambda r: r.exact_cost)
            memory = []
            for r in ends:
                if len(memory) >= args.memory:
                    break
                if all(np.max(np.abs(r.z - m)) > 1e-3 for m in memory):
                    memory.append(np.asarray(r.z, dtype=float))
        if default is not None:
            extra.clear()
            started = time.perf_counter()
            default.plan(state, world, goal, dock=False)
            default_times.append(time.perf_counter() - started)
        gap = plan.fun - ref.fun
        if not gap <= 0.01:
            misses.append(k)
            away = float(np.hypot(goal[0] - state.x, goal[1] - state.y))
            print(f"cycle {k} (t = {k * config.horizon.dt:.1f} s, v {state.v:.2f} m/s, "
                  f"{away:.2f} m from the goal): gap {gap:.4f}, NLP z "
                  f"{np.round(plan.z, 3)}, reference z {np.round(ref.z, 3)}")
    share = 1.0 - len(misses) / len(cycles)
    print(f"{args.scenario}: {len(misses)} of {len(cycles)} cycles missed, {100 * share:.1f} % "
          f"within 0.01")
    if walk_log is not None:
        print("\n".join(rank_lines(walk_log, args.walk_ranks)))
    if default_times:
        a, b = np.median(times), np.median(default_times)
        print(f"plan time median {1e3 * a:.1f} ms against the default's {1e3 * b:.1f} ms "
              f"({a / b:.2f}x)")
    if args.time_episodes:
        extra.clear()
        planners = {"setting": nlp, "default": Planner(config, SolverConfig())}
        planners["default"].prepare()
        for round_ in range(2):
            medians = {}
            order = list(planners.items())                  # the setting first, then last
            for name, planner in (order if round_ == 0 else order[::-1]):
                spent = []
                for state, world, goal in cycles:
                    started = time.perf_counter()
                    planner.plan(state, world, goal, dock=False)
                    spent.append(time.perf_counter() - started)
                medians[name] = np.median(spent)
            print(f"whole passes: plan time median {1e3 * medians['setting']:.1f} ms against "
                  f"the default's {1e3 * medians['default']:.1f} ms "
                  f"({medians['setting'] / medians['default']:.2f}x)")


if __name__ == "__main__":
    main()
