"""A predicted state for a load step: the FE's own load step with Tresca friction, solved as convex QPs.

For fixed shear capacities g (N per pair) the load step of :mod:`bridgefem.solver.newton` (elastic voussoirs, unilateral
contact at the joint pairs, friction incremental from the converged start's tangential displacements d_t,ref) is
the Tresca problem, a convex QP in the displacements u (m) (Kikuchi & Oden 1988, *Contact problems in elasticity*,
ch. 10: minimum potential energy with the friction dissipation):

    min_u  1/2 u^T K u - f(level)^T u + sum_k g_k |G_t u + o_t - d_t,ref|_k
    s.t.   G_n u + o_n >= 0                                         (no interpenetration; d_n >= 0 is opening)

with G the relative displacement operator and o the ground offsets (:mod:`bridgefem.solver.system`). Its multipliers are
the joint forces of the solver's convention, ``K u = f + G_n^T lam_n + G_t^T lam_t``: lam_n >= 0 (N, compression) on the
contact rows and lam_t = -g sign(slip) where a pair slides, |lam_t| <= g where it sticks (open or closed: a pair's
cohesion is shear it carries open). The Coulomb law is the fixed point g = mu lam_n + k (mu: the joint law's
coefficients, k its cohesion: :meth:`bridgefem.laws.base.JointLaw.shear_capacity`; the Tresca fixed point of
:mod:`bridgefem.limit.rigid_block`; slip without dilatancy, the FE's non-associative law): from the capacities at the
start's normal forces, each QP's normal forces give the next capacities, until they settle (largest change below
``SETTLED`` of the largest, within ``TRESCA_QPS`` QPs). A settled fixed point is an equilibrium of the FE's own laws up
to the QP's tolerance; the solver's *Predictor* classifies it against the start
(:meth:`bridgefem.solver.newton.ContactSolver.solve_step`) and the Newton iteration verifies it. A prediction changes
only the iteration's path, never what counts as converged. When and how the search uses it:
:mod:`bridgefem.search.pathfollow`, *Predictor*.

Why: on rings of slice-like voussoirs the Newton iteration moves openings between neighbouring joints and fails
trials whose state the later, smaller steps reach; on hinge collapses the fixed point settles in a few QPs and the
trial converges from it in one to three iterations. Where the collapse slides it settles less often, and an
unsettled fixed point is no prediction (no solve); measured: ``docs/robustness.md``. So
:mod:`bridgefem.analysis.runner` builds the predictor for every bare ring. K and G are gathered on rank 0 once,
each QP runs there (Clarabel) and the state is scattered: collective.
"""
from __future__ import annotations

from typing import NamedTuple

import clarabel
import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from ..laws.base import JointLaw
from ..limit.conic import clarabel_solve
from .newton import ContactSolver, Iterate
from .system import g_entries

TRESCA_QPS = 8  # QPs of the fixed point per prediction
SETTLED = 1e-3  # the normal forces settled: largest change below this fraction of the largest normal force
CAPACITY_FLOOR = 1e-6  # least capacity per pair, of the largest applied nodal force: keeps each QP's slack bounded


class TrescaStep(NamedTuple):
    """A Tresca QP's solution: displacements u (m), normal and tangential joint forces (N)."""

    u: np.ndarray
    lam_n: np.ndarray
    lam_t: np.ndarray


class TrescaProblem:
    """The Tresca QP of the module docstring for a stiffness K (n, n; N/m) and the relative displacement operator G
    (2m, n; rows 2k normal, 2k + 1 tangential of pair k), built once: variables [u, s] with s >= |slip| per pair,
    the quadratic form scaled by K's largest diagonal entry k."""

    def __init__(self, K: sp.spmatrix, G: sp.spmatrix):
        n, m = K.shape[0], G.shape[0] // 2
        self.n, self.m = n, m
        self.stiffness = float(np.abs(K.diagonal()).max())
        Gn, Gt, eye, zero = G[0::2], G[1::2], sp.identity(m, format="csr"), sp.csr_matrix((m, m))
        self.P = sp.block_diag([sp.triu(K / self.stiffness), zero]).tocsc()
        self.A = sp.vstack([sp.hstack([-Gn, zero]), sp.hstack([Gt, -eye]), sp.hstack([-Gt, -eye])]).tocsc()

    def step(self, f: np.ndarray, offset: np.ndarray, slip_ref: np.ndarray, capacity: np.ndarray
             ) -> TrescaStep | None:
        """The QP for the loads f (N), the ground offsets (m, 2; m) and the start's tangential displacements
        ``slip_ref`` (m), the capacities g (N per pair); forces scaled by the largest load F, displacements by
        F / k. None when Clarabel did not solve it (or raised)."""
        n, m = self.n, self.m
        force = max(float(np.abs(f).max()), 1e-300)
        unit = force / self.stiffness  # m
        q = np.concatenate([-f / force, np.maximum(capacity / force, CAPACITY_FLOOR)])
        reference = (slip_ref - offset[:, 1]) / unit
        b = np.concatenate([offset[:, 0] / unit, reference, -reference])
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        sol, _ = clarabel_solve(self.P, q, self.A, b, [clarabel.NonnegativeConeT(3 * m)], settings)
        if sol is None or str(sol.status) != "Solved":
            return None
        z = np.asarray(sol.z)
        return TrescaStep(np.asarray(sol.x)[:n] * unit, z[:m] * force, (z[2 * m:] - z[m:2 * m]) * force)

    def coulomb_fixed_point(self, f: np.ndarray, offset: np.ndarray, slip_ref: np.ndarray, law: JointLaw,
                            normal: np.ndarray) -> TrescaStep | None:
        """The Tresca fixed point g = the ``law``'s shear capacity at lam_n (:meth:`JointLaw.shear_capacity`, the law
        at every pair) from the normal forces ``normal`` (N per pair): the last QP's solution once its normal forces
        settled, None when a QP was not solved or they did not settle."""
        previous = np.maximum(normal, 0.0)
        for _ in range(TRESCA_QPS):
            step = self.step(f, offset, slip_ref, law.shear_capacity(previous))
            if step is None:
                return None
            lam_n = np.maximum(step.lam_n, 0.0)
            if np.abs(lam_n - previous).max() <= SETTLED * max(lam_n.max(), 1e-300):
                return step
            previous = lam_n
        return None


class GatheredOperators:
    """The assembled stiffness K and relative displacement operator G of a
    :class:`bridgefem.solver.newton.ContactSolver`, gathered on rank 0 for a predictor that solves there, and the
    states it predicts scattered back. Collective."""

    def __init__(self, solver: ContactSolver):
        self.solver, self.system, self.comm = solver, solver.system, solver.comm
        self.sizes = self.comm.allgather((self.system.n_u, len(solver.pairs)))

    def operators(self) -> tuple[sp.csr_matrix, sp.csr_matrix] | tuple[None, None]:
        """K (N/m) and G on rank 0, (None, None) elsewhere. Collective."""
        system = self.system
        ki, kj, kv = system.stiffness.getValuesCSR()
        n_global = system.stiffness.getSize()[0]
        rows, cols, vals = g_entries(self.solver.pairs)
        K = sp.csr_matrix((kv, kj, ki), shape=(system.n_u, n_global))
        G = sp.csr_matrix((vals, (rows, cols)), shape=(2 * len(self.solver.pairs), n_global))
        blocks = self.comm.gather((K, G), root=0)
        if self.comm.rank != 0:
            return None, None
        return sp.vstack([b[0] for b in blocks]).tocsr(), sp.vstack([b[1] for b in blocks]).tocsr()

    def gathered(self, local: np.ndarray) -> np.ndarray | None:
        """The owned entries of every rank on rank 0, in rank order (None elsewhere). Collective."""
        parts = self.comm.gather(local, root=0)
        return np.concatenate(parts) if parts is not None else None

    def scattered(self, u: np.ndarray | None, forces: np.ndarray | None) -> PETSc.Vec:
        """The combined vector [u; lam] of rank 0's displacements u (m) and joint forces (N, (m, 2)), each rank's
        share. Collective."""
        shares = None
        if self.comm.rank == 0:
            u_cuts = np.cumsum([s[0] for s in self.sizes])[:-1]
            pair_cuts = np.cumsum([s[1] for s in self.sizes])[:-1]
            shares = list(zip(np.split(u, u_cuts), np.split(forces, pair_cuts)))
        u, forces = self.comm.scatter(shares, root=0)
        system = self.system
        x = system.vector()
        x.array[:system.n_u] = u
        x.array[system.n_u:] = forces.ravel()
        return x


class TrescaPredictor(GatheredOperators):
    """Predicted states for the load steps of a ring's :class:`bridgefem.solver.newton.ContactSolver` (no plastic fill):
    K and G gathered on rank 0 once, at the first prediction (most searches ask for none). Collective."""

    def __init__(self, solver: ContactSolver):
        super().__init__(solver)
        self.problem: TrescaProblem | None = None  # on rank 0, once gathered
        self.built = False  # K and G gathered (the same on every rank)

    def _problem(self) -> TrescaProblem | None:
        """The Tresca QP of the assembled K and G on rank 0 (None elsewhere), gathered at the first call.
        Collective."""
        if not self.built:
            self.built = True
            K, G = self.operators()
            if self.comm.rank == 0:
                self.problem = TrescaProblem(K, G)
        return self.problem

    def predict(self, level: float, start: Iterate) -> PETSc.Vec | None:
        """The combined vector [u; lam] of the Coulomb fixed point at live-load level ``level`` (N per unit load
        factor) from the converged ``start``; None when it did not settle. Collective."""
        system, solver = self.system, self.solver
        _, lam, _ = system.split(start.x)
        gathered = [self.gathered(a) for a in (system.loads(level), lam[:, 0], start.slip_ref, system.ground)]
        law = solver.law.gathered(np.ones(len(solver.pairs), dtype=bool), self.comm)
        problem, step = self._problem(), None
        if self.comm.rank == 0:
            f, normal, slip_ref, offset = gathered
            step = problem.coulomb_fixed_point(f, offset, slip_ref, law, normal)
        if not self.comm.bcast(step is not None, root=0):
            return None
        return self.scattered(step.u if step is not None else None,
                              np.column_stack([step.lam_n, step.lam_t]) if step is not None else None)
