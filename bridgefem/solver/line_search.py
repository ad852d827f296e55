"""The line search of a Newton step (step 4 of :mod:`bridgefem.solver.newton`): always with a plastic fill, a retry's
setting for a ring.

The solution x of an active set's linear system is backtracked from the linearisation point x_k: x becomes
x_k + a (x - x_k), displacements and joint forces alike, for the first a = 1, 1/2, ... (at most
``LINE_SEARCH_HALVINGS`` halvings) whose merit is at most (1 - ``ARMIJO`` a) times the merit at x_k (Armijo's rule),
and stays the full step when none is. The merit is the Euclidean norm of the whole residual of the convergence test
scaled by the largest applied nodal force: the out-of-balance force (with a plastic fill, the fill's return map at the
trial displacements) and the joint law's residual (both in N), the law waived at frozen pairs' friction. Along a
Newton direction it decreases like 1 - a to first order: the natural merit of a semismooth Newton method (Facchinei
& Pang 2003, *Finite-Dimensional Variational Inequalities and Complementarity Problems*, ch. 8). The Euclidean norm
weighs a yielding fill's worst node against the rest of the residual, where the largest entry would refuse every
step that moves the yielding zone.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from petsc4py import PETSc

from ..laws.base import JointLaw
from .system import ContactSystem

if TYPE_CHECKING:
    from ..fe.fill import FillResponse, PlasticFill

LINE_SEARCH_HALVINGS = 5  # a Newton step is halved at most this many times by the line search
ARMIJO = 1e-4  # sufficient decrease of the line search's merit, per unit step length


class LineSearch:
    """The line search on the system ``system`` with the joint law ``law`` and the fill ``material`` (None: none;
    module docstring). Collective."""

    def __init__(self, system: ContactSystem, law: JointLaw, material: "PlasticFill | None"):
        self.system, self.law, self.material = system, law, material
        self._full, self._step = system.vector(), system.vector()  # the full step's iterate and direction

    def merit(self, level: float, x: PETSc.Vec, plastic_strain: np.ndarray, slip_ref: np.ndarray,
              frozen: np.ndarray, f_scale: float) -> "tuple[float, FillResponse | None]":
        """The merit at x: the Euclidean norm of the out-of-balance force f + G^T lam - f_int(u) (the fill's return
        map at the displacements of x, from the step's converged ``plastic_strain``; without a plastic fill
        f + G^T lam - K u) and of the joint law's residual (its friction waived at ``frozen`` pairs), scaled by
        ``f_scale``; and the fill's response at x (no tangent; None without a plastic fill). Collective."""
        system = self.system
        _, lam, d = system.split(x)
        ncp = self.law.residual(lam, d, slip_ref)
        ncp[frozen, 1] = 0.0
        if self.material is None:
            out, response = system.elastic_out_of_balance(x), None
        else:
            response = self.material.evaluate(x.array[:system.n_u], plastic_strain, tangent=False)
            out = system.out_of_balance(x, response.f_int, level)
        squares = system.comm.allreduce(float(out @ out) + float(np.sum(ncp * ncp)))
        return np.sqrt(squares) / f_scale, response

    def search(self, level: float, x: PETSc.Vec, anchor: PETSc.Vec, merit: float, plastic_strain: np.ndarray,
               slip_ref: np.ndarray, frozen: np.ndarray, f_scale: float) -> "tuple[float, FillResponse | None]":
        """Backtrack the Newton step from ``anchor`` (the linearisation point, merit ``merit``) to the solution in
        x (module docstring). Returns the merit and the fill's response at the new x (linearised there next).
        Collective."""
        x.copy(self._full)
        self._step.waxpy(-1.0, anchor, x)
        a = 1.0
        value, response = full = self.merit(level, x, plastic_strain, slip_ref, frozen, f_scale)
        while value > (1.0 - ARMIJO * a) * merit and a > 0.5 ** LINE_SEARCH_HALVINGS:
            a *= 0.5
            anchor.copy(x)
            x.axpy(a, self._step)
            value, response = self.merit(level, x, plastic_strain, slip_ref, frozen, f_scale)
        if value > (1.0 - ARMIJO * a) * merit:
            self._full.copy(x)
            return full
        return value, response
