"""What one load step of the contact solver works on (:mod:`bridgefem.solver.newton`): its solutions and outcome, and
the state of its Newton iteration grouped by job (the task, the failed solves and their recovery, the cycles, the
proximal solves). Plain data; the collective readings of it over MPI ranks are :class:`Ranks`'."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..laws.base import ContactState
from .divergence import ActiveSetFailure


@dataclass(frozen=True)
class PairPrediction:
    """An estimate of this rank's joint pairs at a step's level: forces ``lam`` (N) and relative displacements ``d``
    (m), each (pairs, 2) as (normal, tangential) like :meth:`bridgefem.solver.system.ContactSystem.split`'s. A step
    starts from its classification as from a predicted combined vector's (:mod:`bridgefem.solver.newton`,
    *Predictor*)."""

    lam: np.ndarray
    d: np.ndarray


@dataclass
class Iterate:
    """A (possibly converged) solution: combined vector x = [u; lam], the active set it satisfies, the tangential
    displacements of the last converged step (``slip_ref``, m) and, with a plastic fill, the fill's plastic strain at
    its quadrature points."""

    x: PETSc.Vec
    active: ContactState
    slip_ref: np.ndarray
    plastic_strain: np.ndarray | None = None


@dataclass
class StepOutcome:
    """Result of one load step; ``reason`` is empty when converged. A failure with ``mechanism`` set showed
    a singular system or a response unbounded along an admissible mode (no equilibrium; :mod:`bridgefem.solver.newton`,
    *Mechanism verdicts*); other failures are non-convergence. ``counts``: the pairs per state of the joint law, and
    the frozen and bonded ones."""

    converged: bool
    reason: str
    iterations: int
    residual: float
    factorisations: int
    iterate: Iterate | None = None
    counts: dict = field(default_factory=dict)
    mechanism: bool = False
    proved: bool = False
    unbounded: bool = False  # the failed step ended on a solve that was singular or diverged (along any mode)
    diverged: bool = False  # some solve of the failed step was singular or diverged
    equilibrium: bool = False  # a failure read off a converged equilibrium (a flat load-deflection curve, a collapse
    # state): the solver did not fail, so no other solver setting is tried for it
    upper: float | None = None  # a failure read off the converged state below it (a collapse state after every solver
    # setting failed): the bracket's upper end that reading sets, N per unit load factor (None: the failed level)


class Proposal(NamedTuple):
    """A solved (good) active set, the set it proposed, the proposed changes still applied, the violations (N)."""

    good: ContactState
    proposal: ContactState
    pending: np.ndarray
    violation: np.ndarray


@dataclass(frozen=True)
class StepTask:
    """What one load step solves, and its limits: fixed for the step."""

    level: float  # live-load level (N per unit load factor)
    start: Iterate  # the converged start
    f_scale: float  # the largest applied nodal force (N)
    budget: int  # Newton iterations
    chains: float  # recovered damping chains after which a failure ends the step
    searching: bool  # every Newton step is line searched
    first_factorisation: int  # the solver's factorisations before the step


@dataclass
class Recovery:
    """A step's failed solves and their recovery (:mod:`bridgefem.solver.recovery`)."""

    damping: bool = False  # in a damping chain
    recovered: int = 0  # damping chains that ended with a solved active set
    mechanisms: int = 0  # failed solves that were singular or diverged along an admissible mode
    singular: ActiveSetFailure | None = None  # the last singular proposal
    fix: ContactState | None = None  # the repair of the set whose solve failed last
    repairs: dict = field(default_factory=dict)  # global key of a set whose diverging mode was inadmissible -> repair
    last_repair: bool = False  # the repair solved in place of giving up, once a step
    unbounded: bool = False  # the last solve was singular or diverged (along any mode)
    diverged: bool = False  # some solve of the step was singular or diverged

    def solved(self) -> None:
        """A set solved: the damping chain, if one was open, ended and recovered."""
        self.recovered, self.damping = self.recovered + self.damping, False


@dataclass
class CycleMemory:
    """The active sets a step visited and the pairs its cycles held (:mod:`bridgefem.solver.cycle_breaking`), per
    local pair."""

    frozen: np.ndarray  # local pairs whose friction state cycled: kept holding while closed
    bonded: np.ndarray  # local pairs whose open / closed state cycled: kept closed and holding
    churn: np.ndarray  # the proposals of this step that changed each local pair
    # global keys of the active sets visited at this level -> the line search's merit at the iterate that proposed
    # each (inf: none, or not proposed by a solved iterate)
    seen: dict = field(default_factory=dict)
    condensed: int | None = None  # global key of the last set a cycle's condensation proposed (no leap test)

    @classmethod
    def empty(cls, pairs: int) -> "CycleMemory":
        """No pair held or changed yet, for ``pairs`` local pairs."""
        return cls(np.zeros(pairs, dtype=bool), np.zeros(pairs, dtype=bool), np.zeros(pairs, dtype=np.int64))


@dataclass
class ProximalSolves:
    """The active sets a step solved with the proximal term (:mod:`bridgefem.solver.recovery`, *Proximal solves*)."""

    sets: dict = field(default_factory=dict)  # global key -> the set's plain failure
    count: int = 0  # sets solved with the proximal term in this step
    drift: ActiveSetFailure | None = None  # the plain failure of a proximal set that drifts along its mode


@dataclass
class NewtonStep:
    """The state of one load step's Newton iteration: its task, the iterate and what the iteration remembers of its
    failed solves, its cycles and its proximal solves; ``stats``, the solver's counters."""

    task: StepTask
    x: PETSc.Vec  # the current iterate [u; lam]
    active: ContactState  # the active set solved next
    near: PETSc.Vec  # the last solved iterate: the proximal term's anchor
    anchor: PETSc.Vec | None  # the line search's linearisation point
    plastic: np.ndarray | None  # the fill's trial plastic strain at x
    memory: CycleMemory
    stats: dict
    it: int = 0  # the current iteration
    key: int = 0  # the global key of the set solved in this iteration
    base: Proposal | None = None  # the last good active set and what it proposed
    predicted: Proposal | None = None  # the predictor's proposal, until an active set solves
    merit: float = np.inf  # the line search's merit at anchor: the first Newton step is taken in full
    residual: float = np.inf  # the scaled out-of-balance force of the last solved iterate
    recovery: Recovery = field(default_factory=Recovery)
    proximal: ProximalSolves = field(default_factory=ProximalSolves)

    def factorisations(self) -> int:
        """The factorisations made since the step began."""
        return self.stats["factorisations"] - self.task.first_factorisation

    def ended(self, reason: str, mechanism: bool = False, proved: bool = False) -> StepOutcome:
        """The failed outcome of the step at its current iteration."""
        return StepOutcome(False, reason, self.it, self.residual, self.factorisations(), mechanism=mechanism,
                           proved=proved)

    def take(self, proposal: Proposal, key: int) -> None:
        """The proposed set (global key ``key``) is solved next; the set that proposed it is the good one."""
        self.memory.seen[key] = self.merit
        self.base, self.active = proposal, proposal.proposal


@dataclass(frozen=True)
class Ranks:
    """The collective readings of local pair data over the ranks of ``comm``."""

    comm: MPI.Comm

    def any(self, flag: bool) -> bool:
        """Whether ``flag`` holds on some rank."""
        return bool(self.comm.allreduce(int(flag), op=MPI.MAX))

    def count(self, mask: np.ndarray) -> int:
        """The number of pairs set in a local mask, over all ranks."""
        return self.comm.allreduce(int(np.count_nonzero(mask)))

    def key(self, active: ContactState) -> int:
        """The global identity of an active set."""
        return hash(tuple(self.comm.allgather(active.key())))
