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
    matrices, rhs = _equations(law, states, signs, d0, C)
    pivots = np.abs(np.linalg.svd(matrices, compute_uv=False))
    solvable = pivots[:, -1] > SINGULAR_RTOL * np.maximum(pivots[:, 0], 1e-300)
    lam = np.zeros((len(combos), 2 * p))
    lam[solvable] = np.linalg.solve(matrices[solvable], rhs[solvable][..., None])[..., 0]
    d = d0.ravel() + lam @ C.T
    ok = solvable.copy()
    for k in np.flatnonzero(solvable):  # a few hundred combinations of a few pairs
        candidate = ContactState(states[k], signs[k])
        proposed, _ = law.classify(candidate, lam[k].reshape(p, 2), d[k].reshape(p, 2), np.zeros(p))
        ok[k] = np.array_equal(proposed.state, candidate.state) and np.array_equal(proposed.sign, candidate.sign)
    if not ok.any():
        return None
    changed = [((states != a.state) | (signs != a.sign)).sum(axis=1) for a in (reference, current)]
    best = np.flatnonzero(ok)[np.lexsort((changed[1][ok], changed[0][ok]))[0]]
    return ContactState(states[best].copy(), signs[best].copy()), lam[best].reshape(p, 2)


def _equations(law: CoulombJoints, states: np.ndarray, signs: np.ndarray, d0: np.ndarray, C: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """The joint law's rows for every combination (rows ``states``, ``signs``: (n, |P|)) on d = d0 + C lam:
    ``a c (d0 + C lam) + b lam + e lam_n = 0`` per pair and direction (:class:`bridgefem.contact.LawRows`).
    Returns the matrices (n, 2|P|, 2|P|) and right-hand sides (n, 2|P|)."""
    n, p = states.shape
    tiled = CoulombJoints(np.tile(law.mu, n), np.tile(law.c, n), law.force_tol)
    rows = tiled.rows(ContactState(states.ravel(), signs.ravel()))
    c = tiled.c.reshape(n, p)
    a = np.stack([rows.a_n.reshape(n, p), rows.a_t.reshape(n, p)], axis=2).reshape(n, 2 * p) * np.repeat(c, 2, 1)
    b = np.stack([rows.b_n.reshape(n, p), rows.b_t.reshape(n, p)], axis=2).reshape(n, 2 * p)
    matrices = a[:, :, None] * C[None] + b[:, :, None] * np.eye(2 * p)[None]
    k = np.arange(p)
    matrices[:, 2 * k + 1, 2 * k] += rows.e_t.reshape(n, p)
    return matrices, -a * d0.ravel()[None]
