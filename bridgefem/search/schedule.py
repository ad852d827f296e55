"""The step schedule of the limit search and the Newton iteration budget of its trials
(:mod:`bridgefem.search.pathfollow`). Steps and levels in N per unit load factor.

**Steps.** The step is the last step taken, set after every trial:

1. After a converged step it grows or stays, never shrinks (shrinking would stall where every step needs many
   Newton iterations). Without a flat-curve check or a plastic fill (a bare ring; an elastic fill with
   ``stiffness_drop`` 0) it doubles: there the iterations of a converged step hardly depend on its length, so only
   a failure says that a step is too long. With a flat-curve check (a fill) the step's length is part of the
   criterion (its secant), and with a plastic fill the iterations' growth is what says a step is too long: the step
   doubles only after a step of at most ``EASY_ITERATIONS`` Newton iterations or as many as the self-weight took,
   and with a plastic fill also after a step of no more iterations than the one before it (a yielding fill needs
   many iterations on every step near its mechanism, whatever the step's length).
2. A converged step that arrives at the search's target sets it to the width, so that a limit between the target
   and the guess is bracketed in two trials (:mod:`bridgefem.search.target`, *Guess*).
3. Without a plastic fill, a converged step that reaches the soft bound clears it and leaves a step of at least
   half the one whose failure set that bound: the level has converged from a nearer state, so the failure was the
   Newton method's on a long step into that level, not the path's beyond it. With a plastic fill the steps stay as
   they are (its flat-curve bracket moves with the step schedule).
4. A failed step that sets a soft bound halves the step (:mod:`bridgefem.search.bracket`); after a backtrack the
   step is ``BACKTRACK_STEP`` of the step that reached the discarded state.

The step is the step away from the target (beyond it, or without a guess) and bounds every approach step (the
first: ``initial_step``), which bounds the cost of a guess that is too high.

**Trial budgets.** A trial more than the width above ``lower`` (one that cannot close the bracket) gets ``BUDGET``
times the Newton iterations of the hardest converged step, and at least ``BUDGET_FLOOR``; trials that can close the
bracket keep the solver's ``max_iterations``. Such a trial's failure only halves the step, so its budget bounds what
a hopeless trial costs and never decides a verdict. Without a plastic fill, a trial at a level that has already
failed (a soft bound retried from a nearer state) gets at most ``BUDGET`` times the iterations of the step that
reached ``lower``, at least ``RETRY_FLOOR``: the retry usually spans no more than that step, and a retry that
wanders does not recover.

Safeguards:

- *Doubling on easy steps only, with a fill*: a plastic fill's iterations, not a failure, say that its step is too
  long.
- *No shrinking after a converged step*: a search whose every step is hard would otherwise crawl.
- *Half the failed step after a cleared soft bound*: a failure of the Newton method on a long step does not keep
  the steps short once its level has converged.
- *Trial budgets* (``BUDGET``, ``BUDGET_FLOOR``, ``RETRY_FLOOR``): a trial that cannot close the bracket stops
  when it has spent well over what the converged steps needed, instead of wandering through its whole budget.
"""
from __future__ import annotations

from dataclasses import dataclass, field

EASY_ITERATIONS = 4  # with a fill, a converged step with at most this many Newton iterations doubles the step
BACKTRACK_STEP = 0.25  # after a backtrack the step is this fraction of the step that reached the discarded state
BUDGET = 2  # a trial that cannot close the bracket gets this many times the Newton iterations of the hardest
# converged step: a plastic Newton iteration that has not converged by then does not recover
BUDGET_FLOOR = 20  # ... and at least this many: a bare ring's hardest converged step may take one iteration
RETRY_FLOOR = 14  # without a plastic fill, a trial at a level that failed before gets at most BUDGET times the Newton
# iterations of the step that reached lower, and at least this many (module docstring, *Trial budgets*)


@dataclass
class StepSchedule:
    """The step schedule and the Newton iteration budget of a trial (module docstring, *Steps*, *Trial budgets*).
    Steps in N per unit load factor."""

    step: float  # the next step (first: the initial step)
    self_weight_iterations: int  # Newton iterations of the self-weight step
    plastic: bool  # a plastic fill: a step of no more iterations than the one before it is easy too
    flat: bool  # the search checks a flat curve (a fill): a step's length is part of that criterion
    hardest: int = field(init=False)  # Newton iterations of the hardest converged step
    latest: int = field(init=False)  # Newton iterations of the step that reached lower

    def __post_init__(self) -> None:
        self.hardest = self.latest = self.self_weight_iterations

    def budget(self, again: bool) -> int:
        """Newton iterations of a trial that cannot close the bracket (*Trial budgets*): ``BUDGET`` times
        those of the hardest converged step, at least ``BUDGET_FLOOR``; for a level that failed before (``again``),
        at most ``BUDGET`` times those of the latest step (the one that reached lower), at least ``RETRY_FLOOR``."""
        budget = max(BUDGET_FLOOR, BUDGET * self.hardest)
        return min(budget, max(RETRY_FLOOR, BUDGET * self.latest)) if again else budget

    def converged(self, iterations: int, taken: float, width: float | None = None, failed: float | None = None
                  ) -> None:
        """Count the ``iterations`` of the converged step ``taken`` and set the next step (*Steps*): the ``width``
        when the step arrived at T, else twice the step taken when it was easy and the step taken when not, at
        least half the ``failed`` step whose soft bound it cleared (None: none cleared)."""
        easy = not (self.flat or self.plastic) or iterations <= max(EASY_ITERATIONS, self.self_weight_iterations) or (
            self.plastic and iterations <= self.latest)
        self.hardest = max(self.hardest, iterations)
        self.latest = iterations
        if width is not None:
            self.step = width
            return
        self.step = 2.0 * taken if easy else taken
        self.step = max(self.step, 0.5 * failed) if failed is not None else self.step

    def halve(self, failed: float) -> None:
        """After the ``failed`` step set a soft bound, the next step is half of it (*Steps*)."""
        self.step = 0.5 * failed

    def back_off(self, discarded: float) -> None:
        """After a backtrack, the next step is ``BACKTRACK_STEP`` of the step that reached the ``discarded`` state
        (*Steps*)."""
        self.step = BACKTRACK_STEP * discarded

