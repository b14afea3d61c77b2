"""tools/dev/crosscheck_starts.py --walk-ranks: which polish seeds past the k-th win, and when."""

import types


def test_rank_lines_count_late_winners_and_the_round_they_lead(tool):
    starts = tool("crosscheck_starts")
    log = [
        # plan 1: the 4th seed wins by 0.5, leading seeds 3-4 from its own round 2
        [{1: -1.0, 2: -1.0}, {1: -0.9, 2: -0.9}, {1: -0.8, 2: -0.8}, {1: -0.7, 2: -1.5}],
        # plan 2: the 3rd seed wins by only 0.005: not counted
        [{1: -1.0, 2: -1.0}, {1: -0.9, 2: -0.9}, {1: -0.9, 2: -1.005}],
        # plan 3: a first-two seed wins
        [{1: -2.0, 2: -2.0}, {1: -0.9, 2: -0.9}, {1: -0.9, 2: -1.0}],
    ]
    lines = starts.rank_lines(log, 2)
    assert "plans polished: 3" in lines[0] and lines[0].endswith(": 1")
    assert lines[1].endswith("{4: 1}") and lines[2].endswith("{2: 1}")


def test_record_walks_keeps_each_walks_cost_by_its_own_round(tool):
    starts = tool("crosscheck_starts")
    walks = [types.SimpleNamespace(rounds=0, cost=0.0) for _ in range(2)]

    def walk_round(batch, evaluator, one_thread=False):
        for walk in batch:
            walk.rounds += 1
            walk.cost -= 1.0

    def finish(batch, evaluator):
        polish.round(batch, evaluator)      # the patched round, as Polish.finish calls it

    polish = types.SimpleNamespace(round=walk_round, finish=finish, reset=lambda: None)
    log = starts.record_walks(polish)
    polish.round(walks[:1], None, True)     # a round run ahead, on one walk only
    polish.finish(walks, None)
    assert log == [[{1: -1.0, 2: -2.0}, {1: -1.0}]]
    polish.reset()
    polish.finish(walks, None)
    assert log[-1] == [{3: -3.0}, {2: -2.0}]
