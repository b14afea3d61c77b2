"""The outcome rules of docs/method.md section 7.3, on numbers: no planner, no episode."""

import pytest

from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.sim.outcomes import (
    OUTCOMES,
    OutcomeConfig,
    footprint_gap,
    outcome,
    window_progress,
)

PROGRESS = OutcomeConfig().deadlock_progress


def decide(t=1.0, duration=30.0, kind="fixed", collided=False, near=False, progress=None):
    return outcome(t, duration, kind=kind, collided=collided, near=near, progress=progress)


def test_the_four_outcomes_are_named():
    assert OUTCOMES == ("success", "collision", "deadlock", "timeout")


def test_fixed_goal_within_tolerance_is_success_and_keeps_going_otherwise():
    assert decide(near=True) == "success"
    assert decide(near=False) is None


def test_collision_wins_over_everything():
    for kind in ("fixed", "follow"):
        assert decide(kind=kind, collided=True, near=True) == "collision"
        assert decide(kind=kind, collided=True, t=30.0, progress=0.0) == "collision"


def test_fixed_goal_deadlock_needs_a_full_window_and_too_little_progress():
    assert decide(progress=None) is None                    # window not over yet
    assert decide(progress=PROGRESS - 1e-6) == "deadlock"
    assert decide(progress=PROGRESS) is None       # exactly enough progress
    assert decide(progress=PROGRESS - 1e-6, near=True) == "success"


def test_fixed_goal_timeout_at_the_end_of_the_duration():
    assert decide(t=30.0) == "timeout"
    assert decide(t=30.0 - 1e-12) == "timeout"              # the float sum of dt's
    assert decide(t=29.8) is None
    assert decide(t=30.0, near=True) == "success"


def test_follow_goal_is_decided_at_the_end_by_distance():
    assert decide(kind="follow", near=True, t=10.0) is None  # never early success
    assert decide(kind="follow", near=True, t=30.0) == "success"
    assert decide(kind="follow", near=False, t=30.0) == "timeout"


def test_follow_goal_deadlock_only_when_far_behind_and_stuck():
    assert decide(kind="follow", near=False, progress=0.0) == "deadlock"
    assert decide(kind="follow", near=True, progress=0.0) is None  # waiting beside the target
    assert decide(kind="follow", near=False, progress=1.0) is None


def test_window_progress_of_a_navigation_function_and_of_a_path_length():
    nf = [5.0, 4.0, 3.95, 3.9]                   # values fall as the robot gets closer
    assert window_progress(nf, 4, "fixed") is None  # 4 values: a 4-cycle window is not over
    assert window_progress(nf + [3.85], 3, "fixed") == pytest.approx(0.15)
    driven = [0.0, 0.5, 0.55, 0.6, 0.62]          # cumulative path length
    assert window_progress(driven, 3, "follow") == pytest.approx(0.12)
    assert window_progress(driven, 2, "follow") == pytest.approx(0.07)


def test_footprint_gap_is_negative_on_overlap_and_inf_with_nothing():
    a, ra = [[0.0, 0.0]], [0.3]
    assert footprint_gap(a, ra, [[1.0, 0.0]], [0.3]) == pytest.approx(0.4)
    assert footprint_gap(a, ra, [[0.5, 0.0]], [0.3]) == pytest.approx(-0.1)
    assert footprint_gap(a, ra, [], []) == float("inf")


def test_the_rules_numbers_are_a_validated_configuration():
    rules = OutcomeConfig(deadlock_progress=0.5)
    assert decide(progress=0.4) is None                       # the default asks 0.1 m
    assert outcome(1.0, 30.0, kind="fixed", collided=False, near=False, progress=0.4,
                   rules=rules) == "deadlock"
    with pytest.raises(InputError, match="deadlock_window"):
        OutcomeConfig(deadlock_window=0.0)
    with pytest.raises(InputError, match="deadlock"):
        OutcomeConfig(deadlock=1)
