"""The target of the limit search and the collapse-state readings that move it (:mod:`bridgefem.search.pathfollow`).
Levels in N per unit load factor; T is the target, ``lower`` the last converged level, the width ``tolerance x
lower`` (:mod:`bridgefem.search.bracket`).

**Guess.** What is known of the limit before the search steers its path, never its bracket rule:

1. T is the level whose width reaches just to the static bound (:mod:`bridgefem.search.pathfollow`, *Static
   bound*), else (1 - tolerance) g for an estimate g of the limit (``guides.guess``, e.g. the rigid-block LP's
   level), at most (1 - tolerance) x the lower end of a coarser run's bracket on a re-run (a finer mesh carries
   close to its coarser run's limit: its trials above that level are then plausible, not suspect).
2. Each approach step leaves ``APPROACH`` of the distance to T, at most the schedule's step long
   (:mod:`bridgefem.search.schedule`); a step that would stop within ``LANDING`` x T of T goes to T, unless T
   already failed from the same converged state (after a backtrack: the solve is deterministic, so that landing
   would replay the failure the search backed away from) or from ``FUTILE_LANDINGS`` states
   (:mod:`bridgefem.search.bracket`; a T above the limit of the path, as a coarser mesh's level can be, fails from
   every state: landing there again spends the steps of a bisection back down each time). An approach step that may
   not land is at least the width long, so that it crosses T instead of halving the distance to it for ever.
3. The step after T is the width, so that a limit in [T, g] is bracketed in two trials.
4. A failure below (1 - ``PLAUSIBLE``) T contradicts the guess: it is *suspect* (usually the Newton method failing
   on a long step) and closes the bracket only under the stricter rules of :mod:`bridgefem.search.bracket`
   (*Suspect failures*).

**Collapse state.** On a bare ring the search reads its converged states as rigid blocks (evidence 3 of
:mod:`bridgefem.analysis.evidence`; the rigid-block LP of Livesley 1978 with each joint's shear capacity frozen at
mu x the state's normal force). ``collapse.level(state)`` is the level F at which a state's blocks collapse on a
mechanism that slides only where the state's joints are at their Coulomb limit; F is at least the state's level L,
since the state's forces are admissible for those blocks (the lower-bound theorem of the frozen problem).

1. Once the FE slides on that mechanism F often stops rising; but where the normal forces of the sliding joints
   grow with the load, F rises nearly as fast as the load, and a search aiming at F itself would creep up in ever
   shorter steps. So F counts as *settled* only while its reserve F - L shrinks (F rose by less than the step that
   reached its state), and only while a failure lies above the state.
2. A settled F rising by at most ``RISE`` x the step is the estimate itself; otherwise the reserve of the last two
   states is extrapolated to zero along its secant, L + (F - L) / (1 - dF/dL): below F where F falls (it approaches
   the limit from above), above F where it rises (extrapolating a slow rise would overshoot where F jumps and then
   stays).
3. The estimate sets T = estimate / (1 + ``STRADDLE`` tolerance), never above the target of step 1 of *Guess*; a
   state within the width of its estimate tries the width above it next, the closing trial (a trial at F itself,
   where the curve is flat, fails without showing a mechanism and only halves the step).
4. A closing trial that fails without proof from a collapse state whose F lies within the width above ``lower``
   is the mechanism, without retries (``collapse.settles``,
   :meth:`bridgefem.analysis.evidence.SlipCheck.settles`): the verdict confirms the bracket from that very state,
   and a retry could only reach another non-associative collapse state (they are not unique: Gilbert, Casapulla &
   Ahmed 2006) by raising the sliding joints' normal forces along a flat curve.
5. A closing trial that every solver setting failed without proof (:mod:`bridgefem.search.pathfollow`, *Failures
   without proof*), from a state that is the collapse state confirming [``lower``, trial] (F within ``AGREEMENT``
   of it, the rest of evidence 3 as in step 4), is the mechanism too, and the bracket ends at F
   (``collapse.upper_end``, :meth:`bridgefem.analysis.evidence.SlipCheck.upper_end`): the FE's path finds no
   equilibrium above ``lower``, its state's rigid blocks carry up to F with the state's normal forces, and the
   bracket claims no more than those two readings, its width wider than the tolerance saying how far they leave the
   limit. Where the path stops at a state with a reserve beyond ``AGREEMENT`` the failure stays a solver failure.
6. On a barrel of rings only steps 4 and 5 apply, on its own pairs (:class:`bridgefem.analysis.checks.PairCheck`):
   the estimate F would steer the path, and there it can then reach another non-associative collapse state far
   below the one the search's own path reaches (``docs/robustness.md``, *Rings*).
7. Under an elastic fill the reading is evidence 5 of :mod:`bridgefem.analysis.evidence` instead
   (:func:`bridgefem.analysis.interface.fill_collapse_check`, ``collapse.at_collapse``): no estimate F (the rings'
   collapse level under the loads the fill transmits rises with the load wherever the fill restrains them), but a
   converged state at which the rings under those loads collapse within the width is a collapse state by itself,
   and its step counts as failed with a mechanism (:mod:`bridgefem.search.step`, *Collapse state*).

Safeguards:

- *Plausibility* ``PLAUSIBLE``: a failure far below the estimate is more likely the Newton method's than the
  limit's, so it must pass the suspect rules before it closes the bracket.
- *No landing where T failed*: a landing that already failed from the same state would replay that failure, and
  one that failed from ``FUTILE_LANDINGS`` states is above the path's limit more likely than not.
- *Settled collapse level only*: aiming at an F that keeps rising with the load would creep up in ever shorter
  steps.
- *Reading cap* ``RISINGS``: a reading costs a rigid-block LP and the joints' resultants, about a Newton
  iteration's time, so a search stops reading after that many states whose reserve did not shrink.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..solver.newton import Iterate
from .bracket import Bracket, below
from .records import CollapseCheck

APPROACH = 0.5  # fraction of the distance to the target T left by an approach step
LANDING = 0.08  # an approach step that would stop within this fraction of T goes to T
PLAUSIBLE = 0.02  # failures below (1 - PLAUSIBLE) T contradict the guess (suspect)
RISE = 0.5  # a collapse level that rose by at most this fraction of the step to its state is the estimate itself;
# one that rose faster, but by less than the step, is extrapolated to where its reserve vanishes
RISINGS = 3  # the search stops reading collapse states after this many whose level rose by the step or more
STRADDLE = 0.5  # a collapse state's estimate lies this many widths above the target it sets (module docstring,
# *Collapse state*)


def first_target(cap: float, guess: float | None, coarser: float | None, tolerance: float) -> float:
    """The search's target T before any collapse state's estimate (N per unit load factor; inf: none): the level
    whose width reaches just to the static bound ``cap``, else (1 - tolerance) x the ``guess``, at most (1 -
    tolerance) x the ``coarser`` run's lower end (module docstring, *Guess*, step 1)."""
    target = below(cap, tolerance) if cap < math.inf else math.inf if guess is None else (1.0 - tolerance) * guess
    return min(target, (1.0 - tolerance) * coarser) if coarser else target


@dataclass
class Target:
    """The search's target T and the collapse-state readings that lower it (module docstring, *Guess*, *Collapse
    state*). Levels in N per unit load factor; every reading is collective."""

    aim: float  # T before any collapse state's estimate (of the guess, the static bound, a coarser run; inf: none)
    collapse: CollapseCheck | None
    level: float = field(init=False)  # T
    foreseen: float | None = None  # the converged state's settled collapse level (None: none)
    readings: dict[int, float | None] = field(default_factory=dict)  # each read state's collapse level, by visit
    risen: set[int] = field(default_factory=set)  # the states whose reserve did not shrink (not settled)

    def __post_init__(self) -> None:
        self.level = self.aim

    def plausible(self, level: float) -> bool:
        """A failure at ``level`` does not contradict the target (*Guess*)."""
        return self.level == math.inf or level >= (1.0 - PLAUSIBLE) * self.level

    def approach(self, lower: float, step: float, refused: bool, width: float) -> float:
        """The approach step from ``lower`` (*Guess*): ``APPROACH`` of the distance to T left, at most ``step``
        long, to T itself when that leaves at most ``LANDING`` x T, unless the landing is ``refused``
        (:meth:`bridgefem.search.bracket.Bracket.landing_refused`); then at least the ``width`` long."""
        trial = min(self.level - APPROACH * (self.level - lower), lower + step)
        if refused:
            return max(trial, lower + width)
        return self.level if self.level - trial <= LANDING * self.level else trial

    def read(self, bracket: Bracket) -> None:
        """The converged state's settled collapse level and the target it sets: ``aim``, or while a failure lies
        above the state, the level ``STRADDLE`` widths below that settled level when that is lower (*Collapse
        state*)."""
        self.foreseen = self._settled_collapse(bracket)
        if self.foreseen is None or bracket.soft == math.inf:
            self.level = self.aim
        else:
            self.level = min(self.aim, self.foreseen / (1.0 + STRADDLE * bracket.tolerance))

    def _reading(self, at: Iterate, number: int) -> float | None:
        """The collapse level of the converged state ``at`` (visit ``number``), read once."""
        if number not in self.readings:
            self.readings[number] = self.collapse.level(at)
        return self.readings[number]

    def _settled_collapse(self, bracket: Bracket) -> float | None:
        """Where the converged states' collapse levels meet the load, when they are settled and a failure lies above
        (*Collapse state*), else None; read only then, once per state, and no longer after ``RISINGS`` states whose
        reserve did not shrink."""
        if self.collapse is None or bracket.soft == math.inf or not bracket.history or len(self.risen) >= RISINGS:
            return None
        previous = bracket.history[-1]
        now = self._reading(bracket.state, bracket.visit)
        before = self._reading(previous.state, previous.visit)
        if now is None or before is None:
            return None
        rise = (now - before) / bracket.taken  # dF/dL over the step that reached the state
        if rise >= 1.0:  # the reserve F - L does not shrink
            self.risen.add(bracket.visit)
            return None
        if 0.0 < rise <= RISE:  # a slow rise: F itself
            return now
        return bracket.lower + (now - bracket.lower) / (1.0 - rise)  # where the reserve's secant meets zero

