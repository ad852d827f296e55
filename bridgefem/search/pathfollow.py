"""Load incrementation to the limit load: self-weight first, then the live load until no equilibrium exists.

Levels are live-load levels in N per unit load factor. Every trial is solved from the last converged state
``lower``; a failed trial is discarded (incremental friction makes the response path dependent).
A search takes its numbers (:class:`SearchSettings`), what steers it (:class:`SearchGuides`) and its watchers
(:class:`SearchObservers`).
The search (:class:`_Search`) repeats four stages until a rule below ends it: ``next_trial`` chooses the level
(*Bracket rule*, *Guess*, *Steps*, *Collapse state*), ``solve`` solves it (*Predictor*, *Failures without proof*),
``take_converged`` moves ``lower`` up (*Static bound*, *Steps*) and ``take_failed`` backtracks, ends the search or
halves the step; both then read the collapse state (*Collapse state*). The stages compose three pieces of state, one
per job: the bracket and its backtracking (``_Bracket``: *Bracket rule*, *Guess*), the step schedule with the trial
budget (``_Schedule``: *Steps*, *Failures without proof*) and the target with the collapse-state readings
(``_Target``: *Guess*, *Collapse state*). ``_StepRecorder`` solves and records one step (*Flat curve*).

**Bracket rule.** The limit load is [lower, upper] once a trial ``upper`` started from ``lower`` fails with
``upper - lower <= tolerance * lower`` (the *width*). A failure reached by a larger step proves nothing (the
response is path dependent, and the active-set Newton method can fail on a large step below the limit): it is
a *soft* bound. Later trials bisect [lower, soft] and retry the soft bound itself once it is within the width
of ``lower``, where its failure is decisive. A trial that converges at or above the soft bound discards it. After
a step that converged in one Newton iteration (its start's active set held: the response was linear over it), the
next trial is the width below the soft bound rather than the midpoint (not twice in a row): where the soft bound
lies just above the limit, that closes the bracket in two trials instead of a bisection down to the width.

**Static bound.** On a bare ring the static theorem bounds every equilibrium of the FE from above
(:mod:`bridgefem.analysis.evidence`, evidence 4): ``bound.level``, the rigid-block LP on the same joints under the FE's own
loads. The search never tries a level above the one whose width reaches just to it, its target T: a state that
converges at T already ends the search with a bracket within the tolerance, while a level nearer the bound is at the
FE's limit or beyond it, where the curve is flat and the Newton method struggles (campaign seed 1, #193 with 16
elements: a step cut at the bound itself cycled for 28 iterations, 53 linear solves, and failed; T then converged in
one). A step that converges within the width of it (``bound.level - lower <= tolerance * lower``) ends the search
with the bracket [lower, bound.level] once ``bound.admissible`` has checked that converged state against the theorem's
premises (its joint resultants within the LP's rows); a state that fails the check voids the bound and the search
goes on without it. A failure below the bound ends the search by the bracket rule (sliding collapses of
elastic blocks stop below the LP): the bound removes trials above it and ends a bracket that it already proves,
nothing else. With ``bound.falls`` no equilibrium under self-weight exists: a failed self-weight step is the
answer (:func:`bridgefem.search.selfweight.carry_self_weight`), without continuations or retries.

**Guess.** With an estimate g of the limit (``guides.guess``, e.g. the rigid-block LP level) the search
approaches the target T = (1 - tolerance) g (with a static bound: T as above): each step leaves ``APPROACH`` of the
distance to T, and a step that would stop within ``LANDING * T`` of T goes to T, unless T already failed from the
same converged state (after a backtrack: the solve is deterministic, so that landing would replay the failures the
backtrack backed away from). The step after T is the width, so that a limit in [T, g] is bracketed by two trials. A
failure below ``(1 - PLAUSIBLE) * T`` contradicts the guess and is *suspect* (usually the Newton method failing on
a large step): a suspect soft bound is retried after every converged step while it is beyond the width, and a
suspect failure closes the bracket only with a failing step of at most ``SUSPECT`` widths, from a state reached by
a step of at most ``SETTLED`` widths; when that state was reached by a larger step, the search backtracks to the
converged state before it (of the last ``BACKTRACK``) and goes on with ``BACKTRACK_STEP`` of that step, at most
``BACKTRACKS`` times in a search (a search that climbs back to the same failure would otherwise cycle). A wrong
guess therefore costs steps, never the bracket rule. A re-run on a finer mesh also knows the lower end of its coarser
run's bracket, ``coarser``: T is at most (1 - tolerance) x it, so that its trials above it are plausible, not suspect
(the re-runs of the campaigns carry within 2 % of their coarser run's limit).

**Steps.** The step is the last step taken. Without a flat-curve check or a plastic fill (a bare ring; an elastic
fill with ``stiffness_drop`` 0) it doubles after every converged step: there the Newton iterations of a converged
step hardly depend on its length, so only a failure says that a step is too long (campaign seeds 1-7, the 3989
converged live-load steps below 0.98 of the limit of the bare rings not re-run: on rings of fewer than 100 voussoirs
a median of 3 iterations for steps under 5 % of the limit and 4 for steps over 40 %; on rings of 100 to 256
voussoirs 6 and 7, where a crack front crosses about one joint per iteration, so that a rule on the iterations never
let their steps grow). On seeds 1-7 that took the bare rings' solves from 35652 to 34559 (the 223 rings of 100 or
more voussoirs 13993 -> 13232), every class and limit as before (docs/robustness.md, *The campaign*). Where the
search checks a flat curve (a fill) a step's length is part of the criterion (its secant), and with a plastic fill
the iterations' growth is what says a step is too long (below); there the step doubles only after a converged step
of at most ``EASY_ITERATIONS`` Newton iterations or as many as the self-weight step took (a plastic fill needs
several on every step) and, with a plastic fill, after a converged step of no more iterations than the step before
it: a yielding fill takes 10 to 30 on every step near its mechanism whatever the step's size (campaign seed 2, #13:
11-20 on each of 75 steps of the width, from the guess's target up to the limit 37 % above it), so only the
iterations' growth says the step is too long. ``EASY_ITERATIONS`` = 4 rather than 3: on the 4-element runs of the
383 bare rings of campaigns seeds 1 and 2, 17603 -> 17361 linear solves, 36 scenes fewer (265), 10 more (23), every
bracket within the tolerance of its old one (a 3 % larger first step instead shuffles 174 scenes, 92 up and 82 down,
for -49). It never shrinks after a converged step (that would stall where every step needs many iterations), a soft
failure halves it, and arriving at T sets it to the width. It is the step away from T (beyond T, or without a guess)
and bounds every approach step (first: ``initial_step``), which bounds the cost of a guess that is too high. Without
a plastic fill, a converged step that reaches the soft bound clears it and leaves a step of at least half the one
whose failure set that bound: the level has converged from a nearer state, so the failure was the Newton method's on
a long step into that level, not the path's beyond it (seed 1, #182: past 2390 kN, which failed from 88 kN below and
converged from 11 kN below, the next step is 44 kN instead of 11 kN; 391 -> 329 linear solves). With a plastic fill
the steps stay as they were: its flat-curve bracket moves with the step schedule (*Flat curve*; seed 1, #136 and
seed 2, #14 moved by 0.25 % and 0.8 % with that rule).

**Flat curve.** A structure whose mechanism is restrained by a soft or yielding fill never loses equilibrium
exactly: its load-deflection curve flattens. With ``stiffness_drop`` set, a converged trial counts as failed (a
mechanism) when the curve is flat there: its secant stiffness from ``lower`` (load over deflection increment) or the
tangent stiffness of its converged state (:func:`_tangent_stiffness`: the live load's response with the joints'
active set held and the fill's consistent tangent, one solve) is below that fraction of the tangent stiffness after
self-weight. On a softening (concave) curve the secant over a step exceeds the tangent at its end, so such a
failure is as decisive as a lost equilibrium, and the bracket rule is unchanged. Each measure covers the other's
blind spot. The secant alone averages the curve over the step, so a long step from below the flat level to above it
converges and the bracket moves with the step schedule (campaign seed 2, #13: [405.0, 406.4] kN with the default
steps, [402.4, 403.0] with tolerance 0.002; with the tangent [397.7, 399.2] and [398.9, 399.5]); the tangent is the
state's. But the tangent holds the joints' active set: where the flattening comes from joints that open or slide
further within the next increment, it stays well above the secant over a step of the width (seed 1, #136: 5 % of
the initial stiffness against the secant's 0.2 %; seed 2, #14: 10 % against 1 %), and only the secant sees it;
there the bracket still depends on the path the steps take (#14: +1.1 % with half or twice the first step).

**Predictor.** A trial more than the width above ``lower`` starts from the active set predicted by the secant
through the last two converged states (``lower`` and the one before it, both with live load: the self-weight
state is a poor start for a secant), extrapolated to the trial (:meth:`bridgefem.solver.newton.ContactSolver.solve_step`):
on a load path whose joints open and slide progressively that saves the first Newton iteration. A bare ring's
re-run on a finer mesh starts such a trial, within its coarser run's path, from that path's increment over the step
instead (``guides.coarser_path``, :mod:`bridgefem.search.coarser_path`): its joints open and slide as the coarser run's did,
and its first trial, with no secant yet, is the longest of its steps. A trial within
the width of ``lower`` (one that can close the bracket) starts from the converged active set, so that its
failure is the Newton method's own evidence. With a plastic fill every trial after two live-load states, the
closing ones too, also starts from the secant's displacements and joint forces (:func:`_displaced`), its active
set chosen as above, its slip reference and plastic strain the converged state's (a start changes the Newton
iteration's path, never what counts as converged; a fill's failure without proof is never decisive): the yielding zone
then starts where the last two steps were taking it, instead of being carried there again by a nearly singular
tangent in line-searched steps of 1/8 to 1/32. Campaign seed 1, #145: converged steps of 3 to 5 Newton iterations
instead of 7 to 9; #136, near its fill's mechanism (the curve's secant a few per cent of its initial stiffness):
the trials within the width of ``lower`` crawled at out-of-balance forces of 1e-5 to 1e-4 of the largest applied
nodal force through their 60 iterations from the converged state, a solver failure; from the secant the closing
trial converges in 17 and its flat secant closes the bracket.
A failed trial more than the width above ``lower`` is solved once more from the state ``predicted`` proposes for it
when one is given (:class:`bridgefem.solver.tresca.TrescaPredictor`: the FE's own step with Tresca friction, its
Coulomb fixed point; built for every bare ring), before the step is halved: the prediction changes only the path,
its outcome is judged as any other. Campaign seed 1, #48: 284 -> 78 solves, #224: 185 -> 42, the same brackets (the
predicted trials converge in 1 to 3 Newton iterations); where the rigid-block mechanism slides, seed 9 #159: 246 -> 74
(the module's measurements: :mod:`bridgefem.solver.tresca`). After
``FUTILE_PREDICTIONS`` predicted trials in a row that failed (or whose fixed point did not settle) the search stops
predicting: each costs up to 8 QPs and a trial's Newton budget.

**Failures without proof.** A failure that shows no mechanism (the Newton method not converging) is never
decisive: the search halves the step towards it, down to ``SUBSTEP`` widths, and only then reports a solver
failure. A failure that would end the search without proof (or a suspect one) is first solved again with the
solver's other settings (:func:`bridgefem.solver.newton.retried`), unless the state it started from settles it (*Collapse
state*); a retry that converges continues the search. Live-load trials are solved with ``give_up`` (the solver's
*Damping chains*): a Newton iteration that keeps wandering into mechanisms stops early, as such a failure, instead
of spending its iterations.
A trial more than the width above ``lower`` gets ``BUDGET`` times the Newton iterations of the hardest converged
step, and at least ``BUDGET_FLOOR``; trials that can close the bracket keep ``max_iterations``. Such a trial's
failure only halves the step, so the budget bounds what a hopeless trial costs and never decides a verdict. Steps
that converge only beyond it are rare: with a plastic fill (Prestwood) converged steps take 4-23 iterations, failed ones
used 40-60 without recovering; on the campaigns' bare rings and elastic fills (seeds 1 and 2, 3326 converged live
steps) two converged steps took more than the budget (24 iterations after a hardest step of 9, 23 after 4), while
failed trials spent up to 60 (seed 1, #48: 39, 37 and 60 iterations at 306.7 kN from states 28, 14 and 7 kN below,
before that level converged in 2 from 1.7 kN below).
Without a plastic fill, a trial at a level that has already failed (from a farther state: a soft bound retried after
a converged step) gets at most ``BUDGET`` times the iterations of the step that reached ``lower``, at least
``RETRY_FLOOR``: the retry usually spans no more than that step (the soft bound retried from the midpoint of the step
that failed), and a retry that wanders does not recover. On the campaigns' final runs (seeds 1 and 2, bare rings) all
170 such retries that converged did so within that budget, while the 92 that failed spent up to 20 (seed 1, #48:
306.7 kN failed three times, 20 iterations each from 28, 14 and 7 kN below, with 12 to 43 pairs changing on every
iteration). On the 4-element runs of the 383 bare rings of both campaigns: 17634 -> 17603 linear solves, none more
in any scene, the brackets unchanged (#48 305 -> 291, seed 2 #41 170 -> 165); with 10 instead of 14, 17625 (seed 1
#278 121 -> 156: its converged retry took 12 iterations).

**Collapse state.** On a bare ring ``collapse`` reads each converged state as rigid blocks (evidence 3 of
:mod:`bridgefem.analysis.evidence`): ``collapse.level(state)`` is the level F at which the state's blocks with its friction
capacities (mu x its joint normal forces) collapse, on a mechanism that slides only where the state's joints are at
their Coulomb limit. F is at least the state's level (its forces are admissible for those blocks). Once the FE
slides on that mechanism F often stops rising: campaign seed 1, 4 elements through the thickness, #220: F = 7943.26
kN, to 1e-10, at every state from 7703 kN up to its limit [7943.26, 7943.44] kN; #184: 10766.57 kN from 9883 kN, 8 %
below its limit; on #124 F falls from 7655 to 7630.28 kN as the states reach its limit 7630.2 kN. But where the
normal forces of the sliding joints grow with the load it rises nearly as fast as the load (#290: 0.9 x the step;
#2: 0.4; seed 6, #146: 0.76), and a search that aimed at F itself would creep up in ever shorter steps, each gaining
1 - dF/dL of the reserve F - L (#290: no bracket within 200 steps). So F counts as *settled* only while that reserve
shrinks (F rose by less than the step that reached its state), and only while a failure lies above the state (where
the search bisects near the top). The reserve of the last two states is then extrapolated to zero along the secant,
L + (F - L) / (1 - dF/dL): a level below F where F falls (it approaches the limit from above, #124), above F where F
rises by more than ``RISE`` x the step (seed 6, #146 on 4 elements: 2549.9 kN from its states at 2456.3 and 2521.8
kN, its limit [2549.80, 2550.05] kN: 2 trials and 7 linear solves from the later state instead of 17 and 44). Where
F rises by at most ``RISE`` x the step the estimate is F itself (extrapolating a slow rise overshoots where F jumps
and then stays, #220). That estimate sets the target T = estimate / (1 + ``STRADDLE`` tolerance), never above the
target of the guess, the static bound or a coarser run, and a state within the width of its estimate tries the width
above it next, the closing trial, half a width beyond the estimate when the search landed on T (a trial at F itself,
where the curve is flat, fails without showing a mechanism and only halves the step). A target sets the path, never
the bracket rule; failures above (1 - PLAUSIBLE) T are plausible (*Guess*). Campaign seed 1, with the retries below:
#220 254 linear solves -> 127, #184 236 -> 102, #124 187 -> 85, each bracket within 5e-5 of the one before; #290 and
#2 keep their paths. A settled F can still lie below the limit and lengthen the path (#175: F rose by 0.29 of a
step, then faster). ``RISE`` 0.25 instead of 0.5 cost more (11 sliding scenes of both seeds, 4 elements: 817 solves
against 768), and the extrapolation of a falling F saved more (743, no scene dearer). A reading costs the frozen LP
and the joints' resultants (20 to 30 ms at 165 voussoirs, as much as a Newton iteration), so a search stops reading
after ``RISINGS`` states whose reserve did not shrink (#290: its search 1.0 s -> 1.4 s, 1.9 s without that stop).
A closing failure without proof is first checked against the converged state it started from (``collapse.settles``,
:meth:`bridgefem.analysis.evidence.SlipCheck.settles`): when that state is a collapse state (evidence 3) whose F lies within
the width above ``lower``, the failure is the mechanism without retries. The verdict confirms the bracket [lower,
trial] from that very state, and the state is at its collapse to within the bracket's width, so a retry could only
reach another equilibrium at ``trial`` by raising the normal forces of the sliding joints along a flat curve: a
different non-associative collapse state, which the search is not after (campaign seed 1, #124, #184, #220 and seed
2, #12, #55, whose closing failures start from such states: each of their five retries failed again, 30 to 77 linear
solves per scene, and the brackets are the same without them).

**Support movement.** With ``movement_steps`` > 0 the solver's support movement is imposed after the self-weight,
at live load 0, in that many equal increments (friction is path dependent; a failed increment is halved), and
stays for the live load.

**Self-weight.** The search starts from the self-weight state of :func:`bridgefem.search.selfweight.carry_self_weight`
(one step, or a continuation through a stronger structure when that step fails without proof).

Statuses: "limit load found", "unstable under self-weight", "stable under self-weight" (no live load),
"no collapse up to the maximum load (locked)", "solver failure: <reason>" (a failure that shows no mechanism,
or a bracket not closed within the step budget).
"""
from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Callable, NamedTuple

import numpy as np
from petsc4py import PETSc

from ..solver.newton import ContactSolver, Iterate, PairPrediction, StepOutcome, retried
from ..status import Status
from .selfweight import carry_self_weight

LIMIT_FOUND, UNSTABLE, LOCKED, STABLE = Status.LIMIT, Status.UNSTABLE, Status.LOCKED, Status.STABLE

APPROACH = 0.5  # fraction of the distance to the target T left by an approach step
LANDING = 0.08  # an approach step that would stop within this fraction of T goes to T
PLAUSIBLE = 0.02  # failures below (1 - PLAUSIBLE) T contradict the guess (suspect)
SUSPECT = 0.25  # a suspect failure is decisive for a failing step of at most this many widths ...
SETTLED = 4.0  # ... from a state reached by a step of at most this many widths (else backtrack)
EASY_ITERATIONS = 4  # with a fill, a converged step with at most this many Newton iterations doubles the step
BACKTRACK = 4  # converged states kept for backtracking
BACKTRACK_STEP = 0.25  # after a backtrack the step is this fraction of the step that reached the discarded state
BACKTRACKS = 2  # backtracks per search: a suspect failure that recurs after them is decisive
SUBSTEP = 0.125  # a failure without proof of collapse is retried with halved steps down to this many widths
MOVEMENT_HALVINGS = 6  # a support-movement increment that fails is halved at most this many times
BUDGET = 2  # a trial that cannot close the bracket gets this many times the Newton iterations of the hardest
# converged step: on the Mohr-Coulomb fill scenes of the campaign (seeds 1 and 2) and Prestwood no converged step
# took more than 1.8 times the hardest before it, and the trials that failed at 2 to 3 times ended 1e-4 to 1e2 of the
# largest applied nodal force out of balance (a plastic Newton iteration that has not converged by then does not
# recover)
BUDGET_FLOOR = 20  # ... and at least this many: a bare ring's hardest converged step may take one iteration
# (module docstring, *Failures without proof*)
RISE = 0.5  # a collapse level that rose by at most this fraction of the step to its state is the estimate itself;
# one that rose faster, but by less than the step, is extrapolated to where its reserve vanishes
RISINGS = 3  # the search stops reading collapse states after this many whose level rose by the step or more (#290:
# 16 readings of 20 to 30 ms each, a third of its search's time, none settled)
STRADDLE = 0.5  # a collapse state's estimate lies this many widths above the target it sets (module docstring,
# *Collapse state*)
RETRY_FLOOR = 14  # without a plastic fill, a trial at a level that failed before gets at most BUDGET times the Newton
# iterations of the step that reached lower, and at least this many (module docstring, *Failures without proof*)
CLOSE = 1.0 - 1e-9  # the step after T is this fraction of the width, so that rounding keeps it inside
FUTILE_PREDICTIONS = 3  # the search stops predicting after this many predicted trials in a row that failed or found
# no settled state (seed 1 --options #138, quadratic elements: 1 of 39 predicted trials converged, 65 -> 151 s)


@dataclass
class LoadStep:
    """One attempted step; ``level`` in N per unit load factor, ``deflection`` (m, down positive) under the load;
    ``movement`` the fraction of the imposed support movement applied; ``cohesion`` the fill's raised cohesion (Pa)
    in a step of the self-weight's cohesion continuation (None: the scene's); ``mechanism``: a failed step that showed
    no equilibrium (:class:`bridgefem.solver.newton.StepOutcome`; a flat load-deflection curve counts); ``friction_factor``:
    the joints' raised friction (multiple of the scene's) in a step of the friction continuation (None: the scene's)."""

    index: int
    level: float
    converged: bool
    reason: str
    iterations: int
    factorisations: int
    residual: float
    deflection: float | None
    counts: dict
    seconds: float
    movement: float = 0.0
    cohesion: float | None = None
    mechanism: bool = False
    friction_factor: float | None = None


@dataclass
class LimitSearch:
    """Outcome of the search; ``lower``/``upper`` bracket the limit level (N per unit load factor); ``guess`` is
    the estimate of the limit level the search used (N per unit load factor; None: none); ``last`` is the last
    converged state, ``settled`` the converged state at live load 0 (after self-weight and any support movement)
    from which the live-load search started (None when it was not reached); ``failure``: what ended the search
    above ``lower``, the failed step's reason or the static bound's (empty at the cap on the load steps or a locked
    ring); ``proved``: the failed step that ended the search proved its mechanism
    (:class:`bridgefem.solver.newton.StepOutcome`), else the verdict needs other evidence (:mod:`bridgefem.analysis.evidence`)."""

    status: str
    lower: float
    upper: float | None
    tolerance: float
    steps: list[LoadStep] = field(default_factory=list)
    last: Iterate | None = None
    failure: str = ""
    guess: float | None = None
    settled: Iterate | None = None
    proved: bool = False
    static: bool = False


@dataclass
class StaticCap:
    """The static theorem's bound on a search (module docstring, *Static bound*): ``level`` the largest level at
    which an equilibrium can exist (N per unit load factor; None: no bound on the live load); ``falls``: no
    equilibrium exists under self-weight; ``admissible(step, iterate)`` checks a converged state against the
    theorem's premises, returning the answer and a sentence (collective)."""

    level: float | None
    falls: bool
    admissible: Callable[[LoadStep, Iterate], tuple[bool, str]]


@dataclass
class CollapseCheck:
    """Evidence 3 (:mod:`bridgefem.analysis.evidence`) at a converged state of a bare ring (module docstring, *Collapse
    state*): ``level(state)`` the level (N per unit load factor) at which the state's rigid blocks with its friction
    capacities (mu x its joint normal forces) collapse, on a mechanism that slides only where the state's joints are
    at their Coulomb limit (None: no such mechanism); ``settles(lower, trial, state)`` whether the state at ``lower``
    is the collapse state that settles the bracket [lower, trial], with the check in words. Both collective."""

    level: Callable[[Iterate], float | None]
    settles: Callable[[float, float, Iterate], tuple[bool, str]]


@dataclass(frozen=True)
class SearchSettings:
    """The numbers that set a limit search, chosen by the user or fixed by the scene
    (:func:`bridgefem.analysis.runner.search_settings` reads them from its keys).

    ``tolerance``: the bracket's relative width (module docstring, *Bracket rule*).
    ``initial_step``: the first live-load step (N per unit load factor; module docstring, *Steps*).
    ``max_load``: the level (N per unit load factor) at which the search stops as "locked"; 0 or less: self-weight
    only ("stable under self-weight").
    ``max_steps``: the load steps attempted in all (self-weight and support movement included) before the search is
    a solver failure.
    ``stiffness_drop`` > 0: a converged step whose secant stiffness (load over deflection increment, N/m), or
    tangent stiffness at its converged state, is below this fraction of the tangent stiffness after self-weight
    counts as failed, like a step without equilibrium: the load-deflection curve is flat (collapse of a structure
    restrained by a soft or yielding fill, which never becomes exactly singular; module docstring, *Flat curve*);
    0: no such check.
    ``movement_steps``: the increments of the solver's support movement (module docstring, *Support movement*);
    0: no movement.
    """

    tolerance: float
    initial_step: float
    max_load: float
    max_steps: int
    stiffness_drop: float = 0.0
    movement_steps: int = 0


@dataclass(frozen=True)
class SearchGuides:
    """What is known of the limit before the search: it steers the search's path, and the static bound and the
    collapse state can also end it with their proof. Each None: not known; each but the guess the same on every rank.

    ``guess``: an estimate of the limit level (N per unit load factor; e.g. the rigid-block LP's, taken from rank
    0; module docstring, *Guess*).
    ``bound``: the static theorem's bound (module docstring, *Static bound*).
    ``coarser``: the lower end of the bracket of a run on a coarser mesh (N per unit load factor; module docstring,
    *Guess*); None on a first run.
    ``collapse``: evidence 3 at the converged states of a bare ring (module docstring, *Collapse state*).
    ``predicted(level, start)``: a predicted state (combined vector) for a failed trial from ``start``, or None
    (module docstring, *Predictor*). Collective.
    ``coarser_path(trial, lower, state)``: a re-run's start of a trial from its converged ``state`` at ``lower`` on its
    coarser run's path (:class:`bridgefem.search.coarser_path.CoarserPath`), or None (module docstring, *Predictor*).
    """

    guess: float | None = None
    bound: StaticCap | None = None
    coarser: float | None = None
    collapse: CollapseCheck | None = None
    predicted: Callable[[float, Iterate], PETSc.Vec | None] | None = None
    coarser_path: Callable[[float, float, Iterate], PairPrediction | None] | None = None


@dataclass(frozen=True)
class SearchObservers:
    """Who watches the search: ``report(step)`` is called after every attempted step, ``converged(step, iterate)``
    after every converged one with its state. Both collective; by default nobody."""

    report: Callable[[LoadStep], None] = lambda step: None
    converged: Callable[[LoadStep, Iterate], None] = lambda step, iterate: None


def find_limit_load(solver: ContactSolver, deflection: Callable[[Iterate], float], settings: SearchSettings, *,
                    guides: SearchGuides = SearchGuides(), observers: SearchObservers = SearchObservers()
                    ) -> LimitSearch:
    """Run self-weight then the live-load search (module docstring) with the ``settings``, steered by the
    ``guides``, telling the ``observers`` of every step. ``deflection(state)``: the deflection (m, down positive)
    whose stiffness the flat-curve check measures (module docstring, *Flat curve*). Collective.
    """
    tolerance, bound = settings.tolerance, guides.bound
    attempt = _StepRecorder(solver, deflection, settings.stiffness_drop, observers)
    steps = attempt.steps
    falls = bound is not None and bound.falls
    first = carry_self_weight(solver, attempt, falls)
    if not first.converged:
        status = UNSTABLE if first.mechanism else Status.failure(first.reason)
        return LimitSearch(status, 0.0, 0.0 if first.mechanism else None, tolerance, steps, None, first.reason,
                           proved=first.proved, static=falls)
    state = solver.converged_slip_reference(first.iterate)
    if settings.movement_steps:
        state, failed = _impose_support_movement(solver, attempt, state, settings.movement_steps)
        if failed is not None:
            status = UNSTABLE if failed.mechanism else Status.failure(failed.reason)
            return LimitSearch(status, 0.0, 0.0 if failed.mechanism else None, tolerance, steps, state,
                               f"support movement {solver.movement:.4g} of the whole: {failed.reason}",
                               proved=failed.proved)
    settled = state
    if settings.max_load <= 0:
        return LimitSearch(STABLE, 0.0, None, tolerance, steps, state, settled=settled)
    if settings.stiffness_drop > 0:
        attempt.k_initial = _tangent_stiffness(solver, deflection, state) or math.inf
    g = guides.guess
    guess = solver.comm.bcast(g if g is not None and math.isfinite(g) and g > 0 else None, root=0)
    cap = bound.level if bound is not None and bound.level is not None and bound.level > 0 else math.inf
    aim = _first_target(cap, guess, guides.coarser, tolerance)
    search = _Search(solver, attempt, settings, replace(guides, guess=guess), settled, cap,
                     _Bracket(tolerance, settings.initial_step, state),
                     _Schedule(settings.initial_step, first.iterations, solver.material is not None,
                               settings.stiffness_drop > 0),
                     _Target(aim, guides.collapse))
    return search.run()


@dataclass
class _StepRecorder:
    """Solves and records one load step (``LoadStep``), as ``attempt(level, start, ...)`` for the self-weight, the
    support movement and the live-load search; collective. ``k_initial``: the tangent stiffness after self-weight
    (N/m; inf: no flatness check, module docstring, *Flat curve*)."""

    solver: ContactSolver
    deflection: Callable[[Iterate], float]
    stiffness_drop: float
    observers: SearchObservers
    steps: list[LoadStep] = field(default_factory=list)
    k_initial: float = math.inf

    def __call__(self, level: float, start: Iterate, start_level: float = 0.0, *,
                 predictor: PETSc.Vec | PairPrediction | None = None,
                 give_up: bool = False, iterations: int | None = None, estimate: PETSc.Vec | None = None
                 ) -> StepOutcome:
        """Solve ``level`` from the converged ``start`` at ``start_level`` (N per unit load factor), starting from
        the ``estimate``'s displacements and joint forces when given (:func:`_displaced`), and record the step;
        ``predictor``, ``give_up`` and ``iterations`` go to :meth:`bridgefem.solver.newton.ContactSolver.solve_step`."""
        t0 = time.perf_counter()
        begin = _displaced(start, estimate) if estimate is not None else start
        solver = self.solver
        out = solver.solve_step(level, begin, predictor, give_up, iterations)
        reached = self.deflection(out.iterate) if out.converged else None
        if reached is not None and self.k_initial < math.inf:
            flat = self._flat(level - start_level, reached - self.deflection(start), out)
            out, reached = (flat, None) if flat is not None else (out, reached)
        step = LoadStep(len(self.steps), level, out.converged, out.reason, out.iterations, out.factorisations,
                        out.residual, reached, out.counts, time.perf_counter() - t0, solver.movement,
                        _raised_cohesion(solver), out.mechanism,
                        solver.friction_factor if solver.friction_factor != 1.0 else None)
        self.steps.append(step)
        self.observers.report(step)
        if step.converged:
            self.observers.converged(step, out.iterate)
        return out

    def _flat(self, load: float, rise: float, out: StepOutcome) -> StepOutcome | None:
        """The converged ``out`` as a failed step with a mechanism when the load-deflection curve is flat there
        (module docstring, *Flat curve*): its secant stiffness over the step (``load`` in N per unit load factor
        over the deflection ``rise`` in m) or its tangent stiffness below ``stiffness_drop`` x ``k_initial``; else
        None."""
        secant = load / rise if rise > 0 else math.inf
        flat = self.stiffness_drop * self.k_initial
        # the tangent (one solve) only where the secant has not already shown the curve flat
        tangent = _tangent_stiffness(self.solver, self.deflection, out.iterate) if secant >= flat else None
        if min(secant, tangent or math.inf) >= flat:
            return None
        at_end = f"tangent {tangent:.3g} N/m at its end" if tangent else "tangent not needed"
        return StepOutcome(False, f"load-deflection curve flat: secant stiffness {secant:.3g} N/m over the step, "
                                  f"{at_end}: the lesser is below {self.stiffness_drop:g} x the initial "
                                  f"{self.k_initial:.3g} N/m (collapse)", out.iterations, out.residual,
                           out.factorisations, mechanism=True)


def _first_target(cap: float, guess: float | None, coarser: float | None, tolerance: float) -> float:
    """The search's target T before any collapse state's estimate (N per unit load factor; inf: none): the level
    whose width reaches just to the static bound ``cap``, else (1 - tolerance) x the ``guess``, at most (1 -
    tolerance) x the ``coarser`` run's lower end (module docstring, *Static bound*, *Guess*)."""
    target = _below(cap, tolerance) if cap < math.inf else math.inf if guess is None else (1.0 - tolerance) * guess
    return min(target, (1.0 - tolerance) * coarser) if coarser else target


class _Converged(NamedTuple):
    """A converged state of the search: its ``level`` (N per unit load factor), the ``state``, the step ``taken``
    that reached it (N per unit load factor) and its ``visit``: the count of steps attempted when it was reached
    (0: the settled state)."""

    level: float
    state: Iterate
    taken: float
    visit: int


@dataclass
class _Bracket:
    """The bracket [lower, soft] and its backtracking (module docstring, *Bracket rule*, *Guess*): the converged
    state at ``lower``, the converged states before it and the failures above it. Levels in N per unit load
    factor."""

    tolerance: float
    initial_step: float  # the width at lower = 0 is that of 1e-9 x this level
    state: Iterate  # the converged state at ``lower``
    lower: float = 0.0  # the last converged level
    taken: float = 0.0  # the step that reached lower
    visit: int = 0  # the converged state's number: the count of steps attempted when it was reached (0: the settled)
    history: deque[_Converged] = field(default_factory=lambda: deque(maxlen=BACKTRACK))  # the converged states before
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
        *Guess*)."""
        width = self.width
        return not self.stalled and (self.retry or self.soft - self.lower <= (SUSPECT * width if suspect else width))

    def closes_at(self, level: float) -> bool:
        """``level`` lies within the width of lower while the soft bound lies beyond it: a trial the width above
        lower can close the bracket there (*Collapse state*)."""
        return abs(level - self.lower) <= self.width < self.soft - self.lower

    def closing(self) -> float:
        """The trial the width above lower (*Collapse state*)."""
        return self.lower + CLOSE * self.width

    def bisection(self) -> float:
        """The trial between lower and the soft bound: the midpoint, after a linear step the width below the soft
        bound when that is higher (*Bracket rule*)."""
        middle = 0.5 * (self.lower + self.soft)
        return max(middle, _below(self.soft, self.tolerance)) if self.linear else middle

    def failed_here(self, level: float) -> bool:
        """A trial at ``level`` already failed from the converged state at lower (*Guess*)."""
        return (self.visit, level) in self.failed_from

    def failed_before(self, level: float) -> bool:
        """A trial at ``level`` already failed, from any state (*Failures without proof*)."""
        return any(failed == level for _, failed in self.failed_from)

    def advance(self, level: float, state: Iterate, visit: int, iterations: int) -> None:
        """Move lower to ``level``, converged in ``iterations`` Newton iterations to ``state`` at ``visit``; the
        state left joins the history (*Bracket rule*)."""
        jump = self.linear and level == _below(self.soft, self.tolerance)
        self.linear = iterations == 1 and not jump
        self.history.append(_Converged(self.lower, self.state, self.taken, self.visit))
        self.visit, self.taken = visit, level - self.lower
        self.lower, self.state, self.stalled = level, state, False

    def reach_soft(self) -> bool:
        """Whether lower reached the soft bound, which it then discards (*Bracket rule*)."""
        reached = self.lower >= self.soft
        if reached:
            self.soft = math.inf
        return reached

    def mark_retry(self, suspect: bool) -> None:
        """After a converged step, retry a ``suspect`` soft bound while it lies beyond the width (*Guess*)."""
        self.retry = self.soft - self.lower > self.tolerance * self.lower and suspect

    def fail(self, level: float) -> None:
        """Record the failure of the trial at ``level`` from lower."""
        self.linear = False
        self.failed_from.add((self.visit, level))

    def backs_away(self, level: float, suspect: bool) -> bool:
        """A ``suspect`` failure at ``level`` within the width of lower, a state reached by a step of more than
        ``SETTLED`` widths, backtracks, at most ``BACKTRACKS`` times (*Guess*)."""
        width = self.width
        return (suspect and level - self.lower <= width and self.taken > SETTLED * width and bool(self.history)
                and self.backtracks < BACKTRACKS)

    def backtrack(self) -> float:
        """Back to the converged state before lower, without a soft bound; returns the step that reached the
        discarded state (*Guess*)."""
        discarded = self.taken
        self.backtracks += 1
        self.lower, self.state, self.taken, self.visit = self.history.pop()
        self.soft, self.retry = math.inf, False
        return discarded

    def ends(self, level: float, suspect: bool, mechanism: bool) -> bool:
        """A failure at ``level`` ends the search: one with a ``mechanism``, a ``suspect`` one or one within
        ``SUBSTEP`` widths of lower, from a step of at most the width (``SUSPECT`` widths when suspect), unless it
        backtracks (*Bracket rule*, *Guess*, *Failures without proof*)."""
        rise, width = level - self.lower, self.width
        return (mechanism or suspect or rise <= SUBSTEP * width) \
            and rise <= (SUSPECT * width if suspect else width) and not self.backs_away(level, suspect)

    def soften(self, level: float) -> None:
        """The failure at ``level`` becomes the soft bound, stalled when it failed within the width of lower
        (*Bracket rule*)."""
        self.failed_step = level - self.lower if level < self.soft else self.failed_step
        self.soft, self.retry = level, False
        self.stalled = level - self.lower <= self.width


@dataclass
class _Schedule:
    """The step schedule and the Newton iteration budget of a trial (module docstring, *Steps*, *Failures without
    proof*). Steps in N per unit load factor."""

    step: float  # the next step (first: the initial step)
    self_weight_iterations: int  # Newton iterations of the self-weight step
    plastic: bool  # a plastic fill: a step of no more iterations than the one before it is easy too
    flat: bool  # the search checks a flat curve (a fill): a step's length is part of that criterion
    hardest: int = field(init=False)  # Newton iterations of the hardest converged step
    latest: int = field(init=False)  # Newton iterations of the step that reached lower

    def __post_init__(self) -> None:
        self.hardest = self.latest = self.self_weight_iterations

    def budget(self, again: bool) -> int:
        """Newton iterations of a trial that cannot close the bracket (*Failures without proof*): ``BUDGET`` times
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
        (*Guess*)."""
        self.step = BACKTRACK_STEP * discarded


@dataclass
class _Target:
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

    def approach(self, lower: float, step: float, failed_here: bool) -> float:
        """The approach step from ``lower`` (*Guess*): ``APPROACH`` of the distance to T left, at most ``step``
        long, to T itself when that leaves at most ``LANDING`` x T, unless T already ``failed_here``."""
        trial = min(self.level - APPROACH * (self.level - lower), lower + step)
        landing = self.level - trial <= LANDING * self.level and not failed_here
        return self.level if landing else trial

    def read(self, bracket: _Bracket) -> None:
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

    def _settled_collapse(self, bracket: _Bracket) -> float | None:
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


@dataclass
class _Search:
    """The live-load search of :func:`find_limit_load` from the settled state (module docstring): its inputs, the
    bracket (:class:`_Bracket`), the step schedule (:class:`_Schedule`) and the target (:class:`_Target`), and the
    four stages that compose them. Levels in N per unit load factor. Every method is collective."""

    solver: ContactSolver
    attempt: _StepRecorder  # solves and records one step
    settings: SearchSettings
    guides: SearchGuides  # its guess broadcast from rank 0 (None: none, or not a positive finite level)
    settled: Iterate  # the converged state at live load 0
    cap: float  # the static bound (inf: none, or voided by a state outside its premises)
    bracket: _Bracket
    schedule: _Schedule
    target: _Target
    futile: int = 0  # predicted trials in a row that failed or found no settled state (*Predictor*)

    @property
    def steps(self) -> list[LoadStep]:
        """The steps attempted."""
        return self.attempt.steps

    @property
    def plastic(self) -> bool:
        """The structure has a plastic fill (*Steps*, *Predictor*)."""
        return self.solver.material is not None

    def run(self) -> LimitSearch:
        """The four stages until a rule ends the search, the maximum load is carried or the settings' ``max_steps``
        steps were attempted."""
        while len(self.steps) < self.settings.max_steps:
            if self.bracket.lower >= self.settings.max_load:
                return self.result(LOCKED)
            trial = self.next_trial()
            out = self.solve(trial)
            found = self.take_converged(trial, out) if out.converged else self.take_failed(trial, out)
            if found is not None:
                return found
        return self.result(Status.failure(f"bracket not closed within {self.settings.max_steps} load steps"))

    def result(self, status: str, upper: float | None = None, failure: str = "", proved: bool = False,
               static: bool = False) -> LimitSearch:
        """The search's outcome with ``status`` and the bracket [lower, ``upper``]."""
        b = self.bracket
        return LimitSearch(status, b.lower, upper, b.tolerance, self.steps, b.state, failure, self.guides.guess,
                           self.settled, proved, static)

    def next_trial(self) -> float:
        """The next trial level: the soft bound when due (*Bracket rule*, *Guess*), the closing trial above a state
        within the width of its collapse (*Collapse state*), an approach step to T (*Guess*), a bisection towards the
        soft bound (*Bracket rule*), else the step (*Steps*); never above the maximum load or the level whose width
        reaches the static bound (*Static bound*)."""
        b, target = self.bracket, self.target
        if b.soft_due(not target.plausible(b.soft)):
            trial = b.soft
        elif target.foreseen is not None and b.closes_at(target.foreseen):
            trial = b.closing()
        elif b.lower < target.level < b.soft:
            trial = target.approach(b.lower, self.schedule.step, b.failed_here(target.level))
        elif b.soft < math.inf:
            trial = b.bisection()
        else:
            trial = b.lower + self.schedule.step
        return min(trial, self.settings.max_load, _below(self.cap, b.tolerance))

    def solve(self, trial: float) -> StepOutcome:
        """Solve ``trial`` from ``lower``: with the secant's predictor and start (*Predictor*) and the budget of a
        trial that cannot close the bracket; a failure that would end the search without proof, or a suspect one, is
        settled by the collapse state or retried (*Failures without proof*); a trial that cannot close the bracket and
        failed without proof is solved once more from the ``predicted`` state (*Predictor*)."""
        b = self.bracket
        lower, state = b.lower, b.state
        secant = _secant(b.history[-1], lower, state, trial) if b.history and b.history[-1].level > 0 else None
        far = trial - lower > b.width  # cannot close the bracket
        path = self.guides.coarser_path(trial, lower, state) if far and self.guides.coarser_path else None
        predictor = path or (secant if far else None)  # a re-run's coarser path, or two live-load states; not closing
        estimate = secant if self.plastic else None
        budget = self.schedule.budget(not self.plastic and b.failed_before(trial)) if far else None
        out = self.attempt(trial, state, lower, predictor=predictor, give_up=True, iterations=budget, estimate=estimate)
        if not out.converged and self._final(trial, out) and not out.proved and (
                not self.target.plausible(trial) or not out.mechanism):
            out = _settled(self.target.collapse, lower, trial, state, out) or retried(
                self.solver, lambda: self.attempt(trial, state, lower, give_up=True, iterations=budget), out)
        predicted = self.guides.predicted
        if out.converged or out.proved or not far or predicted is None or self.futile >= FUTILE_PREDICTIONS:
            return out
        x = predicted(trial, state)  # *Predictor*: once more from the predicted state
        again = self.attempt(trial, state, lower, predictor=x, give_up=True, iterations=budget) if x is not None else out
        helped = again.converged or again.proved
        self.futile = 0 if helped else self.futile + 1
        return again if helped else out

    def _final(self, trial: float, out: StepOutcome) -> bool:
        """The failure ``out`` at ``trial`` ends the search (:meth:`_Bracket.ends`); the same before and after its
        retries, which run only when it holds without a mechanism or with a suspect trial."""
        return self.bracket.ends(trial, not self.target.plausible(trial), out.mechanism)

    def take_converged(self, trial: float, out: StepOutcome) -> LimitSearch | None:
        """Move ``lower`` to the converged ``trial``: the static bound's end (*Static bound*), the soft bound cleared
        at or below it, the collapse-state reading and the next step (*Steps*). The outcome when the search ends."""
        b, target = self.bracket, self.target
        arrived = b.lower < target.level <= trial
        b.advance(trial, self.solver.converged_slip_reference(out.iterate), len(self.steps), out.iterations)
        if self.cap - b.lower <= b.tolerance * b.lower:
            ended = self._static_end(out.iterate)
            if ended is not None:
                return ended
        cleared = b.reach_soft() and not self.plastic
        target.read(b)
        b.mark_retry(not target.plausible(b.soft))
        self.schedule.converged(out.iterations, b.taken, CLOSE * b.tolerance * b.lower if arrived else None,
                                b.failed_step if cleared else None)
        return None

    def _static_end(self, iterate: Iterate) -> LimitSearch | None:
        """The bracket [lower, the static bound] when the converged ``iterate`` within its width is admissible for
        it; else the bound is voided and None (*Static bound*)."""
        admissible, check = self.guides.bound.admissible(self.steps[-1], iterate)
        if admissible:
            return self.result(LIMIT_FOUND, self.cap, "no trial above the bracket: its upper end is the static "
                               "theorem's bound, the rigid-block LP under the FE's own loads (the converged state's "
                               f"joint resultants are admissible for it; {check})", static=True)
        self.cap = math.inf
        return None

    def take_failed(self, trial: float, out: StepOutcome) -> LimitSearch | None:
        """The failed ``trial``: a backtrack (*Guess*), the end of the search (*Bracket rule*), else a soft bound and
        a halved step (*Steps*); then the collapse-state reading. The outcome when the search ends."""
        b = self.bracket
        b.fail(trial)
        if b.backs_away(trial, not self.target.plausible(trial)):
            self.schedule.back_off(b.backtrack())
        elif self._final(trial, out):
            status = LIMIT_FOUND if out.mechanism else Status.failure(out.reason)
            return self.result(status, trial if out.mechanism else None, out.reason, out.proved)
        else:
            self.schedule.halve(trial - b.lower)
            b.soften(trial)
        self.target.read(b)
        return None


def _settled(collapse: CollapseCheck | None, lower: float, trial: float, state: Iterate, failed: StepOutcome
             ) -> StepOutcome | None:
    """The closing trial at ``trial`` that ``failed`` without proof from the converged ``state`` at ``lower``, as a
    mechanism when ``collapse`` finds that state a collapse state settling the bracket [lower, trial] (module
    docstring, *Collapse state*), else None (the failure is retried). Collective."""
    if collapse is None:
        return None
    settles, check = collapse.settles(lower, trial, state)
    return replace(failed, mechanism=True, reason=f"{failed.reason}; the converged state below is a collapse "
                                                  f"state: {check}") if settles else None


def _below(level: float, tolerance: float) -> float:
    """The level whose width reaches just to ``level`` (N per unit load factor): a failure at ``level`` from there
    closes the bracket."""
    return level / (1.0 + CLOSE * tolerance)


def _secant(previous: _Converged, level: float, state: Iterate, trial: float) -> PETSc.Vec:
    """The combined vector extrapolated to ``trial`` along the secant from the converged ``previous`` to ``state``
    at ``level`` (levels in N per unit load factor)."""
    before, earlier = previous.level, previous.state
    x = state.x.copy()
    x.axpy((trial - level) / (level - before), state.x - earlier.x)
    return x


def _displaced(state: Iterate, predictor: PETSc.Vec) -> Iterate:
    """The converged ``state`` with its displacements and joint forces replaced by the ``predictor``'s (the Newton
    iteration's first linearisation point, and the origin of the modes its diverging solves are judged by, which
    are beyond a million times the self-weight response); its active set, slip reference and plastic strain stay the
    converged state's (module docstring, *Predictor*)."""
    return Iterate(predictor, state.active, state.slip_ref, state.plastic_strain)


def _tangent_stiffness(solver: ContactSolver, deflection: Callable[[Iterate], float], state: Iterate
                       ) -> float | None:
    """Tangent stiffness dP/d(delta) (N/m) of the load-deflection curve at the converged ``state`` with its joints'
    active set held (:meth:`ContactSolver.live_load_tangent`; call it right after the step that reached the state):
    one solve. None when that system cannot be solved or its deflection is not positive (no tangent). Collective."""
    tangent = solver.live_load_tangent(state)
    compliance = deflection(tangent) if tangent is not None else 0.0
    return 1.0 / compliance if compliance > 0 else None


def _raised_cohesion(solver: ContactSolver) -> float | None:
    """The fill's cohesion (Pa) while the self-weight's cohesion continuation raises it, else None."""
    fill = solver.material
    if fill is None or fill.material.cohesion == fill.cohesion:
        return None
    return fill.material.cohesion


def _impose_support_movement(solver: ContactSolver, attempt: Callable[[float, Iterate], StepOutcome], state: Iterate,
                             steps: int) -> tuple[Iterate, StepOutcome | None]:
    """Impose the support movement at live load 0 in ``steps`` equal increments from the converged ``state``; a
    failed increment is halved and retried from the last converged state, down to ``MOVEMENT_HALVINGS`` times.
    Returns the last converged state and the failed outcome (None when the whole movement is imposed)."""
    done, step = 0.0, 1.0 / steps
    while done < 1.0:
        trial = min(1.0, done + step)
        solver.set_support_movement(trial)
        out = attempt(0.0, state)
        if out.converged:
            done, state = trial, solver.converged_slip_reference(out.iterate)
            continue
        step /= 2
        if step < 0.5 ** MOVEMENT_HALVINGS / steps:
            solver.set_support_movement(done)
            return state, out
    return state, None


def monitor_deflection(solver: ContactSolver, monitor: np.ndarray) -> Callable[[Iterate], float]:
    """Mean downward displacement (m) of the monitored nodes (blocked owned indices) over all ranks."""
    comm = solver.comm

    def deflection(it: Iterate) -> float:
        u = it.x.array[:solver.n_u]
        local = (-u[2 * monitor + 1].sum(), len(monitor))
        total, count = comm.allreduce(np.array(local, dtype=float))
        return float(total / count) if count else float("nan")

    return deflection
