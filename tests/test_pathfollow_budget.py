"""Newton iteration budgets of the limit search's trials (bridgefem.search.schedule, *Trial budgets*) on the
one-degree-of-freedom fake solver of test_bracket, whose limit is known exactly."""
from dataclasses import replace

from test_bracket import LIMIT, OneDof, assert_bracket, search

from bridgefem.search.schedule import BUDGET, BUDGET_FLOOR, RETRY_FLOOR
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


def test_a_hopeless_trial_costs_the_budget_and_a_closing_trial_keeps_every_iteration():
    """Steps longer than 100 N never converge; the last 1.2 N below the limit (ten widths) need 30 Newton iterations,
    more than the floor of the budget. The wandering trials beyond the width stop at the budget (the floor, 20, while
    the hardest converged step took 2 iterations; twice 30 after the band), not at the solver's 60; a trial within the
    width of the converged state keeps all 60, so the slow band converges and the bracket closes on the known limit
    instead of ending in a solver failure."""
    solver = Wandering(reach=100.0, band=1e-3 * LIMIT, slow=30)
    s = search(solver)
    assert_bracket(s)
    wandering = [(spent, hardest) for length, spent, ended, hardest in solver.trials if not ended and length > 100.0]
    assert all(spent == max(BUDGET_FLOOR, BUDGET * hardest) for spent, hardest in wandering), wandering
    assert (BUDGET_FLOOR, EASY) in wandering
    assert any(ended and spent == 30 for _, spent, ended, _ in solver.trials)


def test_a_level_that_failed_before_is_retried_with_the_smaller_budget():
    """With the exact limit as the guess, the first failures (250 N from 0, beyond the 100 N reach) are suspect and
    250 N is retried after the next converged step, 125 N below it: still beyond the reach, that retry stops after
    RETRY_FLOOR iterations (twice the 2 of the step that reached its start is fewer), while every trial at a new
    level that wanders spends the whole budget (the floor, 20); the bracket still holds the known limit."""
    solver = Wandering(reach=100.0, band=0.0, slow=EASY)
    s = search(solver, guess=LIMIT)
    assert_bracket(s)
    tried, again, first = set(), [], []
    for step, (length, spent, ended, _) in zip(s.steps, solver.trials):
        if not ended and length > 100.0:
            (again if step.level in tried else first).append(spent)
        tried.add(step.level)
    assert again and all(spent == max(RETRY_FLOOR, BUDGET * EASY) for spent in again), again
    assert first and all(spent == BUDGET_FLOOR for spent in first), first
