"""Cycles of a few pairs solved exactly on their condensed compliance (step 6 of :mod:`bridgefem.solver.newton`,
:mod:`bridgefem.solver.cycle_breaking`).

**Cycles.** When the active set returns to one already solved in the step and at most ``CONDENSED_PAIRS`` pairs
change, those pairs are solved exactly with every other pair's state held (:meth:`CycleCondenser.condensed`):

1. Their relative displacements are affine in their forces, d = d0 + C lam: d0 from one solve with the pairs open,
   C column by column from a unit force at each of their law rows (at most 2p + 1 solves with one factorisation:
   :meth:`CycleCondenser.compliance`).
2. :func:`bridgefem.solver.condensation.consistent_states` finds a state of theirs that the joint law accepts (up to
   four pairs by enumerating their states, above by Lemke's method on the law's complementarity problem).
3. The iteration goes on from that active set, so its end is checked like any other (no law is waived).

With every other closed pair holding, C is the Schur complement of a symmetric positive definite matrix; with pairs
sliding elsewhere (non-associative: lam_t = s mu lam_n) it is not symmetric and its normal block need not be a
P-matrix (:func:`bridgefem.solver.condensation.opens_when_pulled`): then the small problem has no solution or several
(a crack-tip pair penetrating when open and in tension when closed), and the held slips are what is wrong. Such a
condensation is not used; it is repeated with every other sliding pair holding (their slip is re-derived by the
next iterations). A cycle of more pairs, or with no consistent state either way, goes on to damping and bonding.
The compliances are kept per held active set and pairs while the matrix depends on them alone (a cycle condensed
again costs one solve), and the pairs whose normal block failed are solved first the next time (a cycle usually fails
at the same crack-tip pair).

**Rounding.** With the pairs open and slips held elsewhere the system can be so nearly singular that a unit force's
response is rounding, and the sign of a pair's own entry C_nn then depends on it (it differed between one MPI rank
and two). A P-matrix verdict is taken only where it exceeds the rounding: a normal column that moves some pair more
than ``AMPLIFIED`` times its own entry has its error measured by one step of iterative refinement
(:meth:`PairSolves.unit_force_error`, one more solve), and the block is kept only when its distance from failing the
test (:func:`bridgefem.solver.condensation.pulled_margin`) exceeds ``ROUNDING_MARGIN`` times the Frobenius norm of its
estimated error (a bound of that error's 2-norm; the factor covers the estimate's own rounding). Declining is always
safe (the caller holds the other slips, then damps): it changes the path, never what counts as converged.

The condensation uses the contact system (:mod:`bridgefem.solver.system`) through :class:`PairSolves` (its
factorisation is reused: the pairs' columns of C are solves with one matrix) and counts its solves as
``condensation_solves``.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np
from mpi4py import MPI

from ..fe.pairs import JointPairs
from ..laws.base import ContactState, JointLaw
from .condensation import consistent_states, opens_when_pulled, pulled_margin

CONDENSED_PAIRS = 24  # a cycle of at most this many pairs is solved exactly on their compliance (<= 2p + 1 solves)
AMPLIFIED = 1e4  # a normal column moving some pair more than this multiple of its own entry has its rounding measured
ROUNDING_MARGIN = 10.0  # a normal block's P-matrix margin must exceed this multiple of its estimated error's norm


class PairSolves(Protocol):
    """What a condensation needs of the contact system (:class:`bridgefem.solver.system.ContactSystem`): the
    communicator, the joint law and the pairs of this rank, the solve counters (``solves``, ``condensation_solves``)
    and two solves of an active set's system, each with the factorisation of that set's matrix."""

    comm: MPI.Comm
    law: JointLaw
    pairs: JointPairs
    stats: dict

    def active_set_displacements(self, level: float, active: ContactState, slip_ref: np.ndarray
                                 ) -> np.ndarray | None:
        """The relative displacements d (local pairs, (m, 2), m; normal with the ground offset) of the solution of
        ``active``'s system under the loads at live level ``level``; None when the solve fails. Collective."""

    def unit_force_displacements(self, active: ContactState, row: int | None) -> np.ndarray | None:
        """The relative displacements (local pairs, (m, 2), m per N; no ground offset) of the solution of
        ``active``'s system under a unit force alone at local law row ``row`` (2 k normal, 2 k + 1 tangential of
        local pair k; None: no force on this rank); None when the solve fails. Collective."""

    def unit_force_error(self) -> np.ndarray | None:
        """An estimate of the error (local pairs, (m, 2), m per N) of the last :meth:`unit_force_displacements`
        from one step of iterative refinement (:meth:`bridgefem.solver.linear.CheckedSolve.correction`: one more solve
        with its factorisation); None when that solve fails. Collective."""


class CycleCondenser:
    """Solves the pairs of a cycle in consistent states on their condensed compliance (module docstring), keeping
    each compliance (or its decline) per held active set and pairs while the matrix depends on them alone
    (``reuse``: without a plastic fill) until :meth:`forget`, and the pairs whose normal block declined one."""

    def __init__(self, system: PairSolves, reuse: bool):
        self.system = system
        self.comm = system.comm
        self.reuse = reuse
        self._compliances: dict = {}  # (held active set, pairs) -> condensed compliance or None (:meth:`compliance`)
        self._declining: set[int] = set()  # global pairs at which a condensation's normal block failed

    def forget(self) -> None:
        """Drop the kept compliances: the law's constants (mu, c) in the matrix changed."""
        self._compliances = {}

    def condensed(self, level: float, active: ContactState, cycling: np.ndarray, slip_ref: np.ndarray,
                  reference: ContactState) -> ContactState | None:
        """``active`` with the pairs of a cycle in consistent states (the module's *Cycles*): the pairs
        ``cycling`` (a local mask, at most ``CONDENSED_PAIRS`` in all), condensed onto their forces
        (:mod:`bridgefem.solver.condensation`; ``reference``, the converged start's active set, breaks ties) with every
        other pair's state of ``active`` held, else with every other sliding pair sticking; a condensation whose normal
        compliance is not a P-matrix is not used. None when there are too many, a solve fails, or no combination is
        consistent. Collective."""
        if self.comm.allreduce(int(np.count_nonzero(cycling))) > CONDENSED_PAIRS:
            return None

        def gather(a: np.ndarray) -> np.ndarray:  # the cycling pairs' entries of all ranks, in global order
            return np.concatenate(self.comm.allgather(a[cycling]))

        law, stats = self.system.law, self.system.stats
        cycle_law = law.gathered(cycling, self.comm)
        stuck = active.copy()
        slips = law.sliding(stuck) & ~cycling  # every other sliding pair, held
        law.hold(stuck, slips)
        slips_elsewhere = bool(self.comm.allreduce(int(slips.any()), op=MPI.MAX))
        for held in (active, stuck)[:1 + slips_elsewhere]:
            before = stats["solves"]
            response = self.pair_response(level, held, cycling, slip_ref)
            stats["condensation_solves"] += stats["solves"] - before
            found = None if response is None else consistent_states(
                cycle_law, *response, ContactState(gather(reference.state), gather(reference.sign)),
                ContactState(gather(active.state), gather(active.sign)))
            if found is not None:
                lo = self.comm.exscan(int(cycling.sum())) or 0
                mine = slice(lo, lo + int(cycling.sum()))
                solved = held.copy()
                solved.state[cycling], solved.sign[cycling] = found[0].state[mine], found[0].sign[mine]
                return solved
        return None

    def pair_response(self, level: float, active: ContactState, pairs: np.ndarray, slip_ref: np.ndarray
                      ) -> "tuple[np.ndarray, np.ndarray] | None":
        """The relative displacements of ``pairs`` (local mask; gathered in global order) as an affine function of
        their forces, every other pair's state of ``active`` held: d0 (p, 2; normal with the ground offset, slip
        since the last converged step, m) with the pairs open (one solve), and their compliance C (2p, 2p, m/N,
        :meth:`compliance`); None when a solve fails or C's normal block is not a P-matrix (the condensation is not
        used: the module's *Cycles*). Collective."""
        trial = active.copy()
        self.system.law.release(trial, pairs)
        C = self.compliance(trial, pairs)
        if C is None:
            return None
        d = self.system.active_set_displacements(level, trial, slip_ref)
        if d is None:
            return None
        d0 = d[pairs] - np.column_stack([np.zeros_like(slip_ref), slip_ref])[pairs]
        return np.concatenate(self.comm.allgather(d0)), C

    def compliance(self, trial: ContactState, pairs: np.ndarray) -> np.ndarray | None:
        """The compliance C (2p, 2p, m/N; rows and columns (n, t) per pair in global order) of ``pairs`` (local mask),
        open in ``trial``: column j is the pairs' relative displacement under a unit force alone at their j-th law row
        (lam = r), one solve each with the factorisation of ``trial``'s matrix. The normal columns come first, and after
        each the principal block of C_nn of the pairs solved so far is tested
        (:func:`bridgefem.solver.condensation.opens_when_pulled`): a block that fails stops with None (every principal
        submatrix of a P-matrix is one, and of a matrix with a positive definite symmetric part has one, so C_nn fails
        too), so a declined condensation costs only the solves up to the pair that shows it. Pairs that showed it before
        are solved first: a cycle condensed again, with other pairs or held states, usually fails at the same crack-tip
        pair. None too when a solve fails. With ``reuse`` the matrix depends only on the active set and the law's
        constants, so C (or its decline) is kept per (``trial``, ``pairs``) until :meth:`forget`: a cycle condensed
        again with the same held states costs no solve. Collective."""
        comm = self.comm
        ids = np.concatenate(comm.allgather(self.system.pairs.offset + np.flatnonzero(pairs)))  # global, C's order
        key = (tuple(comm.allgather(trial.key())), ids.tobytes())
        if self.reuse and key in self._compliances:
            return self._compliances[key]
        rows = 2 * np.flatnonzero(pairs)  # the local law rows of the pairs' normal forces
        owner = np.concatenate([np.full(n, r) for r, n in enumerate(comm.allgather(int(pairs.sum())))])
        first = np.searchsorted(owner, comm.rank)
        order = sorted(range(len(ids)), key=lambda i: ids[i] not in self._declining)  # stable: known ones first
        C, error = np.zeros((2 * len(ids), 2 * len(ids))), np.zeros((2 * len(ids), 2 * len(ids)))  # error: of C
        declined = False
        for k, j in enumerate([*(2 * i for i in order), *(2 * i + 1 for i in order)]):  # normal, then tangential
            row = rows[j // 2 - first] + j % 2 if owner[j // 2] == comm.rank else None
            d = self.system.unit_force_displacements(trial, row)
            if d is None:
                return None
            C[:, j] = np.concatenate(comm.allgather(d[pairs])).ravel()
            if k >= len(ids):
                continue
            solved = order[:k + 1]
            holds = opens_when_pulled(_pairs_block(C, solved))
            if holds and comm.allreduce(np.abs(d).max(initial=0.0), op=MPI.MAX) > AMPLIFIED * abs(C[j, j]):
                e = self.system.unit_force_error()  # the module's *Rounding*
                if e is None:
                    return None
                error[:, j] = np.concatenate(comm.allgather(e[pairs])).ravel()
                holds = pulled_margin(_pairs_block(C, solved)) > ROUNDING_MARGIN * np.linalg.norm(
                    _pairs_block(error, solved)[0::2, 0::2])
            if not holds:
                self._declining.add(int(ids[j // 2]))
                declined = True
                break
        if self.reuse:
            self._compliances[key] = None if declined else C
        return None if declined else C


def _pairs_block(C: np.ndarray, pairs: list[int]) -> np.ndarray:
    """The principal block of a condensed compliance C (rows and columns (n, t) per pair) of some of its pairs."""
    rows = np.ravel([(2 * i, 2 * i + 1) for i in pairs])
    return C[np.ix_(rows, rows)]
