"""Step control of the limit search (bridgefem.search.pathfollow) on the one-degree-of-freedom fake solver of
test_bracket, with a Newton method that also fails, without proof, from a *dead end*: a state reached by a long
step inside a narrow band of load levels (no step from it converges; one reached by a short step is fine), as the
active-set method does on a path whose joints changed state abruptly. The search must back away from the dead end
and still bracket the known limit. And with a *hard level*: a band of levels that only a short step reaches."""
import pytest
from test_bracket import OneDof, assert_bracket, search

from bridgefem.search.schedule import BACKTRACK_STEP
from bridgefem.solver.newton import StepOutcome


class DeadEnd(OneDof):
    """``OneDof`` with Newton reach ``reach`` (N); a state at a level in (``low``, ``high``) reached by a step
    longer than ``long`` is a dead end: every trial from it below the limit fails without proof."""

    def __init__(self, low, high, long, reach):
        super().__init__(reach=reach)
        self.low, self.high, self.long = low, high, long
        self.reached_by = {0.0: 0.0}  # level of a converged state -> the step that reached it (N)
        self.trials = []  # (start level, trial level, converged)

    def solve_step(self, level, start, predictor=None, give_up=False, iterations=None):
        a = float(start.x.array[0])
        if self.low < a < self.high and self.reached_by[a] > self.long and level <= self.limit:
            self.solves += 1
            out = StepOutcome(False, "no convergence", 9, 0.0, 1)
        else:
            out = super().solve_step(level, start, predictor, give_up, iterations)
        if out.converged:
            self.reached_by.setdefault(level, level - a)
        self.trials.append((a, level, out.converged))
        return out


def test_a_backtrack_from_a_dead_end_keeps_its_shortened_step():
    """A guess 7.5 % low puts the dead end's band (1100-1110 N) within the landing distance of the target: a landing
    after the backtrack would jump back to the target from the restored state, from which it already failed, and
    replay the same failures down to the same dead end until the backtracks run out, ending in a solver failure.
    Without that landing the first trial after each backtrack is at most BACKTRACK_STEP of the discarded step, no
    failure is replayed, and the search brackets the limit."""
    solver = DeadEnd(low=1100.0, high=1110.0, long=20.0, reach=60.0)
    s = search(solver, guess=1141.9)
    assert_bracket(s)
    failed = [(a, level) for a, level, converged in solver.trials if not converged]
    assert len(failed) == len(set(failed))  # retries apart (none here), a failed trial is never solved again
    dead = [i for i, (a, _, _) in enumerate(solver.trials) if solver.low < a < solver.high
            and solver.reached_by.get(a, 0.0) > solver.long]
    assert dead, "the search met no dead end: the test proves nothing"
    end = solver.trials[dead[-1]][0]
    taken = solver.reached_by[end]
    a, level, _ = solver.trials[dead[-1] + 1]  # the first trial after backing away from the dead end
    assert a == pytest.approx(end - taken) and level - a <= BACKTRACK_STEP * taken * (1 + 1e-12)


class HardLevel(OneDof):
    """``OneDof`` whose Newton method fails, without proof, on a step longer than ``near`` (N) that ends in the band
    of levels [``low``, ``high``] (N); records every trial as (start level, trial level, converged)."""

    def __init__(self, low, high, near):
        super().__init__()
        self.low, self.high, self.near = low, high, near
        self.trials = []

    def solve_step(self, level, start, predictor=None, give_up=False, iterations=None):
        a = float(start.x.array[0])
        if self.low <= level <= self.high and level - a > self.near:
            self.solves += 1
            out = StepOutcome(False, "no convergence", 9, 0.0, 1)
        else:
            out = super().solve_step(level, start, predictor, give_up, iterations)
        self.trials.append((a, level, out.converged))
        return out


def test_past_a_hard_level_the_search_goes_on_with_half_the_step_that_failed_into_it():
    """Without a guess, the step of 500 N from 250 N fails at 750 N, inside a band (700-760 N) that only steps of at
    most 40 N reach; bisection reaches 750 N from within the bracket's width. The path beyond the band is easy, so the
    next trial is 250 N on (half the failed step), not twice the last tiny bisection step; the bracket still holds
    the known limit."""
    solver = HardLevel(700.0, 760.0, 40.0)
    s = search(solver)
    assert_bracket(s)
    assert (250.0, 750.0, False) in solver.trials
    after = [level for start, level, _ in solver.trials if start == 750.0]
    assert after and after[0] >= 750.0 + 0.5 * 500.0, after
