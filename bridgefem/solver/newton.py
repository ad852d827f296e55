"""One load step of elastic blocks with joint laws: the semismooth Newton (primal-dual active-set) method.

**The problem.** Unknowns: the displacements u (m) and the joint forces lam (N, two per joint pair: normal, then
tangential; lam_n > 0 is compression). At a live-load level P (N per unit load factor):

    K u - G^T lam = f_dead + P f_live                  (equilibrium of the voussoirs, N)
    (G u + g, lam) obeys the joint law at every pair   (:mod:`bridgefem.laws.base`; g: an imposed ground movement)

with G the relative displacement operator of :mod:`bridgefem.fe.pairs`. The joint law (unilateral contact and Coulomb
friction, :class:`bridgefem.laws.coulomb.CoulombJoints`; the seed paper, eqs. 1-6) is given to the solver as an object
and is the only place that knows the pairs' states. Written with the complementarity functions of Alart & Curnier
(1991, CMAME 92) the law is a semismooth equation; its Newton method is the primal-dual active-set method
(Hintermüller, Ito & Kunisch 2002, SIAM J. Optim. 13; for contact Hüeber & Wohlmuth 2005, CMAME 194; with Coulomb
friction Hüeber, Stadler & Wohlmuth 2008, SIAM J. Sci. Comput. 30): guess which pairs are open, holding or sliding
(the *active set*), solve the problem that is linear for that guess, classify the solution again, until the guess no
longer changes. With a Mohr-Coulomb fill the stiffness block is the fill's consistent tangent
(:meth:`bridgefem.solver.system.ContactSystem.linearise`): each iteration is then a Newton step for the fill and an
active-set step for the joints at once.

**The algorithm** (:meth:`ContactSolver.solve_step`), from a converged state, one iteration
(:meth:`ContactSolver._iteration`) being steps 2-6:

1. *Start* with the converged start's active set, or the set a predicted solution proposes (*Predictor*), or every
   pair closed and holding (the retry setting ``fresh``).
2. *Solve* the linear system of the active set with the reused factorisation, checked
   (:class:`bridgefem.solver.system.ContactSystem`, :mod:`bridgefem.solver.linear`): a solver that did not solve is a
   failure, never a mechanism.
3. *Judge a failure*: a solution beyond the divergence cap is judged by its mode (:mod:`bridgefem.solver.divergence`,
   :mod:`bridgefem.solver.mechanism`); a proof of collapse ends the step, any other failure is recovered from
   (:mod:`bridgefem.solver.recovery`: a proximal solve, damping, a repair) or ends the step.
4. *Accept* the solution, backtracked by a line search with a plastic fill or the retry setting ``line_search``
   (:mod:`bridgefem.solver.line_search`).
5. *Classify*: the active set the joint law proposes from the solution, with the path safeguards
   (:mod:`bridgefem.solver.proposals`).
6. *Converge or go on*: an unchanged set whose iterate is in equilibrium and obeys the law has converged
   (:mod:`bridgefem.solver.convergence`); else go to 2 with the proposed set, a return to a set visited at this
   level being a cycle (:mod:`bridgefem.solver.cycle_breaking`).
7. *Retry*: a step that failed without proof where its failure would end the search is solved again with other
   settings (:func:`retried`).

Each iteration costs one sparse solve with the symbolic factorisation reused (the sparsity never changes; the matrix
is refactorised only when the active set does, and without a fill often not even then:
:mod:`bridgefem.solver.low_rank`). Every stop decision is collective over MPI.

**Safeguards.** Each changes only the iteration's path, never what counts as converged or as a proof; why each
exists, with the scenes that showed the need: ``docs/robustness.md``, *Why each safeguard exists*.

- *Predictor*: a step may start from the set an estimate of the solution proposes (the search's secant or Tresca
  prediction, a coarser run's path: :class:`PairPrediction`). A failure before any set of the step solved is then no
  proof of a mechanism, and a return to the start's set is no cycle (it was solved at another load).
- *Mechanism verdicts*: a singular system, an unchanged set whose solve stays inaccurate, or a solve diverging along
  an admissible mode is a mechanism; a proof needs an admissible rigid-block hinge mode on which the loads do more
  work than the joints can dissipate (:func:`bridgefem.solver.mechanism.judge`). A mechanism without proof needs the
  rigid-block LP's agreement (:mod:`bridgefem.analysis.evidence`).
- *Proximal solves*: the system of a wrong active set can be exactly singular along a rigid slide; its first diverging
  solve is repeated with a weak spring against each free direction's motion from the last iterate, which bounds the
  step and vanishes at a fixed point (:mod:`bridgefem.solver.recovery`).
- *Damping chains*: after a failed solve, the half of the last good set's proposed changes farthest from the law
  they leave is applied, until a set solves; a step the search can retry smaller ends when that fails again.
- *Repairs*: an inadmissible diverging mode names the pairs it pushes into each other; the ones that touch first
  along the mode are closed (:func:`bridgefem.solver.mechanism.first_contact`).
- *Pairs on the cone*: a last change left that is a friction flip within the waived residual is frozen, rather than
  the whole joint held.
- *Reversed slips*: a slip proposed against the pair's last slip holds first, since the stick branch lies between
  the two slip branches (:mod:`bridgefem.solver.proposals`).
- *Opposed slips*: a joint proposed to slide both ways at once (its friction forces cancelling) keeps its new slips
  only.
- *Leaps*: a solution that moves the structure far beyond the last iterate and the start is nearly a mechanism; it is
  not classified, and the proposal that led to it is damped.
- *Cycles*: a return to a visited set (with a line search: one without the merit's decrease since that visit) is
  solved exactly on the condensed compliance of its few pairs, else damped, its friction flips frozen and its open /
  closed toggles bonded, the law they waive bounded (:mod:`bridgefem.solver.cycle_breaking`).
- *Refinement*: one step of iterative refinement before an unchanged set is called singular, so that rounding
  under large support-movement forces is not taken for a mechanism (:mod:`bridgefem.solver.convergence`).
- *Line search*: with a plastic fill every step is backtracked on the residual's Euclidean norm (Armijo), since full
  steps overshoot where fill points yield and unload (:mod:`bridgefem.solver.line_search`).
- *Retries*: the Alart-Curnier constants x 10 and x 0.1 (they weigh forces against displacements only in the
  classification), a fresh start, the line search, unlimited damping chains (:mod:`bridgefem.solver.settings`). The
  first that converges or proves its mechanism is taken, judged like any other outcome.
"""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Callable

import numpy as np
from petsc4py import PETSc

from ..fe.pairs import JointPairs
from ..laws.base import JointLaw
from .convergence import ConvergenceTest
from .cycle_breaking import CycleBreaker
from .cycles import CycleCondenser
from .divergence import ActiveSetFailure, DivergenceTest
from .line_search import LineSearch
from .proposals import Proposals
from .recovery import DAMPING_CHAINS, FailureRecovery
from .settings import DEFAULT_SETTING, RETRIES, Setting
from .state import CycleMemory, Iterate, NewtonStep, PairPrediction, Proposal, Ranks, StepOutcome, StepTask
from .system import ContactSystem

if TYPE_CHECKING:
    from ..fe.fill import FillResponse, PlasticFill


class ContactSolver:
    """Solves load steps with the active-set Newton method (module docstring) on the linear systems of a
    :class:`bridgefem.solver.system.ContactSystem` (built once) and the joint law ``law`` it is given (the pairs'
    constants: Coulomb coefficients, Alart-Curnier constants, hysteresis), at most ``max_iterations`` Newton
    iterations per step."""

    def __init__(self, K: PETSc.Mat, f_dead: PETSc.Vec, f_live: PETSc.Vec, pairs: JointPairs, law: JointLaw,
                 max_iterations: int, petsc_options: dict, material: "PlasticFill | None" = None,
                 support_motion: np.ndarray | None = None):
        self.pairs, self.law = pairs, law
        self.system = ContactSystem(K, f_dead, f_live, pairs, law, petsc_options, material, support_motion)
        self.comm, self.n_u, self.material = self.system.comm, self.system.n_u, material
        self.linear, self.stats = self.system.linear, self.system.stats
        # of the solves: those that condensed cycles (bridgefem.solver.cycles) and those of retries (:meth:`use`)
        self.stats.update(condensation_solves=0, retry_solves=0)
        self.cycles = CycleCondenser(self.system, reuse=material is None)
        self.max_iterations = max_iterations
        self.divergence = DivergenceTest(self.system, provable=material is None)  # step 3
        self.setting, self._setting_from = DEFAULT_SETTING, 0  # the setting, and the solves made before it was set
        self.ranks = Ranks(self.comm)
        self.proposals = Proposals(self.system, law, pairs, self.ranks)  # step 5
        self.line_search = LineSearch(self.system, law, material)  # step 4
        self.convergence = ConvergenceTest(self.system, law, material, self.ranks)  # step 6
        self.recovery = FailureRecovery(law, self.proposals, self.ranks, self._solve_current)  # step 3
        self.cycle_breaker = CycleBreaker(law, self.proposals, self.cycles, self.ranks)  # step 6

    @property
    def friction(self) -> np.ndarray:
        """The scene's Coulomb coefficients of the local pairs."""
        return self.law.scene_mu

    @property
    def friction_factor(self) -> float:
        """The factor on the scene's Coulomb coefficients the steps are solved with (:meth:`set_friction_factor`)."""
        return self.law.friction_factor

    def set_friction_factor(self, factor: float) -> None:
        """Solve with the joints' Coulomb coefficients ``factor`` x the scene's from now on."""
        self.law.set_friction_factor(factor)
        self.system.law_changed()  # the slip rows hold mu
        self.cycles.forget()

    def set_tension(self, tension: np.ndarray | None) -> None:
        """Solve with each local pair clamped by the normal force ``tension`` (N, >= 0; None: none) from now on: its
        joint then carries that much tension before it opens, and mu times it more shear (a tensile strength; the
        self-weight's tension continuation; :meth:`bridgefem.solver.system.ContactSystem.clamp`). Collective."""
        self.system.clamp(tension)
        self.cycles.forget()

    def bonded_tensile_stress(self) -> np.ndarray:
        """The tension (N per m of joint, >= 0; zero where compressed) of each local pair under self-weight with
        every pair closed and holding (one linear solve; zeros when that system cannot be solved). Collective."""
        start = self.initial_iterate()
        x = self.system.vector()
        if self.system.solve_set(0.0, start.active, start.slip_ref, x, None) is not None:
            return np.zeros(len(self.pairs))
        _, lam, _ = self.system.split(x)
        return np.maximum(-lam[:, 0], 0.0) / np.maximum(self.pairs.length, 1e-300)

    def use(self, setting: Setting) -> None:
        """Solve the next load steps with ``setting`` (module docstring, *Retries*; ``DEFAULT_SETTING`` restores); the
        solves made with another setting count as ``retry_solves``."""
        if self.setting != DEFAULT_SETTING:
            self.stats["retry_solves"] += self.stats["solves"] - self._setting_from
        self._setting_from = self.stats["solves"]
        self.law.scale_constants(setting.scale / self.setting.scale)
        self.setting = setting
        self.system.law_changed()  # the law's rows hold c
        self.cycles.forget()

    @property
    def movement(self) -> float:
        """The fraction of the support movement imposed (:meth:`set_support_movement`)."""
        return self.system.movement

    def set_support_movement(self, fraction: float) -> None:
        """Impose ``fraction`` of the support movement (offsets ``support_motion``, m per pair) from now on."""
        self.system.set_support_movement(fraction)

    def initial_iterate(self) -> Iterate:
        """Every joint closed and holding, zero state: the start of the self-weight step."""
        plastic = self.material.initial_plastic_strain() if self.material is not None else None
        return Iterate(self.system.vector(), self.law.bonded(len(self.pairs)), np.zeros(len(self.pairs)), plastic)

    def converged_slip_reference(self, it: Iterate) -> Iterate:
        """The converged state becomes the reference for the incremental slip of the next step."""
        _, _, d = self.system.split(it.x)
        return Iterate(it.x, it.active, d[:, 1].copy(), it.plastic_strain)

    def live_load_tangent(self, it: Iterate) -> Iterate | None:
        """The response to a unit increment of the live-load level at the converged ``it`` with its active set
        held and, with a plastic fill, the fill's consistent tangent at the converged displacements (call this right
        after the step that converged to ``it``): displacements in m per N of live load, the tangent of the
        load-deflection curve (:meth:`bridgefem.solver.system.ContactSystem.live_load_tangent`). None when that
        system cannot be solved."""
        dx = self.system.live_load_tangent(it.active)
        return None if dx is None else Iterate(dx, it.active, it.slip_ref, it.plastic_strain)

    def solve_step(self, level: float, start: Iterate, predictor: PETSc.Vec | PairPrediction | None = None,
                   give_up: bool = False, iterations: int | None = None) -> StepOutcome:
        """Solve for live-load level ``level`` (N per unit load factor) from a converged ``start``: the module's
        steps 1-6, one Newton iteration at a time within the step's budget (``iterations``, at most and by default
        ``max_iterations``). ``predictor``: an estimate of the solution at ``level`` (combined vector, or its joint
        pairs'), whose classification against ``start`` is the first active set solved (*Predictor*). With
        ``give_up`` (the caller can retry a smaller step) a failure after ``DAMPING_CHAINS`` recovered damping chains
        ends the step at once, as non-convergence, and so does a cycle. A failure says whether its last solve and
        whether any solve was unbounded (singular, or diverging along any mode)."""
        step = self._begin(level, start, predictor, give_up, iterations)
        out = self._newton(step)
        return out if out.converged else replace(out, unbounded=out.mechanism or step.recovery.unbounded,
                                                 diverged=out.mechanism or step.recovery.diverged)

    def _newton(self, step: NewtonStep) -> StepOutcome:
        """The Newton iterations of a step, until one ends it or its budget is spent."""
        for it in range(1, step.task.budget + 1):
            step.it = it
            outcome = self._iteration(step)
            # the PETSc objects Python dropped (a copied iterate, a trial's vectors) are freed only here: petsc4py
            # 3.18 defers their destruction to this collective call (about one vector of the system per iteration)
            PETSc.garbage_cleanup(self.comm)
            if outcome is not None:
                return outcome
        if self.material is not None and step.residual > 1.0:
            return step.ended(f"diverged: out-of-balance force {step.residual:.3g} x the largest applied nodal force "
                              f"after {step.task.budget} iterations")
        return step.ended(f"max iterations ({step.task.budget}) reached with the active set still changing")

    def _begin(self, level: float, start: Iterate, predictor: PETSc.Vec | PairPrediction | None, give_up: bool,
               iterations: int | None) -> NewtonStep:
        """Step 1: the step's state at its start, with the start's active set (every joint closed and holding with
        the setting ``fresh``) or the one ``predictor`` proposes (*Predictor*). Collective."""
        active = start.active.copy()
        if self.setting.fresh:
            active = self.law.bonded(len(self.pairs))
            predictor = None
        searching = self.material is not None or self.setting.line_search  # step 4's line search
        x = self.system.vector()
        start.x.copy(x)
        task = StepTask(
            level, start, f_scale=max(self.system.norm_inf(self.system.loads(level)), 1e-300),
            budget=self.max_iterations if iterations is None else min(iterations, self.max_iterations),
            chains=DAMPING_CHAINS if give_up and not self.setting.patient else np.inf, searching=searching,
            first_factorisation=self.stats["factorisations"])
        memory = CycleMemory.empty(len(self.pairs))
        step = NewtonStep(task, x, active, near=start.x.copy(), anchor=start.x.copy() if searching else None,
                          plastic=start.plastic_strain, memory=memory, stats=self.stats)
        if self.material is not None:  # the elastic predictor: robust at unloading points
            self.system.linearise(x, start.plastic_strain, elastic=True)
        if predictor is not None:
            step.predicted = self.proposals.predict(predictor, active, start.slip_ref, step.memory.frozen,
                                                    self.setting.through_stick)
        if step.predicted is not None:  # no solved active set yet: a failure proves nothing
            step.base, step.active = step.predicted, step.predicted.proposal
        step.memory.seen = {self.ranks.key(step.active): np.inf}  # the start's set: visited only once solved here
        return step

    def _iteration(self, step: NewtonStep) -> StepOutcome | None:
        """One Newton iteration, the module's steps 2-6: the outcome when it ends the step, else None (go to 2)."""
        failure = self._solve_set(step)  # 2
        if failure is not None and failure.proof:  # 3: a proved mechanism ends the step
            return step.ended(failure.message, mechanism=True, proved=True)
        if failure is not None:
            failure = self.recovery.note(step, failure)  # 3: a proximal solve may still solve it
        if failure is not None:
            return self.recovery.recover(step, failure)  # 3: damping, repair
        accepted = self._accept(step)  # 4
        classified = self._classify(step)  # 5
        if classified is None:  # a leap: the proposal that led to it is damped
            return None
        proposal, changed = classified
        outcome = self.convergence.balance(step, accepted)  # 6
        if outcome is not None:
            return outcome
        if not changed:
            return self.convergence.test(step)  # 6
        return self.cycle_breaker.advance(step, proposal, changed)  # 6, with its cycles

    def _solve_set(self, step: NewtonStep) -> ActiveSetFailure | None:
        """Step 2: solve the active set's system into x (a set with a proximal failure: its proximal system,
        anchored at the last solved iterate), checked; a proximal set that drifts keeps its plain failure without a
        solve. Returns None or the failure. Collective."""
        step.key = self.ranks.key(step.active)
        if step.proximal.drift is not None:
            return step.proximal.drift
        return self._solve_current(step, step.key in step.proximal.sets)

    def _solve_current(self, step: NewtonStep, proximal: bool) -> ActiveSetFailure | None:
        """Solve the active set's system at the step's level into x, checked against the step's start (with
        ``proximal``: its proximal system anchored at the last solved iterate). Collective."""
        task = step.task
        return self._solve_active(task.level, step.active, task.start.slip_ref, step.x, task.start.x,
                                  step.near if proximal else None, step.near)

    def _solve_active(self, level: float, active, slip_ref: np.ndarray, x: PETSc.Vec, origin: PETSc.Vec,
                      near: PETSc.Vec | None = None, forces: PETSc.Vec | None = None) -> ActiveSetFailure | None:
        """Solve the linear system of an active set into x (with ``near``: its proximal system anchored there,
        :meth:`bridgefem.solver.system.ContactSystem.solve_set`); returns None or the failure. A displacement beyond
        the cap is a mechanism only when the diverging direction from ``origin`` (the step's converged start) is
        admissible (:meth:`bridgefem.solver.divergence.DivergenceTest.failure`, with the normal forces of
        ``forces``, the last solved iterate; by default ``origin``)."""
        failure = self.system.solve_set(level, active, slip_ref, x, near)
        if failure is not None:
            return ActiveSetFailure(failure.message, failure.singular)
        return self.divergence.failure(level, active, x, origin, origin if forces is None else forces)

    def _accept(self, step: NewtonStep) -> "FillResponse | None":
        """Step 4: a solved set ends the damping chain; with a line search the step is backtracked from the
        linearisation point, which moves to the accepted iterate. Returns the fill's response there (None without
        a plastic fill). Collective."""
        step.recovery.solved()
        step.predicted, step.recovery.unbounded, task = None, False, step.task
        if not task.searching:
            return None
        step.merit, accepted = self.line_search.search(task.level, step.x, step.anchor, step.merit,
                                                       task.start.plastic_strain, task.start.slip_ref,
                                                       step.memory.frozen, task.f_scale)
        step.x.copy(step.anchor)
        return accepted

    def _classify(self, step: NewtonStep) -> tuple[Proposal, int] | None:
        """Step 5: the active set the joint law proposes from the solution and the number of pairs it changes; None
        when the solution leaps and the proposal that led to it was damped instead (a set a cycle's condensation
        proposed is classified even then: it is consistent at the cycle's pairs). Collective."""
        task, memory = step.task, step.memory
        _, lam, d = self.system.split(step.x)
        proposal = self.proposals.propose(step.active, lam, d, task.start.slip_ref, memory.frozen,
                                          self.setting.through_stick, memory.bonded)
        changed = self.ranks.count(proposal.pending)
        if changed and not task.searching and step.base is not None and step.key != memory.condensed and \
                self.proposals.leaps(step.x, step.near, task.start.x):
            damped = self.proposals.damp(step.base)
            if damped is not None:
                step.active, step.base = damped
                return None
        step.x.copy(step.near)
        memory.churn += proposal.pending
        return proposal, changed


def retried(solver: ContactSolver, solve: Callable[[], StepOutcome], failed: StepOutcome,
            settings: tuple[Setting, ...] = RETRIES) -> StepOutcome:
    """A load step that ended in ``failed`` without proof, solved again by ``solve()`` (which records it) with each of
    ``settings`` in turn (the module's *Retries*): the first outcome that converged or proved a mechanism, else the
    first that showed a mechanism where ``failed`` showed none, else ``failed`` (its reason saying so); when
    ``failed`` ended on an unbounded solve (singular, or diverging along any mode) and every retry met one,
    ``failed`` as a mechanism without proof (no setting found an equilibrium, each found the system unbounded: the
    verdict needs the LP's agreement, :mod:`bridgefem.analysis.evidence`). A setting that changes nothing for this
    solver (the line search alone, with a plastic fill) is skipped. Restores the default setting."""
    searching = solver.material is not None  # a plastic fill's steps are line searched already
    settings = tuple(st for st in settings if not (searching and replace(st, line_search=False) == DEFAULT_SETTING))
    best, unbounded = failed, failed.unbounded
    try:
        for setting in settings:
            solver.use(setting)
            out = solve()
            if out.converged or out.proved:
                return out
            best = out if out.mechanism and not best.mechanism else best
            unbounded = unbounded and out.diverged
    finally:
        solver.use(DEFAULT_SETTING)
    if unbounded and not best.mechanism:
        return replace(failed, mechanism=True, reason=f"{failed.reason}; no equilibrium with any of {len(settings)} "
                                                       "other solver settings, each diverging (no proof)")
    if best is failed:
        return replace(failed, reason=f"{failed.reason} (and with each of {len(settings)} other solver settings)")
    return best
