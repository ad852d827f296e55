"""Rigid blocks in contact at points: the frozen-capacity collapse of the FE's own blocks and joint pairs.

The FE's joints are pairs of nodes (:mod:`bridgefem.fe.pairs`): at each pair k a point p_k (m), a unit normal n_k
from its left face into its right one and a unit tangent t_k; its forces are the normal force lam_n >= 0 (N,
compression) and the shear lam_t (N), the force lam_n n_k + lam_t t_k acting on the right block at p_k and the
opposite on the left one (the solver's convention, K u = f + G^T lam). Read as rigid blocks touching at those
points, every block b balances its generalised loads (Fx, Fy in N, M in N·m counter-clockwise about its reference
point r_b) and the pair forces on it:

    A lam + level l = -d            (3 rows per block; the ground has none)

With every pair's shear capacity frozen at g_k (N: the joint law's at the FE's normal force there,
:meth:`bridgefem.laws.base.JointLaw.shear_capacity`) the collapse level of the blocks is the linear programme

    max level  s.t.  A lam + level l = -d,   lam_n >= 0,   |lam_t| <= g

(:func:`frozen_contact_collapse`). Its yield set is convex and fixed, so normality and the bound theorems hold for
it (Livesley 1978): every statically admissible state carries at most its level, and every optimal one does the
mechanism's dissipation (complementary slackness). The mechanism is the programme's dual: block velocities v (3 per
block, signed so that the live load does positive work on them), each pair's relative velocity A^T v (opening
rate, then slip rate along t_k). A pair *opens* where its opening rate is above ``MOTION_RTOL`` of the largest
rate, and *slides* where it stays in contact and its slip rate is above that (an opening pair carries no force: on
a curved ring interface the pairs beside a hinge open with a tangential rate too).

This is the frozen LP of evidence 3 (:mod:`bridgefem.analysis.evidence`) on the FE's own joint geometry: a converged
FE state's pair forces satisfy its rows exactly (the moment rows of a joint are its pairs' no-tension at their
points), wherever the joint lies, straight or along a curved ring interface, so its level is at least the FE
state's up to the solver's residual. Units: N, m, N·m; levels in N per unit load factor when l is the unit live
load.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

MOTION_RTOL = 1e-6  # a pair opens or slides in the mechanism where its rate exceeds this fraction of the largest


@dataclass(frozen=True)
class PointContacts:
    """Rigid blocks touching at points (module docstring); ``nb`` blocks, ``k`` pairs, ground = block -1.

    ref: (nb, 2) reference points (m); dead, live: (nb, 3) generalised loads about them (Fx, Fy in N, M in N·m),
    live for a unit level; point, normal, tangent: (k, 2) each pair's place (m) and unit vectors; left, right: (k,)
    the blocks of its left and right faces (-1: the ground)."""

    ref: np.ndarray
    dead: np.ndarray
    live: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    left: np.ndarray
    right: np.ndarray

    def equilibrium(self) -> sp.csr_matrix:
        """A (3 nb, 2 k): the generalised loads on the blocks of unit pair forces, columns 2k (normal) and 2k + 1
        (shear) of pair k, rows 3b .. 3b + 2 (Fx, Fy, M about r_b) of block b."""
        k, nb = len(self.point), len(self.ref)
        rows, cols, vals = [], [], []
        for side, sign in ((self.right, 1.0), (self.left, -1.0)):
            on = side >= 0
            b, arm = side[on], self.point[on] - self.ref[side[on]]
            for c, direction in ((0, self.normal[on]), (1, self.tangent[on])):
                force = sign * direction
                column = 2 * np.flatnonzero(on) + c
                moment = arm[:, 0] * force[:, 1] - arm[:, 1] * force[:, 0]
                for r, value in enumerate((force[:, 0], force[:, 1], moment)):
                    rows.append(3 * b + r)
                    cols.append(column)
                    vals.append(value)
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(3 * nb, 2 * k))


@dataclass(frozen=True)
class ContactCollapse:
    """The frozen-capacity collapse of :func:`frozen_contact_collapse`: ``level`` (same unit as the live load's
    factor; None without an optimum), the optimal pair forces ``forces`` (k, 2: normal, shear; N), the mechanism's
    ``opening`` pairs (bool, (k,)) and each pair's ``slip`` rate (k,; 0 where it does not slide) for block velocities
    on which the live load does unit work."""

    level: float | None
    forces: np.ndarray
    opening: np.ndarray
    slip: np.ndarray

    @property
    def sliding(self) -> np.ndarray:
        """(k,) bool: the pairs that slide in the mechanism."""
        return self.slip != 0

    def dissipation(self, capacity: np.ndarray) -> np.ndarray:
        """(k,) the friction dissipation g |slip| of each pair (N x rate), the optimum's shear work against the slip
        (complementary slackness: a sliding pair's optimal shear is g against it)."""
        return capacity * np.abs(self.slip)

    def shortfall(self, forces: np.ndarray, capacity: np.ndarray) -> np.ndarray:
        """(k,) how much less of each pair's dissipation the shears of ``forces`` (k, 2; N) do on the mechanism's
        slip than the optimum's: |slip| (g - lam_t sign(the optimum's shear)), 0 for a pair at its Coulomb limit
        against the slip, 2 g |slip| for one at its limit the other way."""
        return np.abs(self.slip) * (capacity - forces[:, 1] * np.sign(self.forces[:, 1]))


def frozen_contact_collapse(contacts: PointContacts, capacity: np.ndarray) -> ContactCollapse:
    """The collapse level of ``contacts`` with every pair's shear capacity frozen at ``capacity`` (N, (k,)): the
    programme of the module docstring, solved by HiGHS in forces divided by the largest dead or live load, its
    mechanism from the equality rows' duals. ``level`` None when the programme has no optimum (no admissible
    state, or no collapse)."""
    k = len(contacts.point)
    A = contacts.equilibrium()
    d, l = contacts.dead.ravel(), contacts.live.ravel()
    scale = max(float(np.abs(d).max(initial=0.0)), float(np.abs(l).max(initial=0.0)), 1e-300)
    lower = np.zeros(2 * k + 1)
    upper = np.full(2 * k + 1, np.inf)
    lower[1:2 * k:2], upper[1:2 * k:2] = -capacity / scale, capacity / scale
    lower[-1] = -np.inf
    cost = np.zeros(2 * k + 1)
    cost[-1] = -1.0
    sol = linprog(cost, A_eq=sp.hstack([A, sp.csr_matrix(l.reshape(-1, 1) / scale)]).tocsc(),
                  b_eq=-d / scale, bounds=np.column_stack([lower, upper]), method="highs")
    if sol.status != 0:
        return ContactCollapse(None, np.zeros((k, 2)), np.zeros(k, bool), np.zeros(k))
    velocity = np.asarray(sol.eqlin.marginals)
    velocity = velocity * (1.0 if l @ velocity >= 0 else -1.0)  # the live load does positive work
    rate = (A.T @ velocity).reshape(-1, 2)
    moving = MOTION_RTOL * max(float(np.abs(rate).max(initial=0.0)), 1e-300)
    opening = rate[:, 0] > moving
    slides = ~opening & (np.abs(rate[:, 1]) > moving)
    return ContactCollapse(float(sol.x[-1]), sol.x[:-1].reshape(-1, 2) * scale, opening,
                           np.where(slides, rate[:, 1], 0.0) / (l @ velocity))
