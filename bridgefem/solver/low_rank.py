"""The reduced system's solves for a new active set from the factorisation of an earlier one, corrected for the law
rows that changed since (the Sherman-Morrison-Woodbury formula).

Between two active sets only the joint law's rows of the reduced system R change (:mod:`bridgefem.solver.interior`),
and an iteration of the active-set method changes a few of them: a handful to a tenth. With R0 the matrix last
factorised and k of its law rows r_1 .. r_k changed since, to R0's rows plus v_j^T,

    R = R0 + E V^T,       E = [e_r1 .. e_rk],   V^T = [v_1^T; ..; v_k^T]
    R^-1 b = y - W C^-1 V^T y,     y = R0^-1 b,   W = R0^-1 E,   C = I_k + V^T W

(Woodbury 1950; Hager 1989, *Updating the inverse of a matrix*, SIAM Review 31; a factorisation updated this way
for the active sets of a QP: Gill, Murray, Saunders & Wright 1984). :class:`LowRankUpdate`:

1. *New active set*: the law rows whose values differ from R0's. A column of W (R0^-1 e_r, one per row r) is
   computed once after each factorisation and kept, so an active set costs the columns of the rows that never
   changed before since R0; with MPI each rank computes a share of them (every rank holds R0's factors).
2. *Rent or buy*: R is factorised again instead when the columns computed since R0 and those the new set needs
   would cost more than one factorisation (the rule of the ski-rental problem: at most twice the cost of the best
   choice in hindsight; Karlin, Manasse, Rudolph & Sleator 1988), or when W would hold more entries than R0's
   factors. Costs in flops, from MUMPS's own counts of R0's factors: a factorisation RINFOG(3), a column
   4 INFOG(29) (a forward and a backward substitution, a multiply and an add per entry of the factors). They depend
   on R0 alone, so every rank (each holds the same R) and every run decides alike. Without MUMPS's LU (a user's
   solver options) every new active set is factorised.
3. *Solve*: y by R0's factors, then x = y - W C^-1 V^T y with C factorised (dense LU, k x k) once per active set.
4. *Check*: x's normwise backward error on R, |R x - b|_inf / (|R|_inf |x|_inf + |b|_inf), must be at most
   ``UPDATE_TOL``; else R is factorised and the system solved afresh. A factorisation's backward error is of the
   order of the rounding unit; an updated solve reaches it unless C is ill-conditioned, which it is when the new
   active set's R is nearly singular (near a mechanism): then the factorisation decides, and a singular R is
   reported as MUMPS reports it (:mod:`bridgefem.solver.linear`), as without the update.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from mpi4py import MPI
from petsc4py import PETSc

UPDATE_TOL = 1e-12  # an updated solve whose backward error on R stays above this is solved by a factorisation


def entries(infog: int) -> float:
    """MUMPS's count of an INFOG entry that may be given in millions (a negative value)."""
    return float(infog) if infog >= 0 else -1e6 * infog


class LowRankUpdate:
    """The solves of the module docstring for a reduced system ``R`` (PETSc, sequential: the same on every rank of
    ``comm``) whose rows from ``first`` on are the law's, in CSR order ``indptr`` / ``indices`` (their columns in R)
    with values ``values`` (those R was built with); ``write(values)`` puts law values into R."""

    def __init__(self, R: PETSc.Mat, first: int, indptr: np.ndarray, indices: np.ndarray, values: np.ndarray,
                 write: Callable[[np.ndarray], None], comm):
        self.R, self.first, self.indptr, self.indices, self.write, self.comm = R, first, indptr, indices, write, comm
        self.row_of = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))  # each law entry's row
        self.n = R.getSize()[0]
        self.current = values.copy()
        self._factorised(values)
        self._r, self._dx = R.createVecLeft(), R.createVecRight()
        self.updates = 0  # active sets solved by an update
        self.fallbacks = 0  # updated solves that failed the check and were factorised

    def _factorised(self, values: np.ndarray) -> None:
        """R holds ``values`` and is (about to be) factorised: R0 is R, no column kept, no cost known yet."""
        self.base = values.copy()
        self.columns: dict[int, int] = {}  # law row -> its column of W
        self.W = np.zeros((self.n, 0))
        self.spent = 0.0  # the columns computed since R0, in factorisations
        self.column_cost: float | None = None  # a column's flops over a factorisation's; None: not read yet
        self.max_columns = 0.0  # W may hold as many entries as R0's factors
        self.changed = np.zeros(0, dtype=np.int64)  # law rows differing from R0's
        self.capacitance = None  # LU of C, None while the current set's correction is not built
        self.base_matrix: sp.csr_matrix | None = None  # R0, read at the first update

    def forget(self) -> None:
        """The factorisation is not to be used again (a failed solve): the next active set is factorised."""
        self.spent = np.inf

    def follows(self, values: np.ndarray) -> bool:
        """Take the law rows' new ``values`` (CSR order); True when R0's factorisation serves them, corrected (steps
        1-2), False when R must be factorised again: ``values`` are then written into R."""
        self.current = values.copy()
        rows = np.unique(self.row_of[values != self.base])
        new = np.count_nonzero([r not in self.columns for r in rows])
        if self.column_cost is None or not self.spent + (new * self.column_cost if new else 0.0) <= 1.0 \
                or len(self.columns) + new > self.max_columns:
            self.write(values)
            self._factorised(values)
            return False
        self.changed, self.capacitance = rows, None
        self.updates += 1
        return True

    def solve(self, ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """x = R^-1 b by ``ksp`` (R's solver) with the correction of the current law rows (steps 3-4; a solve that
        fails the check counts in ``fallbacks``). Raises PETSc.Error where ``ksp`` does. Collective (every rank
        solves the same R)."""
        ksp.solve(b, x)
        if self.column_cost is None:
            self._read_costs(ksp)
        if not len(self.changed):
            return
        if self.capacitance is None:
            self._correction(ksp)
        self._correct(x)
        residual = self._residual(b, x)
        if residual is not None:  # one step of iterative refinement (Higham 2002, ch. 12)
            self._r.array[:] = residual
            ksp.solve(self._r, self._dx)
            self._correct(self._dx)
            x.array[:] -= self._dx.array
            residual = self._residual(b, x)
        if self.comm.allreduce(int(residual is not None), op=MPI.MAX):
            self.fallbacks += 1
            self.write(self.current)
            self._factorised(self.current)
            ksp.setOperators(self.R)
            ksp.solve(b, x)

    def _correct(self, y: PETSc.Vec) -> None:
        """y <- y - W C^-1 V^T y: R0^-1 b made R^-1 b (step 3); NaN where C is singular."""
        if self.capacitance is False:
            y.array[:] = np.nan
            return
        z = la.lu_solve(self.capacitance, self._V @ y.array)
        y.array[:] -= self.W[:, [self.columns[r] for r in self.changed]] @ z

    def _read_costs(self, ksp: PETSc.KSP) -> None:
        """A column's cost over a factorisation's from MUMPS's counts (step 2); infinite (every set factorised)
        without MUMPS's LU."""
        pc = ksp.getPC()
        self.column_cost, self.max_columns = np.inf, 0.0
        if ksp.getType() == "preonly" and pc.getType() == "lu" and pc.getFactorSolverType() == "mumps":
            F = pc.getFactorMatrix()
            flops, factors = F.getMumpsRinfog(3), entries(F.getMumpsInfog(29))
            if flops > 0 and factors > 0:
                self.column_cost, self.max_columns = 4.0 * factors / flops, factors / self.n

    def _correction(self, ksp: PETSc.KSP) -> None:
        """V^T (the changed rows' differences, k x n), the columns of W still missing (one solve of several right-hand
        sides by R0's factors) and C's LU (steps 1 and 3); C's LU is False where it is singular."""
        missing = [r for r in self.changed if r not in self.columns]
        if missing:  # each rank solves a share of the new columns: R0 is the same on every rank
            share = np.array_split(np.array(missing), self.comm.size)
            mine = self._columns(ksp, share[self.comm.rank])
            at = self.W.shape[1]
            self.W = np.hstack([self.W, *self.comm.allgather(mine)] if self.comm.size > 1 else [self.W, mine])
            self.columns.update({r: at + j for j, r in enumerate(missing)})
            self.spent += len(missing) * self.column_cost
        entry = np.isin(self.row_of, self.changed)
        position = np.searchsorted(self.changed, self.row_of[entry])
        self._V = sp.csr_matrix(((self.current - self.base)[entry], (position, self.indices[entry])),
                                shape=(len(self.changed), self.n))
        C = np.eye(len(self.changed)) + self._V @ self.W[:, [self.columns[r] for r in self.changed]]
        try:
            with np.errstate(all="ignore"):
                self.capacitance = la.lu_factor(C, check_finite=True)
        except (ValueError, la.LinAlgError):
            self.capacitance = False

    def _columns(self, ksp: PETSc.KSP, rows: np.ndarray) -> np.ndarray:
        """R0^-1 e_r for the law ``rows`` r (n x len(rows)): one solve of several right-hand sides by R0's factors."""
        if not len(rows):
            return np.zeros((self.n, 0))
        E, X = (PETSc.Mat().createDense([self.n, len(rows)], comm=PETSc.COMM_SELF) for _ in range(2))
        for M in (E, X):
            M.setUp()
            M.getDenseArray()[:] = 0.0
            M.assemble()
        E.getDenseArray()[self.first + rows, np.arange(len(rows))] = 1.0
        ksp.getPC().getFactorMatrix().matSolve(E, X)
        columns = X.getDenseArray().copy()
        E.destroy()
        X.destroy()
        return columns

    def _residual(self, b: PETSc.Vec, x: PETSc.Vec) -> np.ndarray | None:
        """None when x's backward error on R = R0 + E V^T is at most ``UPDATE_TOL`` in every row (step 4), measured
        on the row's displacement and force columns apart (their units differ),
        |R x - b|_i / (|R_iu|_1 |x_u|_inf + |R_il|_1 |x_l|_inf + |b_i|); else the residual R x - b."""
        u, rhs = x.array, b.array
        if not np.all(np.isfinite(u)):
            return np.full(self.n, np.inf)
        if self.base_matrix is None:
            self.base_matrix = sp.csr_matrix(self.R.getValuesCSR()[::-1], shape=(self.n, self.n))
            force = (np.arange(self.n) >= self.first).astype(float)
            magnitude = abs(self.base_matrix)
            self.base_sums = np.stack([magnitude @ (1.0 - force), magnitude @ force])
        r = self.base_matrix @ u - rhs
        r[self.first + self.changed] += self._V @ u
        sums = self.base_sums.copy()
        on_force = self.indices >= self.first
        for kind, columns in enumerate((~on_force, on_force)):
            sums[kind, self.first:] = np.bincount(self.row_of[columns], weights=np.abs(self.current[columns]),
                                                  minlength=len(self.indptr) - 1)
        size = sums[0] * np.abs(u[:self.first]).max(initial=0.0) + sums[1] * np.abs(u[self.first:]).max(initial=0.0)
        return None if np.all(np.abs(r) <= UPDATE_TOL * (size + np.abs(rhs))) else r
