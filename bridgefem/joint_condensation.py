"""The joint law at a few pairs, solved exactly on their condensed (Schur complement) compliance.

With the active set of every other pair held, the problem is linear, so the relative displacements of a few pairs
P are an affine function of their joint forces (one load step's Schur complement of the elastic system onto P):

    d = d0 + C lam          (d: per pair [d_n, d_t - d_t(ref)], m; lam: per pair [lam_n, lam_t], N)

with d0 their displacements with P open (no force, m) and C (m/N, 2|P| x 2|P|, pairs' rows and columns in the order
(n, t) per pair) their compliance. C is symmetric positive definite when every other pair is open or sticking; with
sliding pairs elsewhere (lam_t = s mu lam_n, non-associative) it is not symmetric and need not be a P-matrix, so the
small complementarity problem below can have no solution or several (Klarbring 1990; Alart & Curnier 1991).

:func:`consistent_states` enumerates the 4^|P| combinations of the states open / stick / slip+ / slip- of the pairs
in P, solves the linear equations of each combination (the rows of the joint law, :meth:`CoulombJoints.rows`) and
keeps those that the law's own classification (:meth:`CoulombJoints.classify`, with its hysteresis ``force_tol``)
accepts as they are: a consistent combination is then a fixed point of the active-set iteration at P. Among several
it takes the one with the fewest pairs changed from a reference active set (the step's converged start: the
load step is small, so the state nearest the start continues the load path), then the fewest from the current one.
"""
from __future__ import annotations

import itertools

import numpy as np

from .contact import OPEN, SLIP, STICK, ContactState, CoulombJoints

CANDIDATES = ((OPEN, 0), (STICK, 0), (SLIP, 1), (SLIP, -1))  # (state, slip sign) each pair may take
SINGULAR_RTOL = 1e-12  # a combination whose equations' smallest pivot is below this of the largest is singular


def consistent_states(law: CoulombJoints, d0: np.ndarray, C: np.ndarray, reference: ContactState,
                      current: ContactState) -> "tuple[ContactState, np.ndarray] | None":
    """The consistent active set of the pairs of ``law`` (one per pair of P, in order) for ``d = d0 + C lam``
    (module docstring), and its joint forces lam (N, (|P|, 2)); None when no combination is consistent.

    ``d0``: (|P|, 2) relative displacements of P when open (m; normal with the ground offset, tangential slip since
    the last converged step), ``C``: (2|P|, 2|P|) compliance (m/N), ``reference`` / ``current``: the active sets of P
    that break ties (module docstring)."""
    p = len(d0)
    combos = np.array(list(itertools.product(range(len(CANDIDATES)), repeat=p)), dtype=int).reshape(-1, p)
    table = np.array(CANDIDATES, dtype=np.int8)
    states, signs = table[combos, 0], table[combos, 1]
    tiled = CoulombJoints(np.tile(law.mu, len(combos)), np.tile(law.c, len(combos)), law.force_tol)
    candidates = ContactState(states.ravel(), signs.ravel())
    matrices, rhs = _equations(tiled, candidates, d0, C)
    pivots = np.abs(np.linalg.svd(matrices, compute_uv=False))
    solvable = pivots[:, -1] > SINGULAR_RTOL * np.maximum(pivots[:, 0], 1e-300)
    lam = np.zeros((len(combos), 2 * p))
    lam[solvable] = np.linalg.solve(matrices[solvable], rhs[solvable][..., None])[..., 0]
    d = d0.ravel() + lam @ C.T
    proposed, _ = tiled.classify(candidates, lam.reshape(-1, 2), d.reshape(-1, 2), np.zeros(len(combos) * p))
    kept = ((proposed.state == candidates.state) & (proposed.sign == candidates.sign)).reshape(-1, p)
    ok = solvable & kept.all(axis=1)
    if not ok.any():
        return None
    changed = [((states != a.state) | (signs != a.sign)).sum(axis=1) for a in (reference, current)]
    best = np.flatnonzero(ok)[np.lexsort((changed[1][ok], changed[0][ok]))[0]]
    return ContactState(states[best].copy(), signs[best].copy()), lam[best].reshape(p, 2)


def is_p_matrix(M: np.ndarray) -> bool:
    """Whether every principal minor of the square matrix M is positive (a P-matrix: the linear complementarity
    problem w = q + M z, w, z >= 0, w z = 0 has exactly one solution for every q; Cottle, Pang & Stone 1992,
    Thm 3.3.7). For the normal block of a condensed compliance: pushing any subset of the pairs apart opens them."""
    n = len(M)
    subsets = (np.array(s) for k in range(1, n + 1) for s in itertools.combinations(range(n), k))
    return all(np.linalg.det(M[np.ix_(s, s)]) > 0 for s in subsets)


def _equations(tiled: CoulombJoints, candidates: ContactState, d0: np.ndarray, C: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """The joint law's rows for n combinations of the states of the p pairs (``candidates``: n p pairs, the law
    ``tiled`` n times) on d = d0 + C lam: ``a c (d0 + C lam) + b lam + e lam_n = 0`` per pair and direction
    (:class:`bridgefem.contact.LawRows`). Returns the matrices (n, 2p, 2p) and right-hand sides (n, 2p)."""
    p = len(d0)
    n = len(candidates.state) // p
    rows = tiled.rows(candidates)
    a = np.column_stack([rows.a_n, rows.a_t]).reshape(n, 2 * p) * np.repeat(tiled.c.reshape(n, p), 2, axis=1)
    b = np.column_stack([rows.b_n, rows.b_t]).reshape(n, 2 * p)
    matrices = a[:, :, None] * C[None] + b[:, :, None] * np.eye(2 * p)[None]
    k = np.arange(p)
    matrices[:, 2 * k + 1, 2 * k] += rows.e_t.reshape(n, p)
    return matrices, -a * d0.ravel()[None]
