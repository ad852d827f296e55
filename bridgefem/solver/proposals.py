"""The active set a solution proposes (step 5 of :mod:`bridgefem.solver.newton`), with the path safeguards that act
on a proposal, and the two ways a proposal is cut back: damping and repair.

1. The joint law classifies the solution (:meth:`bridgefem.laws.base.JointLaw.classify`) against the set that was
   solved; each changed pair carries its violation (N), how far it is from the law it leaves.
2. *Reversed slips*: a pair proposed to slip against its last solved slip holds instead
   (:meth:`bridgefem.laws.base.JointLaw.hold_reversals`); the incremental friction law is a monotone graph (slip
   one way, stick, slip the other way), and a Newton step that lands on the opposite branch has crossed the stick
   branch. The next classification proposes the reversal if the holding force leaves the cone again.
3. *Opposed slips*: on a joint proposed to slide both ways at once (its friction forces cancel, so it would slide
   freely) the pairs that keep their old slip hold (:meth:`bridgefem.laws.base.JointLaw.hold_opposed_slips`).
4. Pairs frozen or bonded by a cycle (:mod:`bridgefem.solver.cycle_breaking`) keep their held state.
5. *Damping* (:meth:`Proposals.damp`): of the changes still pending, the half with the largest violations is kept
   (at least one), from the last good set.
6. *Repair* (:meth:`Proposals.repaired`): the pairs an inadmissible diverging mode pushes into each other closed
   (:meth:`bridgefem.laws.base.JointLaw.repaired`, narrowed to the mode's first contact by
   :func:`bridgefem.solver.mechanism.first_contact`).
7. *Leaps* (:meth:`Proposals.leaps`): a solution that moves the structure more than ``LEAP`` times as far as the
   last solved iterate and the step's start is nearly a mechanism below the divergence cap, and its classification
   proposes changes with violations far beyond the load; the solver damps the proposal that led to it instead.

Each changes only the iteration's path: a converged set proposes no change, so what counts as converged is the
law's own. Why each exists: ``docs/robustness.md``, *Why each safeguard exists*.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..fe.pairs import JointPairs
from ..laws.base import ContactState, JointLaw
from .state import PairPrediction, Proposal, Ranks
from .system import ContactSystem

LEAP = 10.0  # a solution moving the structure beyond this multiple of the last solved iterate and the step's start
# is not classified: the proposal that led to it is damped


class Proposals:
    """The proposals of the joint law ``law`` at the ``pairs`` of a :class:`bridgefem.solver.system.ContactSystem`
    (module docstring). Collective."""

    def __init__(self, system: ContactSystem, law: JointLaw, pairs: JointPairs, ranks: Ranks):
        self.system, self.law, self.pairs, self.ranks = system, law, pairs, ranks

    def propose(self, active: ContactState, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray,
                frozen: np.ndarray, through_stick: bool, bonded: np.ndarray | None = None) -> Proposal:
        """The active set the law proposes from ``active`` for multipliers ``lam`` and relative displacements ``d``
        (module docstring, steps 1-4; reversed slips held with ``through_stick``), with the changed pairs and their
        violations."""
        law = self.law
        new, violation = law.classify(active, lam, d, slip_ref)
        if through_stick:
            law.hold_reversals(new, active)
        law.hold_opposed_slips(new, active, self.pairs.joint, self.ranks.comm)
        law.hold(new, frozen)
        if bonded is not None:
            law.bond(new, bonded)
        return Proposal(active, new, new.differs(active), violation)

    def predict(self, predictor: PETSc.Vec | PairPrediction, active: ContactState, slip_ref: np.ndarray,
                frozen: np.ndarray, through_stick: bool) -> Proposal | None:
        """The active set an estimate of the solution (a combined vector or its pairs') proposes from the converged
        ``active``, as a proposal whose good set is ``active``; None when it proposes no change."""
        if isinstance(predictor, PairPrediction):
            lam, d = predictor.lam, predictor.d
        else:
            _, lam, d = self.system.split(predictor)
        proposal = self.propose(active, lam, d, slip_ref, frozen, through_stick)
        return proposal if self.ranks.any(proposal.pending.any()) else None

    def damp(self, base: Proposal) -> tuple[ContactState, Proposal] | None:
        """Keep the half of the pending changes with the largest violations (at least one): the damped active
        set and the proposal with its pending changes reduced; None when a single change is left."""
        ranked = np.concatenate(self.ranks.comm.allgather(base.violation[base.pending]))
        if len(ranked) <= 1:
            return None
        threshold = np.sort(ranked)[::-1][max(len(ranked) // 2, 1) - 1]
        keep = base.pending & (base.violation >= threshold)
        damped = base.good.copy()
        damped.state[keep], damped.sign[keep] = base.proposal.state[keep], base.proposal.sign[keep]
        return damped, base._replace(pending=keep)

    def repaired(self, active: ContactState, repair: np.ndarray | None, frozen: np.ndarray) -> ContactState | None:
        """``active`` with the ``repair`` pairs closed (:meth:`bridgefem.laws.base.JointLaw.repaired`) and the
        ``frozen`` ones held; None without a repair anywhere. Collective."""
        if not self.ranks.any(repair is not None and bool(repair.any())):
            return None
        repair = np.zeros(len(self.pairs), bool) if repair is None else repair
        fixed = self.law.repaired(active, repair, self.pairs.joint, self.ranks.comm)
        self.law.hold(fixed, frozen)
        return fixed

    def leaps(self, x: PETSc.Vec, near: PETSc.Vec, start: PETSc.Vec) -> bool:
        """Whether the solution ``x`` moves the structure more than ``LEAP`` times as far as the last solved iterate
        ``near`` and the step's start (largest displacement, m). Collective."""
        norm_inf, n_u = self.system.norm_inf, self.system.n_u
        largest = norm_inf(x.array[:n_u])
        return largest > LEAP * max(norm_inf(near.array[:n_u]), norm_inf(start.array[:n_u]))
