"""The limit search: self-weight first, then the live load raised until no equilibrium exists.

The limit (collapse) load is found by load incrementation, as in the seed paper (Drosopoulos, Stavroulakis &
Massalas 2006): the live load is raised step by step, each step an equilibrium of the elastic voussoirs with
unilateral contact and Coulomb friction at the joints (:class:`bridgefem.solver.newton.ContactSolver`), and the lack
of a solution at a load level marks the onset of collapse. Levels are live-load levels P in N per unit load factor
(each live load is its ``factor`` x P); deflections are in m, positive down. Incremental friction makes the response
path dependent, so every trial is solved from the last converged state ``lower``, and a failed trial is discarded.

**The algorithm** (:func:`find_limit_load`):

1. *Self-weight*: the dead load in one step, else a continuation through a stronger structure
   (:mod:`bridgefem.search.selfweight`). A failure ends the search: "unstable under self-weight" when it shows a
   mechanism, else a solver failure.
2. *Support movement*: with ``movement_steps`` > 0 the solver's support movement is imposed at live load 0 in that
   many equal increments, a failed increment halved (at most ``MOVEMENT_HALVINGS`` times); it stays for the live
   load. The state reached is the *settled* state, from which the live load starts.
3. Without live loads (``max_load`` <= 0) the search ends: "stable under self-weight". With a flat-curve check the
   settled state's tangent stiffness is measured (:mod:`bridgefem.search.step`, *Flat curve*); with a collapse
   state of its own (``guides.collapse.at_collapse``) each converged live-load state is read against the settled
   one (:mod:`bridgefem.search.step`, *Collapse state*).
4. The target T is set from the static bound, the guess and a coarser run's bracket (:mod:`bridgefem.search.target`,
   *Guess*).
5. Until a rule ends the search, ``max_load`` or the settings' ``enough`` level (as it is before each trial) is
   carried ("locked") or ``max_steps`` steps were attempted (a solver failure), four stages repeat
   (:class:`_Search`):

   a. ``next_trial`` chooses the level: the soft bound when due, the closing trial above a state within the width
      of its collapse level, an approach step to T, a bisection towards the soft bound, else ``lower`` plus the
      step; never above ``max_load`` or the level whose width reaches the static bound;
   b. ``solve`` solves it from ``lower`` (*Predictor*, *Failures without proof*);
   c. ``take_converged`` moves ``lower`` up to it, ends the search on the static bound (*Static bound*), clears a
      soft bound it reached, reads the collapse state and sets the next step;
   d. ``take_failed`` backtracks, ends the search by the bracket rule, or makes the failure the soft bound and
      halves the step; then it reads the collapse state.

The stages compose four pieces, one job each: the bracket and its backtracking
(:class:`bridgefem.search.bracket.Bracket`: *Bracket rule*, *Suspect failures*), the step schedule and the trial
budgets (:class:`bridgefem.search.schedule.StepSchedule`: *Steps*, *Trial budgets*), the target and the
collapse-state readings (:class:`bridgefem.search.target.Target`: *Guess*, *Collapse state*), and the step recorder
(:class:`bridgefem.search.step.StepRecorder`: *Flat curve*). What the search takes and gives:
:mod:`bridgefem.search.records`.

**Static bound.** On a bare ring the static theorem bounds every equilibrium of the FE from above (evidence 4 of
:mod:`bridgefem.analysis.evidence`): ``bound.level`` is the collapse level of the rigid-block LP on the same joints
under the FE's own loads.

1. No trial lies above the level whose width reaches just to the bound: a state that converges there already ends
   the search with a bracket within the tolerance, while a level nearer the bound is at the FE's limit or beyond
   it, where the curve is flat and the Newton method struggles.
2. A step that converges within the width of the bound ends the search with the bracket [lower, ``bound.level``]
   once ``bound.admissible`` has checked that state against the theorem's premises (its joint resultants within the
   LP's rows); a state that fails the check voids the bound, and the search goes on without it.
3. A failure below the bound ends the search by the bracket rule (sliding collapses of elastic blocks stop below
   the LP): the bound removes trials above it and ends a bracket that it already proves, nothing else.
4. With ``bound.falls`` no equilibrium under self-weight exists: a failed self-weight step is the answer, without
   continuations or retries.

**Predictor.** Where a Newton iteration starts changes its path, never what counts as converged.

1. A trial more than the width above ``lower`` starts from the active set predicted by the secant through the last
   two converged live-load states, extrapolated to the trial (the self-weight state is a poor start for a secant):
   on a load path whose joints open and slide progressively that saves the first Newton iteration. A bare ring's
   re-run on a finer mesh starts such a trial, within its coarser run's path, from that path's increment over the
   step instead (``guides.coarser_path``, :mod:`bridgefem.search.coarser_path`).
2. A trial within the width of ``lower`` (one that can close the bracket) starts from the converged active set, so
   that its failure is the Newton method's own evidence.
3. With a plastic fill every trial after two live-load states, the closing ones too, also starts from the secant's
   displacements and joint forces, its slip reference and plastic strain the converged state's: the yielding zone
   then starts where the last two steps were taking it, instead of being carried there again by a nearly singular
   tangent in short line-searched steps.
4. A trial more than the width above ``lower`` that failed without proof is solved once more from the state
   ``guides.predicted`` proposes for it (:class:`bridgefem.solver.tresca.TrescaPredictor`: the FE's own step with
   Tresca friction at its Coulomb fixed point, built for every bare ring), before the step is halved; its outcome
   is judged as any other.

**Failures without proof.** A failure that shows no mechanism (the Newton method not converging) is never decisive:

1. the search halves the step towards it, down to ``SUBSTEP`` widths (:mod:`bridgefem.search.bracket`), and only
   then reports a solver failure;
2. a failure that would end the search without proof, or a suspect one, is first checked against the collapse
   state it started from (:mod:`bridgefem.search.target`, *Collapse state*, step 4), else solved again with the
   solver's other settings (:func:`bridgefem.solver.newton.retried`); a retry that converges continues the search.
   A closing trial that every setting fails ends the search as a limit only where its state is a collapse state
   (step 5 there: the bracket then ends at that state's collapse level), else as a solver failure.
   A failure read off a converged equilibrium (a flat load-deflection curve, a collapse state under an elastic
   fill: :mod:`bridgefem.search.step`) is not a solver's failure and is not solved again: the other settings
   reach the same equilibrium and the same reading, at the cost of their Newton iterations;
3. live-load trials are solved with ``give_up`` (the solver's *Damping chains*): a Newton iteration that keeps
   wandering into mechanisms stops early, as such a failure, instead of spending its iterations; a trial that
   cannot close the bracket has a budget of Newton iterations (:mod:`bridgefem.search.schedule`, *Trial budgets*).

Statuses: "limit load found", "unstable under self-weight", "stable under self-weight" (no live load), "no collapse
up to the maximum load (locked)", "solver failure: <reason>" (a failure that shows no mechanism, or a bracket not
closed within the step budget) (:mod:`bridgefem.status`).

Safeguards:

- *Static cap* (Static bound, 1): the search never tries a level where the FE's curve is flat at its limit; the
  bracket closes on a converged state and the theorem instead.
- *Admissibility before ending on the bound* (Static bound, 2): the theorem's premises are checked on the converged
  state within the solver's own tolerances, so a state that bends the joint law cannot close the bracket.
- *Retries with other settings* (Failures without proof, 2): a failure without proof that would end the search is
  never accepted on one setting's word.
- *Prediction cap* ``FUTILE_PREDICTIONS`` (Predictor, 4): a predicted trial costs up to several QPs and a trial's
  budget, so the search stops predicting after that many predicted trials in a row that did not help.
- *Step cap* ``max_steps``: a search that cannot close its bracket ends as a solver failure, not in a loop.
- *Halved support movement* ``MOVEMENT_HALVINGS``: a movement that friction cannot follow in one increment is
  imposed in smaller ones, and a movement that still fails is the answer.

References: G. A. Drosopoulos, G. E. Stavroulakis & C. V. Massalas (2006), Limit analysis of a single span masonry
bridge with unilateral frictional contact interfaces, Engineering Structures 28 (load incrementation to the limit
load); R. K. Livesley (1978), Limit analysis of structures formed from rigid blocks, IJNME 12 (the rigid-block LP of
the static bound); M. Gilbert, C. Casapulla & H. M. Ahmed (2006), Limit analysis of masonry block structures with
non-associative frictional joints using linear programming, Computers & Structures 84 (the Tresca fixed point).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

from petsc4py import PETSc

from ..solver.newton import ContactSolver, Iterate, StepOutcome, retried
from ..status import COLLAPSE_END, Status
from .bracket import CLOSE, Bracket, Converged, below
from .records import CollapseCheck, LimitSearch, LoadStep, SearchGuides, SearchObservers, SearchSettings
from .schedule import StepSchedule
from .selfweight import carry_self_weight
from .step import StepRecorder, tangent_stiffness
from .target import Target, first_target

LIMIT_FOUND, UNSTABLE, LOCKED, STABLE = Status.LIMIT, Status.UNSTABLE, Status.LOCKED, Status.STABLE

MOVEMENT_HALVINGS = 6  # a support-movement increment that fails is halved at most this many times
FUTILE_PREDICTIONS = 3  # the search stops predicting after this many predicted trials in a row that failed or found
# no settled state (module docstring, *Predictor*)


def find_limit_load(solver: ContactSolver, deflection: Callable[[Iterate], float], settings: SearchSettings, *,
                    guides: SearchGuides = SearchGuides(), observers: SearchObservers = SearchObservers()
                    ) -> LimitSearch:
    """Run self-weight then the live-load search (module docstring, steps 1-5) with the ``settings``, steered by the
    ``guides``, telling the ``observers`` of every step. ``deflection(state)``: the deflection (m, down positive)
    whose stiffness the flat-curve check measures (:mod:`bridgefem.search.step`, *Flat curve*). Collective.
    """
    tolerance, bound = settings.tolerance, guides.bound
    attempt = StepRecorder(solver, deflection, settings.stiffness_drop, tolerance, observers)
    steps = attempt.steps
    falls = bound is not None and bound.falls
    first = carry_self_weight(solver, attempt, falls, guides.self_weight_states)
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
        attempt.k_initial = tangent_stiffness(solver, deflection, state) or math.inf
    attempt.floor = guides.floor
    if guides.collapse is not None and guides.collapse.at_collapse is not None:
        reading = guides.collapse.at_collapse
        attempt.at_collapse = lambda level, it: reading(level, it, settled)
    g = guides.guess
    guess = solver.comm.bcast(g if g is not None and math.isfinite(g) and g > 0 else None, root=0)
    cap = bound.level if bound is not None and bound.level is not None and bound.level > 0 else math.inf
    aim = first_target(cap, guess, guides.coarser, tolerance)
    search = _Search(solver, attempt, settings, replace(guides, guess=guess), settled, cap,
                     Bracket(tolerance, settings.initial_step, state),
                     StepSchedule(settings.initial_step, first.iterations, solver.material is not None,
                                  settings.stiffness_drop > 0),
                     Target(aim, guides.collapse))
    return search.run()


@dataclass
class _Search:
    """The live-load search of :func:`find_limit_load` from the settled state (module docstring, step 5): its
    inputs, the bracket (:class:`bridgefem.search.bracket.Bracket`), the step schedule
    (:class:`bridgefem.search.schedule.StepSchedule`) and the target (:class:`bridgefem.search.target.Target`), and
    the four stages that compose them. Levels in N per unit load factor. Every method is collective."""

    solver: ContactSolver
    attempt: StepRecorder  # solves and records one step
    settings: SearchSettings
    guides: SearchGuides  # its guess broadcast from rank 0 (None: none, or not a positive finite level)
    settled: Iterate  # the converged state at live load 0
    cap: float  # the static bound (inf: none, or voided by a state outside its premises)
    bracket: Bracket
    schedule: StepSchedule
    target: Target
    futile: int = 0  # predicted trials in a row that failed or found no settled state (*Predictor*)

    @property
    def steps(self) -> list[LoadStep]:
        """The steps attempted."""
        return self.attempt.steps

    @property
    def plastic(self) -> bool:
        """The structure has a plastic fill (*Predictor*; :mod:`bridgefem.search.schedule`, *Steps*)."""
        return self.solver.material is not None

    def run(self) -> LimitSearch:
        """The four stages until a rule ends the search, the maximum load or the ``enough`` level is carried or the
        settings' ``max_steps`` steps were attempted."""
        while len(self.steps) < self.settings.max_steps:
            if self.bracket.lower >= min(self.settings.max_load, self.settings.enough_level()):
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
        """The next trial level (module docstring, step 5a): the soft bound when due (*Bracket rule*, *Suspect
        failures*), the closing trial above a state within the width of its collapse (*Collapse state*), an
        approach step to T (*Guess*), a bisection towards the soft bound (*Bracket rule*), else the step (*Steps*);
        never above the maximum load or the level whose width reaches the static bound (*Static bound*)."""
        b, target = self.bracket, self.target
        if b.soft_due(not target.plausible(b.soft)):
            trial = b.soft
        elif target.foreseen is not None and b.closes_at(target.foreseen):
            trial = b.closing()
        elif b.lower < target.level < b.soft:
            trial = target.approach(b.lower, self.schedule.step, b.landing_refused(target.level), b.width)
        elif b.soft < math.inf:
            trial = b.bisection()
        else:
            trial = b.lower + self.schedule.step
        return min(trial, self.settings.max_load, below(self.cap, b.tolerance))

    def solve(self, trial: float) -> StepOutcome:
        """Solve ``trial`` from ``lower`` (module docstring, step 5b): with the secant's predictor and start
        (*Predictor*) and the budget of a trial that cannot close the bracket; a failure that would end the search
        without proof, or a suspect one, is settled by the collapse state or retried (*Failures without proof*); a
        trial that cannot close the bracket and failed without proof is solved once more from the ``predicted``
        state (*Predictor*)."""
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
            out = _settled(self.target.collapse, lower, trial, state, out) or (out if out.equilibrium else retried(
                self.solver, lambda: self.attempt(trial, state, lower, give_up=True, iterations=budget), out))
            if not (out.converged or out.mechanism or far):
                out = _ended(self.target.collapse, lower, trial, state, out) or out
        predicted = self.guides.predicted
        if out.converged or out.proved or not far or predicted is None or self.futile >= FUTILE_PREDICTIONS:
            return out
        x = predicted(trial, state)  # *Predictor*: once more from the predicted state
        again = (self.attempt(trial, state, lower, predictor=x, give_up=True, iterations=budget) if x is not None
                 else out)
        helped = again.converged or again.proved
        self.futile = 0 if helped else self.futile + 1
        return again if helped else out

    def _final(self, trial: float, out: StepOutcome) -> bool:
        """The failure ``out`` at ``trial`` ends the search (:meth:`Bracket.ends`); the same before and after its
        retries, which run only when it holds without a mechanism or with a suspect trial."""
        return self.bracket.ends(trial, not self.target.plausible(trial), out.mechanism)

    def take_converged(self, trial: float, out: StepOutcome) -> LimitSearch | None:
        """Move ``lower`` to the converged ``trial`` (module docstring, step 5c): the static bound's end (*Static
        bound*), the soft bound cleared at or below it, the collapse-state reading and the next step (*Steps*). The
        outcome when the search ends."""
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
        """The failed ``trial`` (module docstring, step 5d): a backtrack (*Suspect failures*), the end of the search
        (*Bracket rule*), else a soft bound and a halved step (*Steps*); then the collapse-state reading. The outcome
        when the search ends."""
        b = self.bracket
        b.fail(trial)
        if b.backs_away(trial, not self.target.plausible(trial)):
            self.schedule.back_off(b.backtrack())
        elif self._final(trial, out):
            status = LIMIT_FOUND if out.mechanism else Status.failure(out.reason)
            return self.result(status, (out.upper or trial) if out.mechanism else None, out.reason, out.proved)
        else:
            self.schedule.halve(trial - b.lower)
            b.soften(trial)
        self.target.read(b)
        return None


def _settled(collapse: CollapseCheck | None, lower: float, trial: float, state: Iterate, failed: StepOutcome
             ) -> StepOutcome | None:
    """The closing trial at ``trial`` that ``failed`` without proof from the converged ``state`` at ``lower``, as a
    mechanism when ``collapse`` finds that state a collapse state settling the bracket [lower, trial]
    (:mod:`bridgefem.search.target`, *Collapse state*, step 4), else None (the failure is retried). Collective."""
    if collapse is None:
        return None
    settles, check = collapse.settles(lower, trial, state)
    return replace(failed, mechanism=True, reason=f"{failed.reason}; the converged state below is a collapse "
                                                  f"state: {check}") if settles else None


def _ended(collapse: CollapseCheck | None, lower: float, trial: float, state: Iterate, failed: StepOutcome
           ) -> StepOutcome | None:
    """The closing trial at ``trial`` that ``failed`` without proof from the converged ``state`` at ``lower`` with
    every solver setting, as a mechanism whose bracket ends where ``collapse`` reads that state's collapse
    (:mod:`bridgefem.search.target`, *Collapse state*, step 5), else None (a solver failure). Collective."""
    if collapse is None:
        return None
    upper, check = collapse.upper_end(lower, trial, state)
    return replace(failed, mechanism=True, upper=upper, reason=f"{failed.reason}; the converged state below is a "
                   f"collapse state and {COLLAPSE_END}: {check}") if upper is not None else None


def _secant(previous: Converged, level: float, state: Iterate, trial: float) -> PETSc.Vec:
    """The combined vector extrapolated to ``trial`` along the secant from the converged ``previous`` to ``state``
    at ``level`` (levels in N per unit load factor)."""
    before, earlier = previous.level, previous.state
    x = state.x.copy()
    x.axpy((trial - level) / (level - before), state.x - earlier.x)
    return x


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


