"""The linear system of an active set: elastic voussoirs (or a fill's tangent) and the joint law's rows.

Unknowns: displacements u (m) and joint forces lam (N). For a given active set the problem is linear:

    K u - G^T lam = f                                   (equilibrium, N)
    open pair:   lam_n = 0,             lam_t = 0
    stick pair:  c G_n u = 0,           c G_t u = c d_t(ref)          (closed, no slip this step)
    slip pair:   c G_n u = 0,           lam_t - s mu lam_n = 0         (closed, sliding in direction -s)

(for the Coulomb law) with G the relative displacement operator of :mod:`bridgefem.fe.pairs` (d = G u, right face minus
left, normal then tangential; lam_n >= 0 is compression) and c the Alart-Curnier constant (N/m per pair); the rows are
the joint law's (:meth:`bridgefem.laws.base.JointLaw.rows`, :class:`bridgefem.laws.base.LawRows`). An imposed support
movement adds a known offset g to the relative displacements of the pairs on the moving ground, d = G u + g
(:func:`bridgefem.fe.pairs.ground_offsets`, scaled by :meth:`ContactSystem.set_support_movement`): the closed and stick
laws read c G_n u = -c g_n and c G_t u = c (d_t(ref) - g_t). The system lives in one PETSc AIJ matrix whose sparsity
pattern never changes (entries of inactive laws are explicit zeros), so the direct solver's symbolic factorisation is
reused; the matrix is refactorised only when the active set changed. Without a plastic fill only the law's rows
change, and the blocks' interiors are condensed out once (:mod:`bridgefem.solver.interior`, where it pays): only the
reduced system of the joint faces and the joint forces is refactorised, or solved by an earlier set's factorisation
and a low-rank correction for the rows that changed (:mod:`bridgefem.solver.low_rank`). Rank r owns [its u rows, its 2 m_r lam rows]
(:meth:`ContactSystem.comb_u`, :meth:`ContactSystem.comb_lam`).

A *clamp* (:meth:`ContactSystem.clamp`) presses the two faces of each pair together with a normal force T >= 0 (N):
the loads gain -G^T t, t = (T, 0) per pair, and the law then governs lam' = lam + t, the joint force plus the clamp's.
A Coulomb joint with a tensile strength carries the same (lam_n >= -T, |lam_t| <= mu (lam_n + T): the law shifted
along the normal by T), so the clamped system is the scene's with that tensile strength, without a law of its own
(the self-weight's tension continuation, :mod:`bridgefem.search.selfweight`); a compressive bound would be lowered
by T as well.

With a Mohr-Coulomb fill (:mod:`bridgefem.fe.fill`) the stiffness block is the fill's consistent tangent K_t at the
current displacements and the right-hand side carries ``K_t u - f_int(u)`` (N; :meth:`ContactSystem.linearise`).

With the proximal term anchored at an iterate x_k (relative displacements d_k; why and when:
:mod:`bridgefem.solver.recovery`, *Proximal solves*) the free directions of the law's rows
(:meth:`bridgefem.laws.base.JointLaw.free_directions`) get a spring k = ``PROXIMAL`` c:

    open pair:   lam + k (d - d_k) = 0                   (both directions)
    slip pair:   lam_t - s mu lam_n + k (d_t - d_t,k) = 0

Every solve is checked (:class:`bridgefem.solver.linear.CheckedSolve`); a failed factorisation is never reused.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from mpi4py import MPI
from petsc4py import PETSc

from ..fe.pairs import GROUND, JointPairs
from ..laws.base import ContactState, JointLaw, LawRows
from .interior import InteriorCondensation
from .linear import CheckedSolve, SolveFailure

if TYPE_CHECKING:
    from ..fe.fill import FillResponse, PlasticFill

PROXIMAL = 1e-4  # stiffness of the proximal term against the free directions' motion, of the Alart-Curnier constant


class ContactSystem:
    """Builds the combined system of the elastic (or fill) stiffness and the joint law once, and solves it for an
    active set with a factorisation reused while the set and the fill's tangent stay."""

    def __init__(self, K: PETSc.Mat, f_dead: PETSc.Vec, f_live: PETSc.Vec, pairs: JointPairs, law: JointLaw,
                 petsc_options: dict, material: "PlasticFill | None" = None,
                 support_motion: np.ndarray | None = None):
        self.comm = K.getComm().tompi4py()
        self.pairs, self.law = pairs, law
        self.support_motion = np.zeros((len(pairs), 2)) if support_motion is None else support_motion
        self.set_support_movement(0.0)
        self.f_dead, self.f_live = f_dead, f_live
        self.material = material
        self._correction = np.zeros(K.getLocalSize()[0])  # K_t u - f_int of the linearisation (N)
        self._clamp: np.ndarray | float = 0.0  # the clamp's nodal forces -G^T t (owned, N; module docstring)
        self._layout(K)
        self._build(K)
        self._ksp(petsc_options)

    # ----------------------------------------------------------------- layout
    def _layout(self, K: PETSc.Mat) -> None:
        """Combined numbering: rank r owns [its u rows, its 2 m_r lam rows]."""
        comm = self.comm
        u0, u1 = K.getOwnershipRange()
        self.n_u, self.n_lam = u1 - u0, 2 * len(self.pairs)
        ranges = np.array(comm.allgather((u0, u1, self.n_lam)))
        self.u_starts, self.u_ends = ranges[:, 0], ranges[:, 1]
        counts = (ranges[:, 1] - ranges[:, 0]) + ranges[:, 2]
        self.starts = np.concatenate([[0], np.cumsum(counts)])
        self.lam_starts = np.concatenate([[0], np.cumsum(ranges[:, 2])])
        self.n_u_all = ranges[:, 1] - ranges[:, 0]
        self.N = int(self.starts[-1])
        self.n_local = self.n_u + self.n_lam

    def comb_u(self, g: np.ndarray) -> np.ndarray:
        """Combined indices of global displacement dofs ``g``."""
        q = np.searchsorted(self.u_ends, g, side="right")
        return self.starts[q] + g - self.u_starts[q]

    def comb_lam(self, g: np.ndarray) -> np.ndarray:
        """Combined indices of global joint-force rows ``g`` (2 k normal, 2 k + 1 tangential of global pair k)."""
        q = np.searchsorted(self.lam_starts[1:], g, side="right")
        return self.starts[q] + self.n_u_all[q] + g - self.lam_starts[q]

    # ----------------------------------------------------------------- assembly
    def _build(self, K: PETSc.Mat) -> None:
        comm, p = self.comm, self.pairs
        g_rows, g_cols, g_vals = g_entries(p)
        m2 = self.n_lam
        n_u_global = K.getSize()[0]
        g_local = sp.csr_matrix((g_vals, (g_rows, g_cols)), shape=(m2, n_u_global))
        G = PETSc.Mat().createAIJ(size=((m2, 2 * p.total), (self.n_u, n_u_global)),
                                  csr=(g_local.indptr.astype(PETSc.IntType),
                                       g_local.indices.astype(PETSc.IntType), g_local.data), comm=comm)
        G.assemble()
        Gt = G.transpose()
        ki, kj, kv = K.getValuesCSR()
        ti, tj, tv = Gt.getValuesCSR()
        k_rows = np.repeat(np.arange(self.n_u), np.diff(ki))
        t_rows = np.repeat(np.arange(self.n_u), np.diff(ti))
        lam_g = 2 * p.offset + np.arange(m2)
        k = np.arange(len(p))
        diag_rows = np.concatenate([2 * k, 2 * k + 1, 2 * k + 1])
        diag_cols = np.concatenate([lam_g[2 * k], lam_g[2 * k + 1], lam_g[2 * k]])
        rows = np.concatenate([k_rows, t_rows, self.n_u + g_rows, self.n_u + diag_rows])
        cols = np.concatenate([self.comb_u(kj.astype(np.int64)), self.comb_lam(tj.astype(np.int64)),
                               self.comb_u(g_cols), self.comb_lam(diag_cols)])
        if self.material is not None and not _same_pattern(K, self.material.K):
            raise RuntimeError("the fill's tangent matrix does not have the sparsity of the elastic K")
        self._const = np.concatenate([kv, -tv])
        self._n_k, self._k_elastic, self._K = len(kv), kv.copy(), K
        self._u_work, self._ku = K.createVecRight(), K.createVecLeft()
        self._g_rows, self._g_vals = g_rows, g_vals
        slots = sp.csr_matrix((np.arange(1, len(rows) + 1, dtype=float), (rows, cols)), shape=(self.n_local, self.N))
        slots.sort_indices()
        self._perm = slots.data.astype(np.int64) - 1
        self._indptr = slots.indptr.astype(PETSc.IntType)
        self._indices = slots.indices.astype(PETSc.IntType)
        values = self._values(self.law.bonded(len(p)))
        self.A = PETSc.Mat().createAIJ(size=((self.n_local, self.N), (self.n_local, self.N)),
                                       csr=(self._indptr, self._indices, values), comm=comm)
        self.A.assemble()
        self._G = PETSc.Mat().createAIJ(size=((m2, 2 * p.total), (self.n_local, self.N)),
                                        csr=(g_local.indptr.astype(PETSc.IntType),
                                             self.comb_u(g_local.indices.astype(np.int64)).astype(PETSc.IntType),
                                             g_local.data), comm=comm)
        self._G.assemble()
        self.b = self.A.createVecLeft()
        self.r = self.A.createVecLeft()
        self.d = self._G.createVecLeft()
        self._lam = self._G.createVecLeft()
        self._mode = self.A.createVecRight()
        G.destroy()
        Gt.destroy()

    def _values(self, active: ContactState, proximal: bool = False) -> np.ndarray:
        """Matrix values (CSR order) of the linear system of an active set (with the proximal term:
        :meth:`_proximal_rows`)."""
        return np.concatenate([self._const, self._law_entries(active, proximal)])[self._perm]

    def _law_values(self, active: ContactState, proximal: bool = False) -> np.ndarray:
        """The law rows' part of :meth:`_values` (the rows after the displacements', CSR order): all the law's
        entries, none of the stiffness'."""
        law = self._perm[self._indptr[self.n_u]:] - len(self._const)
        return self._law_entries(active, proximal)[law]

    def _law_entries(self, active: ContactState, proximal: bool) -> np.ndarray:
        """The law's entries of the combined matrix, in the order :meth:`_build` gave them (G's rows, then the
        diagonal blocks)."""
        rows = self._proximal_rows(active) if proximal else self.law.rows(active)
        pair = self._g_rows // 2
        law_active = np.where(self._g_rows % 2 == 0, rows.a_n[pair], rows.a_t[pair])
        g_part = self._g_vals * self.law.c[pair] * law_active
        return np.concatenate([g_part, rows.b_n, rows.b_t, rows.e_t])

    def _ksp(self, options: dict) -> None:
        condensation = None if self.material is not None else \
            InteriorCondensation.of(self.A, np.arange(self.n_u, self.n_local))
        self._law_rows = (self.starts[self.comm.rank] + np.arange(self.n_u, self.n_local)).astype(PETSc.IntType)
        self.linear = CheckedSolve(self.A, options, condensation)
        self.stats, self.petsc_options = self.linear.stats, self.linear.options
        self._matrix_key = self.law.bonded(len(self.pairs)).key() + bytes([False])

    def vector(self) -> PETSc.Vec:
        """A new combined vector [u; lam] (zero)."""
        return self.A.createVecRight()

    def law_changed(self) -> None:
        """The joint law's constants (mu, c) changed: the next solve assembles and factorises the matrix again."""
        self._matrix_key = None

    @property
    def stiffness(self) -> PETSc.Mat:
        """The assembled elastic stiffness K (owned rows, N/m)."""
        return self._K

    @property
    def ground(self) -> np.ndarray:
        """The ground offsets of the local pairs' relative displacements (m, 2; m) at the imposed support
        movement."""
        return self._ground

    def set_support_movement(self, fraction: float) -> None:
        """Impose ``fraction`` of the support movement (offsets ``support_motion``, m per pair) from now on."""
        self.movement = fraction
        self._ground = fraction * self.support_motion

    # ----------------------------------------------------------------- right-hand side
    def loads(self, level: float) -> np.ndarray:
        """The applied nodal forces (owned, N) at live-load level ``level``: self-weight plus ``level`` x live load,
        and the clamp's forces (:meth:`clamp`; none by default)."""
        return self.f_dead.array + level * self.f_live.array + self._clamp

    def clamp(self, tension: np.ndarray | None) -> None:
        """Press the faces of each local pair together with the normal force ``tension`` (N, >= 0; None: none) from
        now on: the loads gain -G^T t, t = (T, 0) per pair (module docstring). Collective."""
        if tension is None:
            self._clamp = 0.0
            return
        self._lam.array[:] = 0.0
        self._lam.array[0::2] = tension
        self._G.multTranspose(self._lam, self.r)
        self._clamp = -self.r.array[:self.n_u].copy()

    def _rhs(self, level: float, active: ContactState, slip_ref: np.ndarray, near: PETSc.Vec | None = None) -> None:
        """The right-hand side of an active set's system; with ``near``, the proximal term's anchor
        (:meth:`_proximal_rows`)."""
        b = self.b.array
        b[:self.n_u] = self.loads(level) + self._correction
        lam_rhs = np.zeros(self.n_lam)
        lam_rhs[0::2], lam_rhs[1::2] = self.law.rhs(active, slip_ref, self._ground)
        if near is not None:
            rows, plain = self._proximal_rows(active), self.law.rows(active)
            _, _, d = self.split(near)
            lam_rhs[0::2] += (rows.a_n - plain.a_n) * self.law.c * (d[:, 0] - self._ground[:, 0])
            lam_rhs[1::2] += (rows.a_t - plain.a_t) * self.law.c * (d[:, 1] - self._ground[:, 1])
        b[self.n_u:] = lam_rhs

    def _proximal_rows(self, active: ContactState) -> LawRows:
        """The joint law's rows of an active set with a proximal term (module docstring): a spring of
        ``PROXIMAL`` times the Alart-Curnier constant c against each free direction's relative displacement from
        the anchor x_k (open pairs: lam + k (d - d_k) = 0 in both directions; sliding pairs:
        lam_t - s mu lam_n + k (d_t - d_t,k) = 0), the rows of the law itself elsewhere."""
        rows = self.law.rows(active)
        free_n, free_t = self.law.free_directions(active)
        return rows._replace(a_n=rows.a_n + PROXIMAL * free_n, a_t=rows.a_t + PROXIMAL * free_t)

    # ----------------------------------------------------------------- the fill's linearisation
    def linearise(self, x: PETSc.Vec, plastic_strain: np.ndarray, elastic: bool = False,
                  response: "FillResponse | None" = None) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate the fill at the displacements of x (or take its ``response`` there, already evaluated): the
        tangent (the elastic K if ``elastic``) goes into the system matrix and K_t u - f_int into the right-hand
        side. Returns the internal force (owned, N) and the trial plastic strain."""
        if response is None:
            response = self.material.evaluate(x.array[:self.n_u], plastic_strain, tangent=not elastic)
        elif not elastic:
            response = self.material.linearise(response)
        if elastic:
            self._u_work.array[:] = x.array[:self.n_u]
            self._K.mult(self._u_work, self._ku)
            self._const[:self._n_k] = self._k_elastic
            self._correction = self._ku.array - response.f_int
        else:
            self._const[:self._n_k] = response.tangent_values
            self._correction = response.correction
        self._matrix_key = None
        return response.f_int, response.plastic_strain

    # ----------------------------------------------------------------- solves
    def solve_set(self, level: float, active: ContactState, slip_ref: np.ndarray, x: PETSc.Vec,
                  near: PETSc.Vec | None = None) -> SolveFailure | None:
        """Solve the system of ``active`` under the loads at live-load level ``level`` (N per unit load factor) into
        x, the slips of sticking pairs held at ``slip_ref`` (m); with ``near``, its proximal system anchored there.
        Returns None or the failure. Collective."""
        self._rhs(level, active, slip_ref, near)
        return self._solve(active, x, near is not None)

    def _solve(self, active: ContactState, x: PETSc.Vec, proximal: bool = False) -> SolveFailure | None:
        """Solve the system of an active set (``proximal``: with the proximal term) with the right-hand side in
        ``self.b`` (refactorising only when the system or the fill's tangent changed); returns None or the
        failure."""
        key = active.key() + bytes([proximal])
        if self.comm.allreduce(int(key != self._matrix_key), op=MPI.MAX):  # a new active set, or a new fill tangent
            if self.linear.condensation is None:
                self.A.setValuesCSR(self._indptr, self._indices, self._values(active, proximal))
                self.A.assemble()
                self.linear.matrix_changed()
            else:  # only the law's rows change
                law = self._law_values(active, proximal)
                self.A.setValuesIJV(self._indptr[self.n_u:] - self._indptr[self.n_u],
                                    self._indices[self._indptr[self.n_u]:], law, rowmap=self._law_rows)
                self.A.assemble()
                self.linear.matrix_changed(law)
            self._matrix_key = key
        failure = self.linear.solve(self.b, x)
        if failure is not None:
            self._matrix_key = None  # a failed factorisation is never reused: the next solve refactorises
        return failure

    def refinement(self, x: PETSc.Vec) -> "PETSc.Vec | SolveFailure":
        """One step of iterative refinement of the last solve's x with the same factorisation
        (:meth:`bridgefem.solver.linear.CheckedSolve.correction`): the correction, or the failure."""
        return self.linear.correction(self.b, x)

    def live_load_tangent(self, active: ContactState) -> PETSc.Vec | None:
        """The response dx (m and N per N of live load) to a unit increment of the live-load level with ``active``
        held (open pairs open, closed pairs keep their gap, stick pairs their slip, slip pairs their friction law),
        with the matrix as it stands (with a plastic fill, the fill's tangent of the last :meth:`linearise`). One
        solve; None when it fails. Collective."""
        self.b.array[:self.n_u] = self.f_live.array
        self.b.array[self.n_u:] = 0.0
        dx = self.vector()
        if self._solve(active, dx) is not None:
            return None
        return dx

    def active_set_displacements(self, level: float, active: ContactState, slip_ref: np.ndarray
                                 ) -> np.ndarray | None:
        """The relative displacements (m) of ``active``'s solution under the loads at ``level``, or None
        (:class:`bridgefem.solver.cycles.PairSolves`). Collective."""
        if self.solve_set(level, active, slip_ref, self._mode) is not None:
            return None
        return self.split(self._mode)[2]

    def unit_force_displacements(self, active: ContactState, row: int | None) -> np.ndarray | None:
        """The relative displacements (m per N) of ``active``'s solution under a unit force alone at local law row
        ``row``, or None (:class:`bridgefem.solver.cycles.PairSolves`). Collective."""
        self.b.array[:] = 0.0
        if row is not None:
            self.b.array[self.n_u + row] = 1.0
        if self._solve(active, self._mode) is not None:
            return None
        return self.split(self._mode)[2] - self._ground

    def unit_force_error(self) -> np.ndarray | None:
        """The estimated error (m per N) of the relative displacements of the last :meth:`unit_force_displacements`,
        or None (:class:`bridgefem.solver.cycles.PairSolves`). Collective."""
        correction = self.refinement(self._mode)
        if not isinstance(correction, PETSc.Vec):
            self._matrix_key = None  # a failed factorisation is never reused
            return None
        return self.split(correction)[2] - self._ground

    # ----------------------------------------------------------------- evaluations
    def split(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local owned u, lam (m, 2) and relative displacements d (m, 2) of an iterate vector."""
        self._G.mult(x, self.d)
        return x.array[:self.n_u], x.array[self.n_u:].reshape(-1, 2), self.d.array.reshape(-1, 2) + self._ground

    def mode(self, x: PETSc.Vec, origin: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """The displacements u (owned, m) and relative displacements d (local pairs, (m, 2), m) of the motion
        x - origin; d without the ground offset (the support movement is in both states)."""
        mode = self._mode
        x.copy(mode)
        mode.axpy(-1.0, origin)
        _, _, d = self.split(mode)
        return mode.array[:self.n_u], d - self._ground

    def norm_inf(self, a: np.ndarray) -> float:
        """The largest entry of a distributed array (each rank's share ``a``), over all ranks."""
        return float(self.comm.allreduce(np.abs(a).max() if a.size else 0.0, op=MPI.MAX))

    def out_of_balance(self, x: PETSc.Vec, f_int: np.ndarray, level: float) -> np.ndarray:
        """Out-of-balance force f + G^T lam - f_int(u) (owned, N) with the fill's internal force ``f_int``."""
        self._lam.array[:] = x.array[self.n_u:]
        self._G.multTranspose(self._lam, self.r)
        return self.loads(level) + self.r.array[:self.n_u] - f_int

    def elastic_out_of_balance(self, x: PETSc.Vec) -> np.ndarray:
        """Out-of-balance force of the assembled linear system's equilibrium rows at x, b - A x (owned, N)."""
        self.A.mult(x, self.r)
        return self.b.array[:self.n_u] - self.r.array[:self.n_u]

    def equilibrium_residual(self, x: PETSc.Vec, f_scale: float) -> float:
        """Scaled out-of-balance force |b - A x|_inf / f_scale of the equilibrium rows (``f_scale``: N)."""
        return self.norm_inf(self.elastic_out_of_balance(x)) / f_scale

    def material_residual(self, x: PETSc.Vec, f_int: np.ndarray, level: float, f_scale: float) -> float:
        """Scaled out-of-balance force |f + G^T lam - f_int(u)|_inf / f_scale with the fill's true stresses."""
        return self.norm_inf(self.out_of_balance(x, f_int, level)) / f_scale


def g_entries(p: JointPairs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Entries of the relative displacement operator G for the local pairs ``p``: (row in 0..2m-1: 2 k normal,
    2 k + 1 tangential of local pair k; global u dof; value)."""
    k = np.arange(len(p))
    rows, cols, vals = [], [], []
    for node, sign in ((p.right, 1.0), (p.left, -1.0)):
        has = node != GROUND
        for comp in (0, 1):
            for kind, vec in ((0, p.normal), (1, p.tangent)):
                rows.append(2 * k[has] + kind)
                cols.append(2 * node[has] + comp)
                vals.append(sign * vec[has, comp])
    return np.concatenate(rows), np.concatenate(cols).astype(np.int64), np.concatenate(vals)


def _same_pattern(a: PETSc.Mat, b: PETSc.Mat) -> bool:
    (ia, ja, _), (ib, jb, _) = a.getValuesCSR(), b.getValuesCSR()
    return bool(a.getComm().tompi4py().allreduce(int(np.array_equal(ia, ib) and np.array_equal(ja, jb)),
                                                  op=MPI.MIN))
