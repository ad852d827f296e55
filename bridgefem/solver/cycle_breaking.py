"""What the Newton iteration does when its proposal returns to an active set visited at this level (step 6 of
:mod:`bridgefem.solver.newton`): a *cycle*. Without a line search the iterate is a function of the active set, so a
return would repeat the same path for ever. In this order:

1. A return to a set whose diverging mode was inadmissible goes to that set's repair.
2. A cycle after a singular proposal is a mechanism without proof ("damped iterations return to it").
3. *Cycles of a few pairs* are solved exactly on their condensed compliance (:mod:`bridgefem.solver.cycles`): the
   pairs the returning proposal changes, with the *churning pairs* (those changed by two or more of the step's
   proposals) when they are at most ``ENUMERATED_PAIRS`` in all, since a return may change one pair of the cycle
   only. The condensed pairs' friction state is then exact: they are no longer frozen.
4. Otherwise a cycle that is not only friction flips of closed pairs (hold / slip, slip sign) is damped like a failed
   proposal while damping chains may recover; undamped, its open / closed toggles are *bonded* (closed and holding
   for the rest of the step, their law waived) when they and the flips are all its changes, else the step fails as
   active-set cycling. The flips are *frozen* (held while closed, their friction law waived): with large friction
   the discrete law can have no consistent state at a pair next to a crack tip. The convergence test bounds what is
   waived (:mod:`bridgefem.solver.convergence`).

With a line search (a plastic fill) the iterate moves between visits, and a return is a cycle only when the
line search's merit at the iterate that proposes the set again has not fallen by ``ARMIJO`` of its value at the
iterate that proposed it before: the iteration then repeats itself (on a pair near a hinge, or of the arch-fill
interface, whose discrete law has no consistent state while the fill is in equilibrium within its tolerance) and
would spend the step's budget. A return with that decrease clears the visited sets: the iteration progresses.
"""
from __future__ import annotations

import numpy as np

from ..laws.base import ContactState, JointLaw
from .condensation import ENUMERATED_PAIRS
from .cycles import CycleCondenser
from .line_search import ARMIJO
from .proposals import Proposals
from .state import NewtonStep, Proposal, Ranks, StepOutcome


class CycleBreaker:
    """Breaks the cycles of the Newton iteration (module docstring) with the joint law ``law``, its ``proposals`` and
    the condensation ``cycles``. Collective."""

    def __init__(self, law: JointLaw, proposals: Proposals, cycles: CycleCondenser, ranks: Ranks):
        self.law, self.proposals, self.cycles, self.ranks = law, proposals, cycles, ranks

    def advance(self, step: NewtonStep, proposal: Proposal, changed: int) -> StepOutcome | None:
        """The active set changed: the proposed set is solved next, unless it returns to a set visited at this level
        without a line search, or with one but without the merit's decrease since that visit (a cycle:
        :meth:`break_cycle`). Collective."""
        key, seen = self.ranks.key(proposal.proposal), step.memory.seen
        if key in seen and not (step.task.searching and step.merit < (1.0 - ARMIJO) * seen[key]):
            return self.break_cycle(step, proposal, changed, key)
        if key in seen:
            seen.clear()
        step.take(proposal, key)
        return None

    def break_cycle(self, step: NewtonStep, proposal: Proposal, changed: int, key: int) -> StepOutcome | None:
        """A proposal returning to a visited set (global key ``key``): module docstring, steps 1-3, else
        :meth:`freeze`. Collective."""
        task, memory, recovery = step.task, step.memory, step.recovery
        fix = recovery.repairs.pop(key, None)
        if fix is not None and self.visit(step, fix, proposal.violation):
            return None
        if recovery.singular is not None:
            return step.ended(f"{recovery.singular.message}; confirmed: damped iterations return to it",
                              mechanism=True)
        solved = self.cycles.condensed(task.level, step.active, self.cycle_pairs(proposal.pending, memory.churn),
                                       task.start.slip_ref, task.start.active)
        if solved is not None and self.visit(step, solved, proposal.violation):
            memory.frozen &= ~step.base.pending  # the condensed pairs' friction state is now exact
            memory.condensed = self.ranks.key(solved)
            return None
        return self.freeze(step, proposal, changed)

    def freeze(self, step: NewtonStep, proposal: Proposal, changed: int) -> StepOutcome | None:
        """Module docstring, step 4: damp, or bond the open / closed toggles and freeze the friction flips, and take
        the proposal so held. Collective."""
        new, pending, memory, law = proposal.proposal, proposal.pending, step.memory, self.law
        flips = pending & ~memory.frozen & law.closed(new) & law.closed(step.active)
        if self.ranks.count(flips) != changed:
            damped = self.proposals.damp(proposal) if step.recovery.recovered < step.task.chains else None
            toggles = pending & ~memory.bonded & (law.closed(new) != law.closed(step.active))
            if damped is None and self.ranks.count(toggles | flips) == changed:
                memory.bonded |= toggles  # no consistent open / closed state: kept closed, its law waived
            elif damped is None:
                return step.ended(f"active set cycling ({changed} pairs changing)")
            else:
                step.recovery.damping = True
                step.active, step.base = damped
                return None
        memory.frozen |= flips
        law.hold(new, memory.frozen)
        law.bond(new, memory.bonded)
        step.take(proposal, self.ranks.key(new))
        return None

    def visit(self, step: NewtonStep, target: ContactState, violation: np.ndarray) -> bool:
        """Whether ``target`` is new at this level; if so it is solved next, as the proposal of the current set
        with ``violation``. Collective."""
        key = self.ranks.key(target)
        if key in step.memory.seen:
            return False
        step.take(Proposal(step.active, target, target.differs(step.active), violation), key)
        return True

    def cycle_pairs(self, pending: np.ndarray, churn: np.ndarray) -> np.ndarray:
        """The pairs of a cycle to condense: those the returning proposal changes, with those that changed in two or
        more of the step's proposals (``churn``: counts per local pair) when they are at most ``ENUMERATED_PAIRS`` in
        all, else the returning proposal's alone. Collective."""
        cycle = pending | (churn >= 2)
        return cycle if self.ranks.count(cycle) <= ENUMERATED_PAIRS else pending
