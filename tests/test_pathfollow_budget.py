"""The limit search with a Newton method that wanders (bridgefem.search.schedule, *Trial budgets*: each trial
is given a budget of Newton iterations) on the one-degree-of-freedom fake solver of test_bracket, whose limit is known
exactly: the budgets never cost the bracket. The iterations each trial is given are counted against the rule in
benchmarks/solve_budgets.py."""
from dataclasses import replace

from test_bracket import LIMIT, OneDof, assert_bracket, search

from bridgefem.solver.newton import StepOutcome

MAX_ITERATIONS = 60  # the solver's own budget when a trial is given none (bridgefem.scene.schema, solver.max_iterations)
EASY = 2  # Newton iterations of an ordinary step of the fake solver (OneDof)


class Wandering(OneDof):
    """``OneDof`` whose Newton method wanders without converging, until its iterations run out, on a step longer
    than ``reach`` (N), and needs ``slow`` iterations on a step ending within ``band`` (N) below the limit (if given
    fewer, it fails without proof after spending them). Records every trial as (step length in N, iterations
    spent, converged or proved unbounded, Newton iterations of the hardest converged step before it)."""

    def __init__(self, reach, band, slow):
        super().__init__()
        self.reach, self.band, self.slow = reach, band, slow
        self.trials = []
        self.hardest = 0

    def solve_step(self, level, start, predictor=None, give_up=False, iterations=None):
        length = level - float(start.x.array[0])
        given = MAX_ITERATIONS if iterations is None else iterations
        need = self.slow if self.limit - self.band <= level <= self.limit else EASY
        if level <= self.limit and (length > self.reach or need > given):
            self.solves += 1
            out = StepOutcome(False, "no convergence", given, 0.0, given)
        else:
            out = super().solve_step(level, start, predictor, give_up, iterations)
            out = replace(out, iterations=need) if out.converged else out
        self.trials.append((length, out.iterations, out.converged or out.mechanism, self.hardest))
        self.hardest = max(self.hardest, out.iterations) if out.converged else self.hardest
        return out


def test_a_newton_method_that_wanders_on_long_steps_and_is_slow_near_the_limit_still_brackets_it():
    """Steps longer than 100 N never converge; the last 1.2 N below the limit (ten widths) need 30 Newton iterations,
    more than the floor of a trial's budget (20). The wandering trials stop at their budget, but a trial within the
    width of the converged state keeps all the solver's 60: the slow band converges and the bracket closes on the
    known limit instead of ending in a solver failure."""
    solver = Wandering(reach=100.0, band=1e-3 * LIMIT, slow=30)
    assert_bracket(search(solver))
    assert any(not ended and length > 100.0 for length, _, ended, _ in solver.trials), "no trial wandered"
    assert any(ended and spent == 30 for _, spent, ended, _ in solver.trials), "no trial converged in the slow band"


def test_a_level_that_failed_before_is_retried_and_the_bracket_holds_the_limit():
    """With the exact limit as the guess, the first failures (250 N from 0, beyond the 100 N reach) are suspect and
    250 N is retried after the next converged step, 125 N below it, with a smaller budget (still beyond the reach: it
    fails again); the bracket still holds the known limit."""
    solver = Wandering(reach=100.0, band=0.0, slow=EASY)
    s = search(solver, guess=LIMIT)
    assert_bracket(s)
    tried, again = set(), []
    for step, (length, _, ended, _) in zip(s.steps, solver.trials):
        if not ended and length > 100.0 and step.level in tried:
            again.append(step.level)
        tried.add(step.level)
    assert again, "no level was retried: the test proves nothing"
