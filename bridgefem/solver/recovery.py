"""What the Newton iteration does after a failed solve without proof (step 3 of :mod:`bridgefem.solver.newton`).

A solve fails when the linear solver refuses the system (singular, inaccurate) or when its solution diverges
(:class:`bridgefem.solver.divergence.DivergenceTest`); a diverging mode that proves collapse ends the step before
this module is asked. Otherwise, in this order:

1. *Note.* The failure is noted (the last singular one, the unbounded solves, the mechanisms) with its *repair*:
   the pairs its inadmissible mode pushes into each other, closed (:meth:`bridgefem.solver.proposals.Proposals.
   repaired`).
2. *Proximal solves.* The system of a wrong active set can be exactly singular along a strain-free rigid slide. When
   the first proposal of a damping chain diverges along a mode that slips pairs against their friction force, at
   most ``PROXIMAL_SETS`` sets per step and within ``PROXIMAL_CHANGES`` pairs of the last solved set, that set is
   solved again with a proximal term (Rockafellar 1976, *Monotone operators and the proximal point algorithm*): a
   spring against each free direction's motion from the last solved iterate
   (:data:`bridgefem.solver.system.PROXIMAL`). The step is then bounded, and the classification sees which pairs the
   mode closes or slips backwards. The term vanishes at a fixed point, so the convergence test is the law's own; a
   proximal iterate that proposes no change while the law does not hold drifts, and the set's plain failure stands.
3. *Damping chains.* From the last good set, the half of its proposed changes farthest from the law they leave is
   applied (:meth:`bridgefem.solver.proposals.Proposals.damp`); the chain ends when a damped set solves. With
   nothing left to halve: a friction flip on its cone is frozen (*Pairs on the cone*, below), else the failed set's
   repair is solved, else the failure ends the step (a mechanism without proof, unless the set was predicted).
4. *Give up.* In a step the caller can retry with a smaller one, a proposal that fails after ``DAMPING_CHAINS``
   recovered chains ends the step as non-convergence (after its repair, once a step): wandering into mechanisms is
   the Newton method failing on a large step. It is a mechanism without proof only when the failing solve and an
   earlier one were singular or diverged along admissible modes (the verdict then needs the rigid-block LP's
   agreement, :mod:`bridgefem.analysis.evidence`).

*Pairs on the cone.* A damping chain whose last change left is a friction flip of a closed pair (hold to slip, or a
slip sign) within the residual waived at frozen pairs (``BOND_RTOL`` of the largest applied nodal force), on a set
that still fails along a wrong active set's mode, freezes that pair and solves the set that proposed the flip
again: such a pair sits on its friction cone, where neither state is consistent to within the solve's rounding.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from mpi4py import MPI

from ..laws.base import JointLaw
from .convergence import BOND_RTOL
from .divergence import ActiveSetFailure
from .proposals import Proposals
from .state import NewtonStep, Ranks, StepOutcome

DAMPING_CHAINS = 1  # damping chains that may recover per step; a failure after that ends it (no proof)
PROXIMAL_SETS = 1  # active sets per load step whose diverging solve is replaced by a proximal solve
PROXIMAL_CHANGES = 24  # ... only when the set differs from the last solved one at no more than this many pairs

Solve = Callable[[NewtonStep, bool], "ActiveSetFailure | None"]


class FailureRecovery:
    """Recovery from failed solves (module docstring) with the joint law ``law``, its ``proposals`` and
    ``solve(step, proximal)``, the solver's solve of the step's active set. Collective."""

    def __init__(self, law: JointLaw, proposals: Proposals, ranks: Ranks, solve: Solve):
        self.law, self.proposals, self.ranks, self.solve = law, proposals, ranks, solve

    def note(self, step: NewtonStep, failure: ActiveSetFailure) -> ActiveSetFailure | None:
        """Steps 1-2: note a failed solve without proof; a set whose first failure diverges along a mode that slips
        pairs against their friction force is solved again with the proximal term. Returns the failure that stands,
        or None. Collective."""
        recovery, proximal = step.recovery, step.proximal
        if proximal.drift is not None:  # a proximal set that drifts: its plain failure, no solve
            recovery.fix, proximal.drift, recovery.unbounded = recovery.repairs.get(step.key), None, True
            return failure
        recovery.singular = failure if failure.mechanism else recovery.singular
        recovery.unbounded = failure.mechanism or failure.unbounded
        recovery.diverged |= recovery.unbounded
        recovery.mechanisms += failure.mechanism
        recovery.fix = self.proposals.repaired(step.active, failure.repair, step.memory.frozen)
        if recovery.fix is not None:
            recovery.repairs[step.key] = recovery.fix
        if not recovery.damping and failure.slides and proximal.count < PROXIMAL_SETS and (
                step.base is None or self.ranks.count(step.active.differs(step.base.good)) <= PROXIMAL_CHANGES):
            proximal.sets[step.key], proximal.count = failure, proximal.count + 1
            return self.solve(step, True)
        return failure

    def recover(self, step: NewtonStep, failure: ActiveSetFailure) -> StepOutcome | None:
        """Steps 3-4: the next active set after a failed solve (damped, frozen on the cone, or the repair), or the
        outcome that ends the step. Collective."""
        recovery = step.recovery
        if recovery.recovered >= step.task.chains and not recovery.damping:
            if not recovery.last_repair and self.take_repair(step):  # once a step
                recovery.last_repair = True
                return None
            return step.ended(f"no convergence: a proposed active set failed again after {recovery.recovered} "
                              f"damping chain(s): {failure.message}",
                              mechanism=failure.mechanism and recovery.mechanisms > 1)
        recovery.damping = True
        damped = self.proposals.damp(step.base) if step.base is not None else None
        if damped is None and not failure.mechanism and self.freeze_at_cone(step):
            return None
        if damped is None and self.take_repair(step):
            return None
        if damped is None:
            return step.ended(failure.message, mechanism=failure.mechanism and step.predicted is None)
        step.active, step.base = damped
        return None

    def take_repair(self, step: NewtonStep) -> bool:
        """Make the failed set's repair the next active set, unless the step has none or visited it already; returns
        whether it did. Collective (the global key)."""
        if step.recovery.fix is None:
            return False
        fix = self.ranks.key(step.recovery.fix)
        if fix in step.memory.seen:
            return False
        step.memory.seen[fix] = np.inf
        step.active = step.recovery.fix
        return True

    def freeze_at_cone(self, step: NewtonStep) -> bool:
        """Whether the last change left of a proposal whose set failed without showing a mechanism is a friction flip
        of a closed pair within the law residual waived at frozen pairs; if so it is frozen and the set that proposed
        it is solved next (module docstring, *Pairs on the cone*). Collective."""
        base, memory, law = step.base, step.memory, self.law
        if base is None:
            return False
        flips = base.pending & ~memory.frozen & law.closed(base.proposal) & law.closed(base.good)
        if not self.ranks.any(flips.any()) or self.ranks.count(flips) != self.ranks.count(base.pending):
            return False
        violation = self.ranks.comm.allreduce(float(base.violation[flips].max(initial=0.0)), op=MPI.MAX)
        if violation > BOND_RTOL * step.task.f_scale:
            return False
        memory.frozen |= flips
        step.active = base.good.copy()
        law.hold(step.active, memory.frozen)
        return True
