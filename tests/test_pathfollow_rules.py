"""The limit search's pieces one rule at a time (bridgefem.search.pathfollow, module docstring): the bracket and its
backtracking (bridgefem.search.bracket: *Bracket rule*, *Suspect failures*), the step schedule and the trial budget
(bridgefem.search.schedule: *Steps*, *Trial budgets*), the target and the collapse-state readings
(bridgefem.search.target: *Guess*, *Collapse state*). Every expected value is worked out by hand
from the rule's words; states are stand-ins (the pieces only store them and hand them to the collapse check)."""
import math

import numpy as np
import pytest

from bridgefem.search.bracket import BACKTRACKS, FUTILE_LANDINGS, SETTLED, SUBSTEP, SUSPECT, Bracket
from bridgefem.search.records import CollapseCheck
from bridgefem.search.schedule import BACKTRACK_STEP, BUDGET, BUDGET_FLOOR, EASY_ITERATIONS, RETRY_FLOOR, StepSchedule
from bridgefem.search.target import APPROACH, LANDING, PLAUSIBLE, RISE, RISINGS, STRADDLE, Target

TOLERANCE = 1e-3


def climbed(*levels, soft=math.inf):
    """A bracket that converged at each of ``levels`` in turn (states "S1", "S2", ..., visits 1, 2, ...) from the
    settled state "S0" at 0, with the soft bound ``soft`` above them."""
    b = Bracket(TOLERANCE, 250.0, "S0")
    for visit, level in enumerate(levels, start=1):
        b.advance(level, f"S{visit}", visit, iterations=3)
    b.soft = soft
    return b


def test_the_width_is_the_tolerance_of_lower_and_tiny_but_positive_at_zero():
    assert climbed(2000.0).width == pytest.approx(2.0)
    assert climbed().width == pytest.approx(TOLERANCE * 1e-9 * 250.0)


def test_a_backtrack_takes_the_converged_state_before_and_drops_the_soft_bound():
    b = climbed(100.0, 300.0, soft=300.2)
    assert b.backtrack() == pytest.approx(200.0)  # the step that reached the discarded state
    assert (b.lower, b.state, b.taken, b.visit) == (100.0, "S1", 100.0, 1)
    assert b.soft == math.inf and not b.retry and b.backtracks == 1


def test_only_a_suspect_failure_within_the_width_after_a_long_step_backs_away_and_only_so_often():
    b = climbed(100.0, 300.0)  # width 0.3; reached by 200 > SETTLED widths
    assert 200.0 > SETTLED * b.width
    assert b.backs_away(300.2, suspect=True)
    assert not b.backs_away(300.2, suspect=False)
    assert not b.backs_away(300.0 + 2 * b.width, suspect=True)
    short = climbed(300.0 - 0.5 * SETTLED * 0.3, 300.0)  # reached by a step of half SETTLED widths
    assert not short.backs_away(300.2, suspect=True)
    b.backtracks = BACKTRACKS
    assert not b.backs_away(300.2, suspect=True)


def test_a_failure_ends_the_search_only_from_within_the_width():
    b = climbed(1000.0, 1001.0)  # width 1.001, reached by a short step: no backtrack
    w = b.width
    assert b.ends(1001.0 + 0.99 * w, suspect=False, mechanism=True)
    assert not b.ends(1001.0 + 1.01 * w, suspect=False, mechanism=True)
    # without a mechanism the step is halved down to SUBSTEP widths first
    assert not b.ends(1001.0 + 0.99 * w, suspect=False, mechanism=False)
    assert b.ends(1001.0 + 0.99 * SUBSTEP * w, suspect=False, mechanism=False)
    # a suspect failure is decisive only from SUSPECT widths
    assert b.ends(1001.0 + 0.99 * SUSPECT * w, suspect=True, mechanism=False)
    assert not b.ends(1001.0 + 1.01 * SUSPECT * w, suspect=True, mechanism=True)


def test_a_failure_becomes_the_soft_bound_and_later_trials_bisect_towards_it():
    b = climbed(1000.0)
    b.soften(1200.0)
    assert (b.soft, b.failed_step, b.stalled, b.retry) == (1200.0, 200.0, False, False)
    assert b.bisection() == pytest.approx(1100.0)
    b.soften(1100.0)  # a failure below the soft bound is a new failed step
    assert (b.soft, b.failed_step) == (1100.0, 100.0)
    b.soften(1000.5)  # within the width (1.0): stalled, approached by halving only
    assert b.stalled and b.failed_step == pytest.approx(0.5)
    assert not b.soft_due(suspect=False)


def test_the_soft_bound_is_due_within_the_width_or_within_suspect_widths_when_suspect():
    b = climbed(1000.0, soft=1000.9)  # width 1.0
    assert b.soft_due(suspect=False) and not b.soft_due(suspect=True)
    b.soft = 1000.0 + 0.9 * SUSPECT
    assert b.soft_due(suspect=True)
    b.soft = 1000.0 + 2.0
    assert not b.soft_due(suspect=False) and not b.soft_due(suspect=True)
    b.mark_retry(suspect=True)  # beyond the width and suspect: retried after a converged step
    assert b.retry and b.soft_due(suspect=True)
    b.mark_retry(suspect=False)
    assert not b.retry


def test_after_a_linear_step_the_bisection_tries_the_width_below_the_soft_bound_but_not_twice_in_a_row():
    b = climbed(1000.0, soft=1100.0)
    b.advance(1010.0, "S2", 2, iterations=1)
    assert b.linear and b.lower < b.soft
    below = 1100.0 / (1.0 + (1.0 - 1e-9) * TOLERANCE)  # the level whose width reaches just to 1100
    assert b.bisection() == pytest.approx(below)
    b.advance(b.bisection(), "S3", 3, iterations=1)  # that jump converged in one iteration too
    assert not b.linear and b.bisection() == pytest.approx(0.5 * (b.lower + 1100.0))


def test_reaching_the_soft_bound_discards_it():
    b = climbed(1000.0, soft=1100.0)
    assert not b.reach_soft() and b.soft == 1100.0
    b.advance(1100.0, "S2", 2, iterations=3)
    assert b.reach_soft() and b.soft == math.inf


def test_a_level_failed_from_this_state_and_from_any_state():
    """failed_before: from any state; the target's landing is refused where it failed from this state or from
    FUTILE_LANDINGS states."""
    b = climbed(1000.0)
    b.fail(1200.0)
    level = 1000.0
    for visit in range(2, FUTILE_LANDINGS + 1):
        level += 10.0
        b.advance(level, f"S{visit}", visit, iterations=3)
        assert b.failed_before(1200.0) and not b.landing_refused(1200.0)  # from fewer states before this one
        b.fail(1200.0)
        assert b.landing_refused(1200.0)  # from this one
    b.advance(level + 10.0, "next", FUTILE_LANDINGS + 1, iterations=3)
    assert b.landing_refused(1200.0) and not b.failed_before(1150.0)  # from FUTILE_LANDINGS states before this one


def test_without_a_fill_every_converged_step_doubles_the_next():
    s = StepSchedule(250.0, self_weight_iterations=2, plastic=False, flat=False)
    s.converged(EASY_ITERATIONS, 100.0)
    assert s.step == 200.0
    s.converged(30, 100.0)  # however many iterations it took: only a failure shortens a ring's step
    assert s.step == 200.0


def test_with_an_elastic_fill_only_an_easy_step_doubles():
    s = StepSchedule(250.0, self_weight_iterations=2, plastic=False, flat=True)
    s.converged(EASY_ITERATIONS, 100.0)
    assert s.step == 200.0
    s.converged(EASY_ITERATIONS + 2, 100.0)
    assert s.step == 100.0
    s.converged(EASY_ITERATIONS + 1, 100.0)  # no harder than the step before it: easy only with a plastic fill
    assert s.step == 100.0


def test_with_a_plastic_fill_an_easy_step_doubles_and_a_hard_one_keeps_its_length():
    s = StepSchedule(250.0, self_weight_iterations=2, plastic=True, flat=True)
    s.converged(EASY_ITERATIONS, 100.0)
    assert s.step == 200.0
    s.converged(EASY_ITERATIONS + 1, 100.0)  # harder than the step before it and than EASY_ITERATIONS
    assert s.step == 100.0
    slow = StepSchedule(250.0, self_weight_iterations=EASY_ITERATIONS + 3, plastic=True, flat=True)
    slow.converged(EASY_ITERATIONS + 3, 100.0)  # as many as the self-weight step took
    assert slow.step == 200.0
    unchecked = StepSchedule(250.0, self_weight_iterations=2, plastic=True, flat=False)  # stiffness_drop = 0
    unchecked.converged(EASY_ITERATIONS + 1, 100.0)  # a plastic fill keeps the rule without the flat-curve check
    assert unchecked.step == 100.0


def test_with_a_plastic_fill_a_step_no_harder_than_the_one_before_is_easy():
    s = StepSchedule(250.0, self_weight_iterations=2, plastic=True, flat=True)
    s.converged(12, 100.0)
    assert s.step == 100.0  # harder than the self-weight step's 2
    s.converged(11, 100.0)
    assert s.step == 200.0
    s.converged(14, 200.0)
    assert s.step == 200.0


def test_arrival_at_the_target_sets_the_width_and_a_cleared_soft_bound_keeps_half_its_failed_step():
    s = StepSchedule(250.0, self_weight_iterations=2, plastic=False, flat=False)
    s.converged(2, 100.0, width=0.5)
    assert s.step == 0.5
    s.converged(9, 10.0, failed=80.0)
    assert s.step == 40.0
    s.converged(2, 30.0, failed=80.0)
    assert s.step == 60.0


def test_a_soft_failure_halves_the_step_and_a_backtrack_shortens_the_discarded_one():
    s = StepSchedule(250.0, self_weight_iterations=2, plastic=False, flat=False)
    s.halve(80.0)
    assert s.step == 40.0
    s.back_off(80.0)
    assert s.step == BACKTRACK_STEP * 80.0


def test_the_trial_budget_follows_the_hardest_step_and_a_retried_level_the_latest():
    s = StepSchedule(250.0, self_weight_iterations=1, plastic=False, flat=False)
    assert BUDGET * 1 < BUDGET_FLOOR and s.budget(again=False) == BUDGET_FLOOR
    s.converged(15, 100.0)
    assert BUDGET * 15 > BUDGET_FLOOR and s.budget(again=False) == BUDGET * 15
    s.converged(1, 100.0)  # the latest step took one iteration: a retried level gets the floor of retries
    assert s.budget(again=True) == RETRY_FLOOR
    s.converged(12, 100.0)  # now BUDGET x 12 lies between RETRY_FLOOR and BUDGET x 15
    assert s.budget(again=True) == BUDGET * 12


def test_a_failure_below_the_target_by_more_than_plausible_is_suspect():
    t = Target(1000.0, None)
    assert t.plausible((1.0 - PLAUSIBLE) * 1000.0) and not t.plausible((1.0 - PLAUSIBLE) * 1000.0 - 1e-6)
    assert Target(math.inf, None).plausible(1.0)


def test_an_approach_step_leaves_a_fraction_of_the_distance_and_lands_on_the_target_when_near():
    t = Target(1000.0, None)
    assert t.approach(0.0, 10000.0, False, 0.1) == pytest.approx(1000.0 - APPROACH * 1000.0)
    assert t.approach(0.0, 100.0, False, 0.1) == 100.0  # the step bounds it
    near = 1000.0 - LANDING * 1000.0 / APPROACH + 1.0  # leaves less than LANDING x T
    assert t.approach(near, 10000.0, False, 0.1) == 1000.0
    assert t.approach(near, 10000.0, True, 0.1) == pytest.approx(1000.0 - APPROACH * (1000.0 - near))


def test_an_approach_that_may_not_land_crosses_the_target_by_the_width():
    """Without landing, an approach halving the distance to T would never reach it: within two widths of T the
    step is the width, and it crosses T."""
    t = Target(1000.0, None)
    assert t.approach(999.95, 10000.0, True, 0.1) == pytest.approx(1000.05)
    assert t.approach(999.0, 10000.0, True, 0.1) == pytest.approx(999.5)


class Readings:
    """A collapse check whose levels are given per state; counts the readings."""

    def __init__(self, levels):
        self.levels, self.read = levels, []

    def check(self):
        def level(state):
            self.read.append(state)
            return self.levels[state]

        return CollapseCheck(level, lambda lower, trial, state: (False, "not used"))


def test_a_falling_collapse_level_is_extrapolated_along_the_secant_to_where_it_meets_the_load():
    """F falls from 1040 to 1030 over the step 900 -> 1000: dF/dL = -0.1, so the reserve F - L = 30 vanishes at
    L + (F - L) / (1 - dF/dL) = 1000 + 30 / 1.1; the target is STRADDLE widths below it."""
    readings = Readings({"S1": 1040.0, "S2": 1030.0})
    t = Target(5000.0, readings.check())
    t.read(climbed(900.0, 1000.0, soft=1100.0))
    assert t.foreseen == pytest.approx(1000.0 + 30.0 / 1.1)
    assert t.level == pytest.approx((1000.0 + 30.0 / 1.1) / (1.0 + STRADDLE * TOLERANCE))


def test_a_slowly_rising_collapse_level_is_taken_as_it_is_and_never_raises_the_target():
    readings = Readings({"S1": 1040.0, "S2": 1060.0})  # rose by 20 <= RISE x 100
    assert 20.0 <= RISE * 100.0
    t = Target(5000.0, readings.check())
    t.read(climbed(900.0, 1000.0, soft=1100.0))
    assert t.foreseen == 1060.0
    low = Target(900.0, readings.check())
    low.read(climbed(900.0, 1000.0, soft=1100.0))
    assert low.foreseen == 1060.0 and low.level == 900.0


def test_a_collapse_level_rising_slower_than_the_load_is_extrapolated_to_where_its_reserve_vanishes():
    """F rises from 1040 to 1110 over the step 900 -> 1000: dF/dL = 0.7 > RISE, so F itself would creep towards the
    limit (each state's reserve F - L only 0.7 of the one before); the reserve 140 -> 110 vanishes along its secant
    at L + (F - L) / (1 - dF/dL) = 1000 + 110 / 0.3."""
    readings = Readings({"S1": 1040.0, "S2": 1110.0})
    assert RISE < 0.7 < 1.0
    t = Target(5000.0, readings.check())
    t.read(climbed(900.0, 1000.0, soft=1100.0))
    assert t.foreseen == pytest.approx(1000.0 + 110.0 / 0.3) and not t.risen


def test_a_fast_rising_collapse_level_is_not_settled_and_reading_stops_after_enough_of_them():
    levels = {f"S{i}": 1000.0 + 100.0 * i for i in range(RISINGS + 3)}  # each rises by the whole step
    readings = Readings(levels)
    t = Target(5000.0, readings.check())
    b = climbed(soft=math.inf)
    for i in range(1, RISINGS + 3):
        b.advance(100.0 * i, f"S{i}", i, iterations=3)
        b.soft = 100.0 * i + 50.0
        t.read(b)
        assert t.foreseen is None and t.level == 5000.0
    assert len(t.risen) == RISINGS
    assert len(readings.read) == RISINGS + 1  # each state read once, none after RISINGS fast rises


def test_no_collapse_reading_without_a_failure_above():
    readings = Readings({"S1": 1040.0, "S2": 1030.0})
    t = Target(5000.0, readings.check())
    t.read(climbed(900.0, 1000.0))
    assert t.foreseen is None and t.level == 5000.0 and not readings.read


def test_the_closing_trial_above_a_state_at_its_collapse_closes_the_bracket_whatever_the_rounding():
    """A state within the width of its collapse level, with a failure beyond the width, tries the width above it;
    rounding never puts that trial outside the width, so its failure is decisive (seeded levels)."""
    rng = np.random.default_rng(3)
    for lower in rng.uniform(1e2, 1e7, 200):
        b = climbed(0.5 * lower, lower, soft=1.1 * lower)
        assert b.closes_at(lower + 0.5 * b.width) and b.closes_at(lower - 0.99 * b.width)
        assert not b.closes_at(lower + 1.5 * b.width)
        assert b.closing() > lower and b.ends(b.closing(), suspect=False, mechanism=True)
    b.soft = lower + 0.5 * b.width  # the failure already lies within the width: nothing to close
    assert not b.closes_at(lower)
