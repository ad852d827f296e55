"""The bracket of the limit search (:mod:`bridgefem.search.pathfollow`): [lower, soft], the rule that closes it and
its backtracking.

Levels are in N per unit load factor. ``lower`` is the last converged level and the *width* is ``tolerance x
lower``: the bracket's relative width.

**Bracket rule.**

1. The limit lies in [lower, upper] once a trial at ``upper``, solved from the converged state at ``lower``, fails
   with ``upper - lower <= tolerance x lower``.
2. A failure reached by a longer step proves nothing: the response is path dependent (incremental friction), and
   the active-set Newton method can fail on a long step below the limit. It becomes the *soft* bound.
3. Later trials bisect [lower, soft] and retry the soft bound itself once it lies within the width of ``lower``,
   where its failure is decisive. A trial that converges at or above the soft bound discards it.
4. After a step that converged in one Newton iteration (its start's active set held: the response was linear over
   it), the next trial is the level whose width reaches the soft bound rather than the midpoint, not twice in a row.
5. A failure that shows no mechanism (the Newton method not converging) closes the bracket only from a step of at
   most ``SUBSTEP`` widths; the step schedule halves the step towards it until then
   (:mod:`bridgefem.search.schedule`).

**Suspect failures.** A failure below what the search's target makes plausible is *suspect*
(:mod:`bridgefem.search.target`, *Guess*):

1. a suspect soft bound is retried after every converged step while it lies beyond the width;
2. a suspect failure closes the bracket only from a failing step of at most ``SUSPECT`` widths, taken from a state
   that a step of at most ``SETTLED`` widths reached;
3. otherwise the search backtracks to the converged state before ``lower`` (one of the last ``BACKTRACK``), drops
   the soft bound and goes on with a shorter step (:mod:`bridgefem.search.schedule`), at most ``BACKTRACKS`` times.

A wrong guess therefore costs steps, never the bracket rule.

Safeguards:

- *Soft bound*: a failure after a step longer than the width only bounds the next trials; it never closes the
  bracket, since the Newton method can fail on a long step below the limit.
- *Linear jump* (rule 4): where the soft bound lies just above the limit, the trial the width below it closes the
  bracket in two trials instead of a bisection down to the width.
- *Stalled soft bound*: a soft bound that failed within the width of ``lower`` without proof is approached by
  bisection, not retried from the same state: the solve is deterministic and would fail again.
- *Backtrack cap* ``BACKTRACKS``: a search that climbs back to the same suspect failure would otherwise backtrack
  until its step budget runs out.
- ``CLOSE``: the closing trial lies a hair inside the width, so that rounding never puts it outside.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import NamedTuple

from ..solver.newton import Iterate

SUSPECT = 0.25  # a suspect failure is decisive for a failing step of at most this many widths ...
SETTLED = 4.0  # ... from a state reached by a step of at most this many widths (else backtrack)
BACKTRACK = 4  # converged states kept for backtracking
BACKTRACKS = 2  # backtracks per search: a suspect failure that recurs after them is decisive
SUBSTEP = 0.125  # a failure without proof of collapse is retried with halved steps down to this many widths
CLOSE = 1.0 - 1e-9  # the closing trial is this fraction of the width, so that rounding keeps it inside
FUTILE_LANDINGS = 2  # no landing on the search's target where a trial failed from this many converged states


class Converged(NamedTuple):
    """A converged state of the search: its ``level`` (N per unit load factor), the ``state``, the step ``taken``
    that reached it (N per unit load factor) and its ``visit``: the count of steps attempted when it was reached
    (0: the settled state)."""

    level: float
    state: Iterate
    taken: float
    visit: int


@dataclass
class Bracket:
    """The bracket [lower, soft] and its backtracking (module docstring: *Bracket rule*, *Suspect failures*): the
    converged state at ``lower``, the converged states before it and the failures above it. Levels in N per unit
    load factor."""

    tolerance: float
    initial_step: float  # the width at lower = 0 is that of 1e-9 x this level
    state: Iterate  # the converged state at ``lower``
    lower: float = 0.0  # the last converged level
    taken: float = 0.0  # the step that reached lower
    visit: int = 0  # the converged state's number: the count of steps attempted when it was reached (0: the settled)
    history: deque[Converged] = field(default_factory=lambda: deque(maxlen=BACKTRACK))  # the converged states before
    failed_from: set[tuple[int, float]] = field(default_factory=set)  # (visit, level) of the trials that failed
    soft: float = math.inf  # lowest failed level above lower
    retry: bool = False  # the next trial retries the soft bound
    stalled: bool = False  # the soft bound failed from lower without proof of collapse: approach it by halving
    backtracks: int = 0
    linear: bool = False  # the last step converged in one Newton iteration (lower's active set) and was no jump
    failed_step: float = 0.0  # the step whose failure set the soft bound

    @property
    def width(self) -> float:
        """The bracket's width at ``lower`` (*Bracket rule*)."""
        return self.tolerance * max(self.lower, 1e-9 * self.initial_step)

    def soft_due(self, suspect: bool) -> bool:
        """The next trial is the soft bound: it is to be retried, or it lies within the width of lower (``SUSPECT``
        widths when a failure there is ``suspect``), unless it failed from lower without proof (*Bracket rule*,
        *Suspect failures*)."""
        width = self.width
        return not self.stalled and (self.retry or self.soft - self.lower <= (SUSPECT * width if suspect else width))

    def closes_at(self, level: float) -> bool:
        """``level`` lies within the width of lower while the soft bound lies beyond it: a trial the width above
        lower can close the bracket there (:mod:`bridgefem.search.target`, *Collapse state*)."""
        return abs(level - self.lower) <= self.width < self.soft - self.lower

    def closing(self) -> float:
        """The trial the width above lower (:mod:`bridgefem.search.target`, *Collapse state*)."""
        return self.lower + CLOSE * self.width

    def bisection(self) -> float:
        """The trial between lower and the soft bound: the midpoint, after a linear step the width below the soft
        bound when that is higher (*Bracket rule*)."""
        middle = 0.5 * (self.lower + self.soft)
        return max(middle, below(self.soft, self.tolerance)) if self.linear else middle

    def landing_refused(self, level: float) -> bool:
        """A trial at ``level`` already failed from the converged state at lower, or from ``FUTILE_LANDINGS``
        converged states (:mod:`bridgefem.search.target`, *Guess*: no landing there)."""
        return ((self.visit, level) in self.failed_from
                or sum(failed == level for _, failed in self.failed_from) >= FUTILE_LANDINGS)

    def failed_before(self, level: float) -> bool:
        """A trial at ``level`` already failed, from any state (:mod:`bridgefem.search.schedule`, *Trial
        budgets*)."""
        return any(failed == level for _, failed in self.failed_from)

    def advance(self, level: float, state: Iterate, visit: int, iterations: int) -> None:
        """Move lower to ``level``, converged in ``iterations`` Newton iterations to ``state`` at ``visit``; the
        state left joins the history (*Bracket rule*)."""
        jump = self.linear and level == below(self.soft, self.tolerance)
        self.linear = iterations == 1 and not jump
        self.history.append(Converged(self.lower, self.state, self.taken, self.visit))
        self.visit, self.taken = visit, level - self.lower
        self.lower, self.state, self.stalled = level, state, False

    def reach_soft(self) -> bool:
        """Whether lower reached the soft bound, which it then discards (*Bracket rule*)."""
        reached = self.lower >= self.soft
        if reached:
            self.soft = math.inf
        return reached

    def mark_retry(self, suspect: bool) -> None:
        """After a converged step, retry a ``suspect`` soft bound while it lies beyond the width (*Suspect
        failures*)."""
        self.retry = self.soft - self.lower > self.tolerance * self.lower and suspect

    def fail(self, level: float) -> None:
        """Record the failure of the trial at ``level`` from lower."""
        self.linear = False
        self.failed_from.add((self.visit, level))

    def backs_away(self, level: float, suspect: bool) -> bool:
        """A ``suspect`` failure at ``level`` within the width of lower, a state reached by a step of more than
        ``SETTLED`` widths, backtracks, at most ``BACKTRACKS`` times (*Suspect failures*)."""
        width = self.width
        return (suspect and level - self.lower <= width and self.taken > SETTLED * width and bool(self.history)
                and self.backtracks < BACKTRACKS)

    def backtrack(self) -> float:
        """Back to the converged state before lower, without a soft bound; returns the step that reached the
        discarded state (*Suspect failures*)."""
        discarded = self.taken
        self.backtracks += 1
        self.lower, self.state, self.taken, self.visit = self.history.pop()
        self.soft, self.retry = math.inf, False
        return discarded

    def ends(self, level: float, suspect: bool, mechanism: bool) -> bool:
        """A failure at ``level`` ends the search: one with a ``mechanism``, a ``suspect`` one or one within
        ``SUBSTEP`` widths of lower, from a step of at most the width (``SUSPECT`` widths when suspect), unless it
        backtracks (*Bracket rule*, *Suspect failures*)."""
        rise, width = level - self.lower, self.width
        return (mechanism or suspect or rise <= SUBSTEP * width) \
            and rise <= (SUSPECT * width if suspect else width) and not self.backs_away(level, suspect)

    def soften(self, level: float) -> None:
        """The failure at ``level`` becomes the soft bound, stalled when it failed within the width of lower
        (*Bracket rule*)."""
        self.failed_step = level - self.lower if level < self.soft else self.failed_step
        self.soft, self.retry = level, False
        self.stalled = level - self.lower <= self.width


def below(level: float, tolerance: float) -> float:
    """The level whose width reaches just to ``level`` (N per unit load factor): a failure at ``level`` from there
    closes the bracket."""
    return level / (1.0 + CLOSE * tolerance)

