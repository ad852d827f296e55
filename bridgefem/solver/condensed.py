"""Predicted states from the joint problem condensed onto the joint forces, block by block: the Tresca fixed point
on convex QPs in forces.

Without a fill every block (voussoir, abutment, pier course) is an elastic body of its own: the stiffness K (N/m) is
block-diagonal, the blocks touching only through the joint pairs. With K_b^- a generalised inverse of block b's
stiffness and R_b its rigid-body modes (K_b R_b = 0), every displacement in equilibrium with joint forces lam (N) is

    u = K^- (f + G^T lam) + R alpha,     provided  R^T (f + G^T lam) = 0   (each free block in equilibrium)

so the relative displacements d = G u + o are affine in (lam, alpha): d = F lam + e + G R alpha, with the compliance
F = G K^- G^T (m/N; symmetric positive semidefinite, one small dense block per pair of faces of a block) and
e = G K^- f + o (o: the ground offsets, minus the start's tangential displacements d_t,ref). The load step of
:mod:`bridgefem.solver.newton` with Tresca friction (shear capacities g, N per pair) is then the dual of the QP of
:mod:`bridgefem.solver.tresca`, a convex QP in the forces (Kikuchi & Oden 1988, ch. 10; the dual of a FETI
decomposition, Farhat & Roux 1991, with the joints as its interfaces):

    min_lam  1/2 lam^T F lam + e^T lam
    s.t.     R^T G^T lam = -R^T f,   lam_n >= 0,   |lam_t| <= g                       (Tresca)
    or       |lam_t| <= mu lam_n + k instead of |lam_t| <= g                           (associative Coulomb)

whose equality multipliers are the blocks' rigid motions alpha. In forces the problem is scaled by the loads and
the compliance alone, so an interior-point method resolves the joints' slips to the precision the Newton method's
test asks for, where the QP in displacements (:mod:`bridgefem.solver.tresca`) cannot on thin rings whose slips span
many orders of magnitude (``docs/robustness.md``, *Rings*).

:meth:`BlockCompliance.coulomb_states`, the Coulomb fixed point (non-associative: slip without dilatancy):

1. the associative problem, feasible whenever statically admissible forces exist (the associative rigid-block LP's
   finding): its normal forces are the first estimate n;
2. the Tresca problem with g = the law's shear capacity at n (:meth:`bridgefem.laws.base.JointLaw.shear_capacity`);
   its solution is yielded as a predicted state;
3. n becomes the first Tresca solution's normal forces, then moves ``RELAXATION`` of the way to each later one's
   (under-relaxed: the undamped iteration alternates between two states on barrels of rings); a Tresca problem
   without a feasible point (capacities from normal forces that no admissible field has) halves that step from the
   last n that had one, down to ``LEAST_RELAXATION``; go to 2, at most ``CONDENSED_QPS`` times.

The caller verifies each yielded state with the Newton method (:mod:`bridgefem.search.selfweight`); a prediction
changes only the iteration's path, never what counts as converged. The blocks' generalised inverses are dense
(eigen-decompositions of each block's stiffness): at most ``DENSE_BYTES`` in all, else no condensation.
"""
from __future__ import annotations

from typing import Iterator

import clarabel
import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc
from scipy.sparse.csgraph import connected_components

from ..laws.base import JointLaw
from ..limit.conic import clarabel_solve
from .newton import ContactSolver, Iterate
from .tresca import GatheredOperators

CONDENSED_QPS = 40  # Tresca QPs of the fixed point at most
RELAXATION = 0.5  # the normal forces move this fraction of the way to each Tresca solution's
LEAST_RELAXATION = 1.0 / 16.0  # an infeasible Tresca QP halves the step down to this fraction, then the point ends
RIGID_RTOL = 1e-9  # a block's eigenvalue below this fraction of its largest is a rigid-body mode
DENSE_BYTES = 1e9  # the blocks' dense generalised inverses at most this many bytes in all
QP_TOL = 1e-10  # Clarabel's feasibility and gap tolerances (the problem scaled to forces and compliances of order 1)
SOLVED = ("Solved", "AlmostSolved")


class BlockCompliance:
    """The condensed joint problem of the module docstring for a block-diagonal stiffness K (n, n; N/m) and the
    relative displacement operator G (2m, n; rows 2k normal, 2k + 1 tangential of pair k), built once (on one
    process): :meth:`of` returns None when K is not block-diagonal in blocks small enough."""

    def __init__(self, inverse: sp.csr_matrix, modes: np.ndarray, G: sp.csr_matrix):
        self.inverse, self.modes, self.G, self.m = inverse, modes, G, G.shape[0] // 2
        F = (G @ inverse @ G.T).tocsc()
        self.F = 0.5 * (F + F.T)
        self.compliance = float(np.abs(self.F.diagonal()).max()) or 1.0  # m/N, the scale of F
        self.B = sp.csr_matrix((G @ modes).T)  # R^T G^T: each free block's equilibrium under the joint forces

    @classmethod
    def of(cls, K: sp.spmatrix, G: sp.spmatrix) -> "BlockCompliance | None":
        """The blocks of K (its connected components), each one's generalised inverse and rigid-body modes (from its
        eigen-decomposition); None when the dense inverses would exceed ``DENSE_BYTES``."""
        K, n = sp.csr_matrix(K), K.shape[0]
        count, label = connected_components(K, directed=False)
        dofs = [np.flatnonzero(label == b) for b in range(count)]
        if sum(len(d) ** 2 for d in dofs) * 8 > DENSE_BYTES:
            return None
        inverses, modes = [], []
        for d in dofs:
            w, V = np.linalg.eigh(K[d][:, d].toarray())
            rigid = w <= RIGID_RTOL * max(w.max(), 0.0)
            inverses.append((V[:, ~rigid] / w[~rigid]) @ V[:, ~rigid].T)
            for j in np.flatnonzero(rigid):
                mode = np.zeros(n)
                mode[d] = V[:, j]
                modes.append(mode)
        order = np.concatenate(dofs)
        permute = sp.csr_matrix((np.ones(n), (order, np.arange(n))), shape=(n, n))
        inverse = (permute @ sp.block_diag(inverses, format="csr") @ permute.T).tocsr()
        return cls(inverse, np.array(modes).T if modes else np.zeros((n, 0)), sp.csr_matrix(G))

    def solve(self, f: np.ndarray, offset: np.ndarray, capacity: np.ndarray, mu: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray] | None:
        """The QP of the module docstring for the loads f (N), offsets o (m, (m, 2): normal; tangential minus the
        start's) and the capacities (N per pair): Tresca when ``mu`` is None, else associative Coulomb with
        cohesion ``capacity``. Returns the displacements u (m) and the joint forces lam (N, (m, 2)), or None when
        Clarabel finds no solution (an infeasible problem: no admissible forces)."""
        m, force = self.m, max(float(np.abs(f).max()), 1e-300)
        scale = self.compliance  # forces in units of the largest load (y = lam / force), the objective divided by
        # force^2 x compliance: 1/2 y^T (F / scale) y + (e / (scale force))^T y
        normal = sp.csr_matrix((np.ones(m), (np.arange(m), 2 * np.arange(m))), shape=(m, 2 * m))
        shear = sp.csr_matrix((np.ones(m), (np.arange(m), 2 * np.arange(m) + 1)), shape=(m, 2 * m))
        cone = sp.diags(mu) @ normal if mu is not None else sp.csr_matrix((m, 2 * m))
        A = sp.vstack([self.B, -normal, shear - cone, -shear - cone]).tocsc()
        e = self.G @ (self.inverse @ f) + offset.ravel()
        b = np.concatenate([-(self.modes.T @ f) / force, np.zeros(m), capacity / force, capacity / force])
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = QP_TOL
        sol, _ = clarabel_solve(sp.triu(self.F / scale).tocsc(), e / (scale * force), A, b,
                                [clarabel.ZeroConeT(self.B.shape[0]), clarabel.NonnegativeConeT(3 * m)], settings)
        if sol is None or str(sol.status) not in SOLVED:
            return None
        lam = np.asarray(sol.x) * force
        alpha = np.asarray(sol.z)[:self.B.shape[0]] * force * scale  # the rigid motions: d = F lam + e + G R alpha
        u = self.inverse @ (f + self.G.T @ lam) + self.modes @ alpha
        return u, lam.reshape(-1, 2)

    def coulomb_states(self, f: np.ndarray, offset: np.ndarray, law: JointLaw
                       ) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """The Tresca fixed point of the module docstring (steps 1-3) for the ``law`` at every pair: yields each
        Tresca solution (u, lam); ends when the associative problem or a Tresca problem at the least relaxation has
        no solution, or after ``CONDENSED_QPS`` QPs."""
        first = self.solve(f, offset, law.shear_capacity(np.zeros(self.m)), law.mu)
        if first is None:
            return
        normal, previous, target = first[1][:, 0], None, None
        step = 1.0  # the first Tresca solution's normal forces are taken whole, the later ones under-relaxed
        for _ in range(CONDENSED_QPS):
            state = self.solve(f, offset, law.shear_capacity(normal))
            if state is None:
                if previous is None or step <= LEAST_RELAXATION:
                    return
                step /= 2
                normal = previous + step * (target - previous)
                continue
            yield state
            previous, target = normal, state[1][:, 0]
            normal = previous + step * (target - previous)
            step = min(step, RELAXATION)


class CondensedPredictor(GatheredOperators):
    """Predicted states of a step of a :class:`bridgefem.solver.newton.ContactSolver` without a fill from the
    condensed Tresca fixed point (module docstring): K and G gathered on rank 0 at the first call, the QPs solved
    there, each state scattered. Collective."""

    def __init__(self, solver: ContactSolver):
        super().__init__(solver)
        self.blocks: BlockCompliance | None = None
        self.built = False

    def states(self, level: float, start: Iterate) -> Iterator[PETSc.Vec]:
        """The combined vectors [u; lam] of the fixed point at live-load level ``level`` (N per unit load factor)
        from the converged ``start``, one per Tresca QP; none when K has no blocks small enough. Collective: every
        rank iterates in step."""
        system, comm = self.system, self.comm
        if not self.built:
            self.built = True
            operators = self.operators()
            if comm.rank == 0:
                self.blocks = BlockCompliance.of(*operators)
        f, slip_ref, ground = (self.gathered(a) for a in (system.loads(level), start.slip_ref, system.ground))
        law = self.solver.law.gathered(np.ones(len(self.solver.pairs), dtype=bool), comm)
        points = None
        if comm.rank == 0 and self.blocks is not None:
            offset = ground.copy()
            offset[:, 1] -= slip_ref
            points = self.blocks.coulomb_states(f, offset, law)
        while True:
            state = next(points, None) if points is not None else None
            if not comm.bcast(state is not None, root=0):
                return
            yield self.scattered(*state if state is not None else (None, None))
