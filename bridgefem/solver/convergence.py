"""When a load step has converged (step 6 of :mod:`bridgefem.solver.newton`).

A step has converged when the active set no longer changes and at the iterate

1. the out-of-balance force is below ``EQUILIBRIUM_RTOL`` of the largest applied nodal force (inf-norms; with a
   plastic fill f + G^T lam - f_int(u) with the fill's true stresses, else the assembled system's equilibrium rows);
2. the joint law's residual (:meth:`bridgefem.laws.base.JointLaw.residual`) is within ten times its hysteresis
   ``force_tol`` at every pair, except where a cycle waived it (the friction of frozen pairs, the whole law of bonded
   ones: :mod:`bridgefem.solver.cycle_breaking`), where it must be within ``BOND_RTOL`` of the largest applied nodal
   force (the default bracket tolerance: a force below the load resolution the search asks for), else the step fails
   as active-set cycling.

Two safeguards on the equilibrium:

- *Refinement.* A support movement can load a stiff, thin ring with forces far above its weight, and the rounding of
  the solve, relative to those forces, then exceeds the tolerance. Before an unchanged set whose iterate fails the
  test is called singular, one step of iterative refinement with the same factorisation
  (:meth:`bridgefem.solver.linear.CheckedSolve.correction`) estimates the solve's forward error: a correction within
  ``REFINED_RTOL`` of the iterate says the solve is exact to working precision, and the iterate is in equilibrium as
  far as the arithmetic resolves; a singular system leaves a larger correction and stays a mechanism without proof.
- *Divergence of a plastic fill.* An out-of-balance force beyond ``DIVERGED_OUT_OF_BALANCE`` times the largest
  applied nodal force ends the step at once as diverged (no proof of collapse: the load incrementation halves it).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from petsc4py import PETSc

from ..laws.base import JointLaw
from .state import Iterate, NewtonStep, Ranks, StepOutcome
from .system import ContactSystem

if TYPE_CHECKING:
    from ..fe.fill import FillResponse, PlasticFill

EQUILIBRIUM_RTOL = 1e-8  # scaled residual |K u - G^T lam - f|_inf / |f|_inf for a converged step
BOND_RTOL = 1e-4  # joint-law residual (N) waived at bonded and frozen pairs, of the largest applied nodal force
REFINED_RTOL = 1e-6  # an iterative refinement's correction below this fraction of the iterate (largest entries): the
# solve is exact to working precision
DIVERGED_OUT_OF_BALANCE = 100.0  # with a plastic fill, an out-of-balance force beyond this multiple of the largest
# applied nodal force ends the step as diverged


class ConvergenceTest:
    """The convergence test of the steps solved on ``system`` with the joint law ``law`` and the fill ``material``
    (None: none; module docstring). Collective."""

    def __init__(self, system: ContactSystem, law: JointLaw, material: "PlasticFill | None", ranks: Ranks):
        self.system, self.law, self.material, self.ranks = system, law, material, ranks

    def balance(self, step: NewtonStep, accepted: "FillResponse | None") -> StepOutcome | None:
        """The scaled out-of-balance force at the iterate (with a plastic fill, the fill linearised there for the
        next solve); the step ends as diverged beyond ``DIVERGED_OUT_OF_BALANCE``. Collective."""
        system = self.system
        if self.material is None:
            step.residual = system.equilibrium_residual(step.x, step.task.f_scale)
            return None
        f_int, step.plastic = system.linearise(step.x, step.task.start.plastic_strain, response=accepted)
        step.residual = system.material_residual(step.x, f_int, step.task.level, step.task.f_scale)
        if step.residual > DIVERGED_OUT_OF_BALANCE:  # no recovery from here
            return step.ended(f"diverged: out-of-balance force {step.residual:.3g} x the largest applied nodal force "
                              f"after {step.it} iterations")
        return None

    def test(self, step: NewtonStep) -> StepOutcome | None:
        """The active set unchanged: converged when equilibrium (:meth:`in_equilibrium`) and the joint law hold
        (module docstring); a proximal set's plain failure when it drifts; with a line search the next iteration;
        else the set is singular (a mechanism without proof). Collective."""
        balanced = self.in_equilibrium(step)
        waived, comp = self.law_residuals(step)
        if waived > BOND_RTOL * step.task.f_scale:
            return step.ended(f"active set cycling: the joint law is violated by {waived:.3g} N at the bonded or "
                              "frozen pairs")
        if balanced and comp <= 10 * self.law.force_tol:
            counts = {**self.law.counts(step.active, self.ranks.comm), "frozen": self.ranks.count(step.memory.frozen),
                      "bonded": self.ranks.count(step.memory.bonded)}
            return StepOutcome(True, "", step.it, step.residual, step.factorisations(),
                               Iterate(step.x, step.active, step.task.start.slip_ref, step.plastic), counts)
        if step.key in step.proximal.sets:  # a drift along the mode that changes no pair
            step.proximal.drift = step.proximal.sets.pop(step.key)
            return None
        if step.task.searching:
            return None  # same active set, damped step or fill not in equilibrium
        return step.ended(f"inaccurate linear solve: scaled equilibrium residual {step.residual:.2e}, "
                          f"complementarity residual {comp:.2e} N (singular system)", mechanism=True)

    def law_residuals(self, step: NewtonStep) -> tuple[float, float]:
        """The joint law's residual at the iterate (N): the largest where it is waived (frozen pairs' friction,
        bonded pairs), and the largest elsewhere. Collective."""
        memory, norm_inf = step.memory, self.system.norm_inf
        _, lam, d = self.system.split(step.x)
        ncp = self.law.residual(lam, d, step.task.start.slip_ref)
        waived = max(norm_inf(ncp[memory.bonded].ravel()), norm_inf(ncp[memory.frozen, 1]))
        ncp[memory.frozen, 1] = 0.0  # the normal law is still checked there
        ncp[memory.bonded] = 0.0
        return waived, norm_inf(ncp.ravel())

    def in_equilibrium(self, step: NewtonStep) -> bool:
        """The iterate of an unchanged active set is in equilibrium: its scaled out-of-balance force is below
        ``EQUILIBRIUM_RTOL``, or (the plain system of a ring without a line search) one step of iterative refinement
        shows the solve exact to working precision (module docstring, *Refinement*); the refined iterate is kept when
        its out-of-balance force is smaller. Collective."""
        if step.residual < EQUILIBRIUM_RTOL:
            return True
        if step.task.searching or step.key in step.proximal.sets:
            return False
        system = self.system
        dx = system.refinement(step.x)
        if not isinstance(dx, PETSc.Vec):
            return False
        exact = system.norm_inf(dx.array) <= REFINED_RTOL * system.norm_inf(step.x.array)
        refined = step.x.copy()
        refined.axpy(1.0, dx)
        residual = system.equilibrium_residual(refined, step.task.f_scale)
        if residual < step.residual:
            refined.copy(step.x)
            step.residual = residual
        return exact or step.residual < EQUILIBRIUM_RTOL
