"""What a limit search takes and what it gives (:mod:`bridgefem.search.pathfollow`): its settings, its guides (what
is known of the limit before it starts), its observers, and the records of its load steps and of its outcome.

Levels are live-load levels P in N per unit load factor: the scene's live loads are each ``factor`` x P
(:mod:`bridgefem.analysis.runner`, *Load vocabulary*). Deflections are in m, positive down.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterator

from petsc4py import PETSc

from ..solver.newton import Iterate, PairPrediction


@dataclass
class LoadStep:
    """One attempted step; ``level`` in N per unit load factor, ``deflection`` (m, down positive) under the load;
    ``movement`` the fraction of the imposed support movement applied; ``cohesion`` the fill's raised cohesion (Pa)
    in a step of the self-weight's cohesion continuation (None: the scene's); ``mechanism``: a failed step that showed
    no equilibrium (:class:`bridgefem.solver.newton.StepOutcome`; a flat load-deflection curve counts);
    ``friction_factor``: the joints' raised friction (multiple of the scene's) in a step of the friction
    continuation (None: the scene's)."""

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
    (:class:`bridgefem.solver.newton.StepOutcome`), else the verdict needs other evidence
    (:mod:`bridgefem.analysis.evidence`); ``static``: the search ended on the static bound (its upper end is the
    bound's level, :mod:`bridgefem.search.pathfollow`, *Static bound*)."""

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
    """The static theorem's bound on a search (:mod:`bridgefem.search.pathfollow`, *Static bound*): ``level`` the
    largest level at which an equilibrium can exist (N per unit load factor; None: no bound on the live load);
    ``falls``: no equilibrium exists under self-weight; ``admissible(step, iterate)`` checks a converged state against
    the theorem's premises, returning the answer and a sentence (collective)."""

    level: float | None
    falls: bool
    admissible: Callable[[LoadStep, Iterate], tuple[bool, str]]


def _no_level(state: Iterate) -> float | None:
    """No estimate of the limit from a state."""
    return None


def _never(lower: float, trial: float, state: Iterate) -> tuple[bool, str]:
    """No state settles a closing trial's bracket."""
    return False, ""


def _no_end(lower: float, trial: float, state: Iterate) -> tuple[float | None, str]:
    """No state ends a bracket whose closing trial every solver setting failed."""
    return None, ""


@dataclass
class CollapseCheck:
    """A converged state read as a collapse state (:mod:`bridgefem.search.target`, *Collapse state*): evidence 3
    (:mod:`bridgefem.analysis.evidence`) on a bare ring, evidence 5 under an elastic fill. Levels in N per unit load
    factor; every callable collective.

    ``level(state)``: the level at which the state's rigid blocks with its friction capacities (mu x its joint
    normal forces) collapse, on a mechanism that slides only where the state's joints are at their Coulomb limit,
    the search's estimate of the limit (None: no such mechanism).
    ``settles(lower, trial, state)``: whether the state at ``lower`` is the collapse state that settles the bracket
    [lower, trial] of a closing trial, with the check in words.
    ``upper_end(lower, trial, state)``: the bracket's upper end (at least ``trial``) when the state at ``lower`` is
    the collapse state that confirms [lower, trial] after every solver setting failed the closing trial without
    proof (:mod:`bridgefem.search.target`, *Collapse state*, step 5), with the check in words; None: no such state.
    ``at_collapse(level, state, settled)``: whether the converged live-load ``state`` at ``level`` is a collapse
    state by itself, with the check in words; its step then counts as failed, with a mechanism
    (:mod:`bridgefem.search.step`, *Collapse state*; ``settled``: the converged state at live load 0). None: no such
    reading."""

    level: Callable[[Iterate], float | None] = _no_level
    settles: Callable[[float, float, Iterate], tuple[bool, str]] = _never
    upper_end: Callable[[float, float, Iterate], tuple[float | None, str]] = _no_end
    at_collapse: Callable[[float, Iterate, Iterate], tuple[bool, str]] | None = None


@dataclass(frozen=True)
class SearchSettings:
    """The numbers that set a limit search, chosen by the user or fixed by the scene
    (:func:`bridgefem.analysis.runner.search_settings` reads them from its keys).

    ``tolerance``: the bracket's relative width (:mod:`bridgefem.search.bracket`, *Bracket rule*).
    ``initial_step``: the first live-load step (N per unit load factor; :mod:`bridgefem.search.schedule`, *Steps*).
    ``max_load``: the level (N per unit load factor) at which the search stops as "locked"; 0 or less: self-weight
    only ("stable under self-weight").
    ``max_steps``: the load steps attempted in all (self-weight and support movement included) before the search is
    a solver failure.
    ``stiffness_drop`` > 0: a converged step whose secant stiffness (load over deflection increment, N/m), or
    tangent stiffness at its converged state, is below this fraction of the tangent stiffness after self-weight, and
    whose curve's plateau, fitted to its last converged states, lies within ``tolerance`` above it, counts as failed,
    like a step without equilibrium: the load-deflection curve is flat (collapse of a structure restrained by a soft
    or yielding fill, which never becomes exactly singular; :mod:`bridgefem.search.step`, *Flat curve*);
    0: no such check.
    ``movement_steps``: the increments of the solver's support movement (:mod:`bridgefem.search.pathfollow`, *Support
    movement*); 0: no movement.
    ``enough``: a level (N per unit load factor) whose carrying also ends the search as "locked", for a caller that
    asks only whether the structure carries it; unlike ``max_load`` it bounds no trial, so the path, and the bracket
    of a structure that collapses below it, are those of the search without it; inf: none. Or a function giving
    that level, asked before every trial (:meth:`enough_level`), for a caller whose level can fall while the search
    runs; collective, the same on every rank.
    """

    tolerance: float
    initial_step: float
    max_load: float
    max_steps: int
    stiffness_drop: float = 0.0
    movement_steps: int = 0
    enough: float | Callable[[], float] = math.inf

    def enough_level(self) -> float:
        """The ``enough`` level now (collective when ``enough`` is a function)."""
        return self.enough() if callable(self.enough) else self.enough


@dataclass(frozen=True)
class SearchGuides:
    """What is known of the limit before the search: it steers the search's path, and the static bound and the
    collapse state can also end it with their proof. Each None: not known; each but the guess the same on every rank.

    ``guess``: an estimate of the limit level (N per unit load factor; e.g. the rigid-block LP's, taken from rank
    0; :mod:`bridgefem.search.target`, *Guess*).
    ``bound``: the static theorem's bound (:mod:`bridgefem.search.pathfollow`, *Static bound*).
    ``coarser``: the lower end of the bracket of a run on a coarser mesh (N per unit load factor;
    :mod:`bridgefem.search.target`, *Guess*); None on a first run.
    ``collapse``: the collapse-state readings of the converged states (:class:`CollapseCheck`;
    :mod:`bridgefem.search.target`, *Collapse state*).
    ``predicted(level, start)``: a predicted state (combined vector) for a failed trial from ``start``, or None
    (:mod:`bridgefem.search.pathfollow`, *Predictor*). Collective.
    ``self_weight_states(level, start)``: predicted states (combined vectors) for a self-weight step that the one
    step and the continuation did not solve (:class:`bridgefem.solver.condensed.CondensedPredictor`), or None
    (:mod:`bridgefem.search.selfweight`, step 2). Collective.
    ``coarser_path(trial, lower, state)``: a re-run's start of a trial from its converged ``state`` at ``lower`` on its
    coarser run's path (:class:`bridgefem.search.coarser_path.CoarserPath`), or None
    (:mod:`bridgefem.search.pathfollow`, *Predictor*).
    ``floor(level)``: a level (N per unit load factor) that a lower bound of the rigid-plastic collapse proves
    carried (a fill's conic lower bound), decided against ``level`` (N per unit load factor); None: none
    (:mod:`bridgefem.search.step`, *Flat curve*, step 4). Collective.
    """

    guess: float | None = None
    bound: StaticCap | None = None
    coarser: float | None = None
    collapse: CollapseCheck | None = None
    predicted: Callable[[float, Iterate], PETSc.Vec | None] | None = None
    coarser_path: Callable[[float, float, Iterate], PairPrediction | None] | None = None
    self_weight_states: Callable[[float, Iterate], Iterator[PETSc.Vec]] | None = None
    floor: Callable[[float], float | None] | None = None


@dataclass(frozen=True)
class SearchObservers:
    """Who watches the search: ``report(step)`` is called after every attempted step, ``converged(step, iterate)``
    after every converged one with its state. Both collective; by default nobody."""

    report: Callable[[LoadStep], None] = lambda step: None
    converged: Callable[[LoadStep, Iterate], None] = lambda step, iterate: None

