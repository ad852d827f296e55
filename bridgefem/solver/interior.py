"""The contact system's linear solves with the blocks' interiors condensed out once (static condensation).

Only the joint law's rows of the contact system (:mod:`bridgefem.solver.system`) change with the active set; without a
plastic fill the stiffness K is constant. The law's rows touch the displacements only at the joint faces' nodes
(through G), so the displacement unknowns split into the *interface* dofs B (every dof a law row touches) and the
*interior* dofs I (all others: inside the voussoirs, on their intrados and extrados, an elastic fill's), and with the
joint forces L the combined matrix is

    [ K_II  K_IB   0    ] [u_I]   [b_I]
    [ K_BI  K_BB  -G_B^T] [u_B] = [b_B]
    [ 0     A_LB   A_LL ] [lam]   [b_L]

where only A_LB and A_LL (the law's rows) change. K_II is the stiffness of every block with its faces held: it is
nonsingular and block-diagonal (one block per connected component: a voussoir, a pier course, a fill), factorised
once; its Schur complement Z = K_BI K_II^-1 K_IB is dense within each block and computed once, from one more
factorisation of the block with its faces last (:func:`trailing_schur`; one solve per face dof where that order
cannot be kept). A solve of the
active set's system is then (Saad 2003, *Iterative Methods for Sparse Linear Systems*, sec. 14.2; the substructuring
of Przemieniecki 1963):

1. y_I = K_II^-1 b_I (each block's factor);
2. solve the reduced system R x_S = b_S - A_SI y_I for S = (B, L), with R = A_SS - [[Z, 0], [0, 0]] (its law rows the
   active set's), by the run's solver (by default MUMPS LU), refactorised only when the law's rows changed, and then
   only when the low-rank correction of an earlier factorisation would cost more (:mod:`bridgefem.solver.low_rank`);
3. u_I = K_II^-1 (b_I - K_IB u_B).

R is singular exactly when the whole system is (K_II is nonsingular): MUMPS finding R numerically singular marks the
solve singular, as it would the whole system's. Every solve is checked on the whole system by the caller
(:class:`bridgefem.solver.linear.CheckedSolve`: its backward error), so a condensed solve that lost accuracy is a
failure, never a mechanism. R has the joint faces' and the joints' unknowns only: a refactorisation costs a fraction
of the whole system's, and the blocks' interiors are factorised once per analysis instead of once per active set.

The whole matrix is gathered on every rank once. The blocks are shared out over the ranks: each rank factorises its
blocks, forms their Schur complements (gathered into R on every rank) and solves them in steps 1 and 3 (the results
summed over the ranks); every rank factorises and solves the same reduced system (identical on every rank, so every
rank's decisions agree; distributed over the ranks by MUMPS it was slower) and keeps its owned share of the solution.

:meth:`InteriorCondensation.of` returns None, and the caller factorises the whole system, when a law row touches an
interior dof's row, when a block has no interface dof (its K_II singular) or when a block's factorisation fails; where
the reduced system would have more than ``REDUCED_SHARE`` of the unknowns (elements a joint long or more: a whole
factorisation then costs little more than the reduced one, and the condensation's set-up more than it saves); and where
R would store more entries than the whole system (a block with long faces, such as an elastic fill along the whole
extrados: its dense Schur complement factorises slower than the whole system's sparse one). Both measured with
``benchmarks/cost_growth.py`` and a fill's run (docs/benchmarks.md, *The blocks' interiors condensed once*).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from mpi4py import MPI
from petsc4py import PETSc
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from .low_rank import LowRankUpdate

REDUCED_SHARE = 1.0 / 3.0  # condensed only where the reduced system has at most this share of the unknowns


class InteriorCondensation:
    """The condensed solves of the module docstring for the gathered combined matrix A (global combined numbering, on
    every rank) whose rows ``law`` (the joint law's) are the only ones that change. The blocks are shared out over
    the ranks (each factorised and solved by one); :meth:`of` builds it from the distributed matrix."""

    def __init__(self, A: sp.csr_matrix, law: np.ndarray, comm, ranges: np.ndarray):
        self.comm, self.ranges, self.N, self.L = comm, ranges, A.shape[0], law
        is_law = np.zeros(self.N, dtype=bool)
        is_law[law] = True
        self._law_part = A[law]
        touched = np.zeros(self.N, dtype=bool)
        touched[self._law_part.indices] = True
        self.B = np.flatnonzero(touched & ~is_law)
        self.I = np.flatnonzero(~touched & ~is_law)
        self.S = np.concatenate([self.B, self.L])
        self._last = (np.zeros(0), np.zeros(0))  # the last interior loads b_I and A_SI K_II^-1 b_I
        self.blocks: list[tuple[np.ndarray, object]] = []  # this rank's blocks: positions in I, sparse LU

    def _couplings(self, A: sp.csr_matrix) -> None:
        """The parts of A the condensation reads: K_II, A_IS (its first |B| columns K_IB), A_SI and A_BS."""
        A_I = A[self.I]
        self.A_II, self.A_IS, self.A_SI = A_I[:, self.I].tocsc(), A_I[:, self.S].tocsr(), A[self.S][:, self.I].tocsr()
        self.A_IB = self.A_IS[:, :len(self.B)].tocsr()
        self._A_BS = A[self.B][:, self.S]

    @classmethod
    def of(cls, A: PETSc.Mat, law_local: np.ndarray) -> "InteriorCondensation | None":
        """The condensation of the distributed combined matrix A whose local rows ``law_local`` (indices into the
        rank's owned rows) are the law's; None where it does not apply (module docstring). Collective."""
        comm = A.getComm().tompi4py()
        first, last = A.getOwnershipRange()
        full, N = gathered(A), A.getSize()[0]
        law = np.concatenate(comm.allgather(first + np.asarray(law_local, dtype=np.int64)))
        built = cls(full, law, comm, np.array(comm.allgather((first, last))))
        if len(built.S) > REDUCED_SHARE * N:
            return None
        built._couplings(full)
        if built.A_IS[:, len(built.B):].nnz:  # a joint force acting on an interior dof: not a contact system
            return None
        blocks = built._blocks()
        dense = sum(len(faces) ** 2 for _, faces in blocks)  # the entries of the blocks' Schur complements
        if built._A_BS.nnz + built._law_part.nnz + dense > full.nnz:  # R's entries: A_SS's and Z's
            return None
        schur = built._factorise_blocks(blocks)
        if not comm.allreduce(int(schur is not None), op=MPI.MIN):
            return None
        built._reduced_system(schur)
        own = [dofs for dofs, _ in built.blocks]
        built._own = np.concatenate(own) if own else np.zeros(0, dtype=np.int64)
        built._A_IS_own, built._A_SI_own = built.A_IS[built._own], built.A_SI[:, built._own].tocsr()
        return built

    def _blocks(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The connected components of K_II (each a block's interior: positions in I) with their face dofs (the
        positions in B its rows couple to)."""
        count, label = connected_components(self.A_II, directed=False)
        order = np.argsort(label, kind="stable")
        return [(dofs, np.unique(self.A_IB[dofs].indices))
                for dofs in np.split(order, np.searchsorted(label[order], np.arange(1, count)))]

    def _factorise_blocks(self, blocks: list[tuple[np.ndarray, np.ndarray]]
                          ) -> "tuple[np.ndarray, np.ndarray, np.ndarray] | None":
        """Factorise this rank's share of the ``blocks`` (:meth:`_blocks`; sparse LU; shared out by size, the
        largest first, each to the rank with the fewest dofs so far) and return their Schur complements
        Z = K_BI K_II^-1 K_IB (N/m) as (rows in B, columns in S, values); None where a block cannot be condensed
        (one without interface dofs, whose K_II is singular)."""
        load = np.zeros(self.comm.size)
        A_BI = self.A_SI[:len(self.B)].tocsc()
        rows, cols, vals = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)], [np.zeros(0)]
        for b in sorted(range(len(blocks)), key=lambda b: (-len(blocks[b][0]), b)):
            rank = int(np.argmin(load))
            load[rank] += len(blocks[b][0])
            if rank != self.comm.rank:
                continue
            dofs, faces = blocks[b]
            if not len(faces):  # a block without interface dofs: its K_II is singular
                return None
            coupling, K_II = self.A_IB[dofs], self.A_II[dofs][:, dofs].tocsc()
            try:
                lu = splu(K_II, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options={"SymmetricMode": True})
            except RuntimeError:  # exactly singular
                return None
            back = A_BI[:, dofs].tocsr()
            touching = np.flatnonzero(np.diff(back.indptr))
            Z = (trailing_schur(lu, K_II, coupling[:, faces], back[faces], self._A_BS[faces][:, faces])
                 if np.array_equal(touching, faces) else None)
            if Z is None:  # no faces-last factorisation: one solve per face dof
                Z = back[touching] @ lu.solve(coupling[:, faces].toarray())
            if not np.all(np.isfinite(Z)):
                return None
            self.blocks.append((dofs, lu))
            rows.append(np.repeat(touching, len(faces)))
            cols.append(np.tile(faces, len(touching)))
            vals.append(Z.ravel())
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)

    def _reduced_system(self, schur: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """R = A_SS - [[Z, 0], [0, 0]] (step 2), the same on every rank: the blocks' Schur complements gathered
        (their entries disjoint: each face dof is one block's), the law rows last. Collective."""
        parts = self.comm.allgather(schur)
        n_b, n_s = len(self.B), len(self.S)
        Z = sp.csr_matrix((np.concatenate([p[2] for p in parts]),
                           (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))),
                          shape=(n_b, n_s))
        upper = (self._A_BS - Z).tocoo()
        law_part = self._law_part
        position = np.full(self.N, -1, dtype=np.int64)
        position[self.S] = np.arange(n_s)
        self._upper_values = upper.data
        rows = np.concatenate([upper.row, n_b + np.repeat(np.arange(law_part.shape[0]), np.diff(law_part.indptr))])
        cols = np.concatenate([upper.col, position[law_part.indices]])
        slots = sp.csr_matrix((np.arange(1, len(rows) + 1, dtype=float), (rows, cols)), shape=(n_s, n_s))
        slots.sort_indices()
        self._perm = slots.data.astype(np.int64) - 1
        self._indptr, self._indices = slots.indptr.astype(PETSc.IntType), slots.indices.astype(PETSc.IntType)
        self.R = PETSc.Mat().createAIJ(size=(n_s, n_s), csr=(self._indptr, self._indices,
                                                             self._values(law_part.data)), comm=PETSc.COMM_SELF)
        self.R.assemble()
        first = self._indptr[n_b]  # R's law rows: the last |L|, their entries from ``first`` on
        self._law_indptr, self._law_indices = self._indptr[n_b:] - first, self._indices[first:]
        self._law_perm = self._perm[first:] - len(self._upper_values)
        self._law_rows = np.arange(n_b, n_s, dtype=PETSc.IntType)
        self._rhs, self._x = self.R.createVecLeft(), self.R.createVecRight()
        self.update = LowRankUpdate(self.R, n_b, self._law_indptr, self._law_indices,
                                    law_part.data[self._law_perm], self._write, self.comm)
        del self._A_BS, self._law_part

    def _values(self, law_values: np.ndarray) -> np.ndarray:
        """R's values (its CSR order) with the law rows' ``law_values`` in the order of the gathered rows."""
        return np.concatenate([self._upper_values, law_values])[self._perm]

    def law_changed(self, law_values: np.ndarray) -> bool:
        """Take the law rows' new values (this rank's law rows, CSR order); True when R must be factorised again (they
        are then in R), False when the factorisation of R as it stands serves, updated (:mod:`bridgefem.solver.low_rank`).
        Collective."""
        return not self.update.follows(np.concatenate(self.comm.allgather(law_values))[self._law_perm])

    def _write(self, values: np.ndarray) -> None:
        """Put the law rows' ``values`` (R's law rows, CSR order) into R."""
        self.R.setValuesIJV(self._law_indptr, self._law_indices, values, rowmap=self._law_rows)
        self.R.assemble()

    def _own_solve(self, rhs: np.ndarray) -> np.ndarray:
        """K_II^-1 rhs on this rank's blocks (``rhs`` and the result on :attr:`_own`, the blocks' positions in I in
        their order)."""
        out = np.empty_like(rhs)
        at = 0
        for dofs, lu in self.blocks:
            out[at:at + len(dofs)] = lu.solve(rhs[at:at + len(dofs)])
            at += len(dofs)
        return out

    def solve(self, ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """x = A^-1 b by steps 1-3 of the module docstring, the reduced system solved by ``ksp`` (its operator R):
        each rank solves its blocks, A_SI y summed over the ranks in step 1 and u_I in step 3. Raises PETSc.Error
        where ``ksp`` fails. Collective."""
        full = np.concatenate(self.comm.allgather(b.array))
        b_I, b_S = full[self.I], full[self.S]
        if not np.array_equal(b_I, self._last[0]):  # step 1 again only for new interior loads
            coupled = self._A_SI_own @ self._own_solve(b_I[self._own]) if b_I.any() else np.zeros(len(self.S))
            self._last = (b_I, self._summed(coupled))
        self._rhs.array[:] = b_S - self._last[1]
        self.update.solve(ksp, self._rhs, self._x)
        x_S = self._x.array
        interior = np.zeros(len(self.I))
        interior[self._own] = self._own_solve(b_I[self._own] - self._A_IS_own @ x_S)
        solution = np.empty(self.N)
        solution[self.S] = x_S
        solution[self.I] = self._summed(interior)
        first, last = self.ranges[self.comm.rank]
        x.array[:] = solution[first:last]

    def _summed(self, a: np.ndarray) -> np.ndarray:
        """``a`` summed over the ranks (each rank's entries zero where another's blocks are). Collective."""
        if self.comm.size > 1:
            self.comm.Allreduce(MPI.IN_PLACE, a, op=MPI.SUM)
        return a


def gathered(A: PETSc.Mat) -> sp.csr_matrix:
    """The distributed matrix ``A`` whole on every rank (scipy CSR, global numbering: the ranks' rows in order).
    Collective."""
    indptr, indices, data = A.getValuesCSR()
    N = A.getSize()[0]
    parts = A.getComm().tompi4py().allgather((indptr, indices, data))
    return sp.vstack([sp.csr_matrix((d, j, i), shape=(len(i) - 1, N)) for i, j, d in parts]).tocsr()


def trailing_schur(lu, K_II: sp.csc_matrix, K_IF: sp.spmatrix, K_FI: sp.spmatrix, K_FF: sp.spmatrix
                   ) -> "np.ndarray | None":
    """Z = K_FI K_II^-1 K_IF (N/m, dense |F| x |F|) of one block, its interior stiffness ``K_II`` factorised in
    ``lu`` (scipy's SuperLU), from one more sparse LU instead of |F| solves:

    1. order the block's matrix [[K_II, K_IF], [K_FI, K_FF + D]] with its interior in ``lu``'s fill-reducing order
       and its face dofs F last; D = d I, d the mean of K_FF's diagonal, holds the faces elastically (a voussoir
       alone is free: its own stiffness is singular by its rigid motions), so that the matrix is symmetric positive
       definite; Z does not depend on D;
    2. factorise it with that order kept (SuperLU's natural order, diagonal pivots). Eliminating the interior first
       leaves the Schur complement K_FF + D - Z in the trailing block: L_FF U_FF (Golub & Van Loan 2013, *Matrix
       Computations*, sec. 3.2.10);
    3. Z = K_FF + D - L_FF U_FF.

    SuperLU post-orders its elimination tree; the faces stay last when the interior is connected (the tree's interior
    part then hangs from the first face dof, the faces a chain above it), which is checked on the factor's
    permutations: None where they moved or the factorisation failed (the caller then solves)."""
    n_i, n_f = K_II.shape[0], K_FF.shape[0]
    interior = np.argsort(lu.perm_c)  # the interior's dofs in the order lu eliminated them
    held = sp.csr_matrix(K_FF) + K_FF.diagonal().mean() * sp.eye(n_f)
    M = sp.bmat([[K_II[interior][:, interior], K_IF[interior]], [K_FI[:, interior], held]], format="csc")
    try:
        full = splu(M, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:
        return None
    tail = np.arange(n_i, n_i + n_f)
    if not (np.array_equal(full.perm_c[n_i:], tail) and np.array_equal(full.perm_r[n_i:], tail)):
        return None
    return held.toarray() - full.L[n_i:, n_i:].toarray() @ full.U[n_i:, n_i:].toarray()
