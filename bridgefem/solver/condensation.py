"""The joint law at a few pairs, solved exactly on their condensed (Schur complement) compliance.

With the active set of every other pair held, the problem is linear, so the relative displacements of a few pairs
P are an affine function of their joint forces (one load step's Schur complement of the elastic system onto P):

    d = d0 + C lam          (d: per pair [d_n, d_t - d_t(ref)], m; lam: per pair [lam_n, lam_t], N)

with d0 their displacements with P open (no force, m) and C (m/N, 2|P| x 2|P|, pairs' rows and columns in the order
(n, t) per pair) their compliance (for the Coulomb law). C is symmetric positive definite when every other pair is
open or sticking; with
sliding pairs elsewhere (lam_t = s mu lam_n, non-associative) it is not symmetric and need not be a P-matrix, so the
small complementarity problem below can have no solution or several (Klarbring 1990; Alart & Curnier 1991).

:func:`consistent_states` returns an active set of P (for Coulomb: open / stick / slip+ / slip- per pair,
:meth:`bridgefem.laws.base.JointLaw.candidates`) whose linear equations (the rows of the joint law,
:meth:`bridgefem.laws.base.JointLaw.rows`) give forces that the law's own classification
(:meth:`bridgefem.laws.base.JointLaw.classify`, with its hysteresis ``force_tol``) accepts as they are: a fixed point
of the active-set iteration at P. Every answer of either method below passes that check; nothing else is returned.

1. Up to ``ENUMERATED_PAIRS`` pairs it enumerates the 4^|P| combinations and, among several consistent ones, keeps
   the one with the fewest pairs changed from a reference active set (the step's converged start: the load step is
   small, so the state nearest the start continues the load path), then the fewest from the current one. Where the
   problem has several solutions (a non-symmetric C, large mu) this choice is what the enumeration gives and a
   pivoting method does not, and at 4^4 combinations it costs less than the 2|P| + 1 sparse solves that build C.
2. Above that (4^|P| grows too fast: 10^9 at 15 pairs), the reference active set is kept if it is consistent, then the
   current one; else the law is written as a linear complementarity problem (LCP, the law's own:
   :meth:`bridgefem.laws.base.JointLaw.complementarity`; for Coulomb friction in variables z = (lam_n, lam_+, lam_-,
   beta) per pair, Stewart & Trinkle 1996) and solved by Lemke's method (:func:`lemke`; Cottle, Pang & Stone 1992, sec.
   4.4), w = q + M z with d = d0 + C lam. Lemke's method was chosen over block principal pivoting (which needs a
   P-matrix, and the Coulomb law's M never is one: its beta block is zero) and over a semismooth Newton method on the
   small system (no finite termination, a merit function to tune): it is finite (lexicographic pivoting, no cycling on
   the degenerate rows q_beta = 0) and ends either at a solution or on a secondary ray. What it guarantees: for z >= 0,
   z^T M z = lam^T C lam + sum mu beta lam_n, so M is copositive whenever the symmetric part of C is positive
   semidefinite. Lemke's method on a copositive M ends on a secondary ray only if some z* != 0 solving the homogeneous
   problem (q = 0) has q^T z* < 0 (Cottle, Pang & Stone 1992, sec. 4.4). With C's symmetric part positive definite such
   a z* has lam* = 0, so z* = (0, 0, 0, beta*) and q^T z* = 0 (q_beta = 0): the method finds a solution. That is the
   case with every other closed pair sticking (C a Schur complement of a symmetric positive definite matrix), up to
   rounding: a C so ill-conditioned that its pairs, open, are nearly a mechanism (diagonal entries a million times
   apart) can still end on a ray. With pairs sliding elsewhere C is not symmetric, M need not be copositive, and the
   method may end on a ray (no solution, or one it cannot reach): then None, and the caller repeats the condensation
   with those slips stuck. The solution's active set is re-solved on its own equations and checked by the law's
   classification like an enumerated one.
"""
from __future__ import annotations

import itertools

import numpy as np

from ..laws.base import ContactState, JointLaw

SINGULAR_RTOL = 1e-12  # a combination whose equations' smallest pivot is below this of the largest is singular
ENUMERATED_PAIRS = 4  # up to this many pairs every combination is tried (4^4); above, Lemke's method
PIVOT_TOL = 1e-11  # a tableau entry below this (the LCP scaled to forces of order one) is no pivot
PIVOTS_PER_UNKNOWN = 50  # Lemke's method gives up after this many pivots per LCP unknown (it is finite)


def consistent_states(law: JointLaw, d0: np.ndarray, C: np.ndarray, reference: ContactState,
                      current: ContactState) -> "tuple[ContactState, np.ndarray] | None":
    """A consistent active set of the pairs of ``law`` (one per pair of P, in order) for ``d = d0 + C lam``
    (module docstring), and its joint forces lam (N, (|P|, 2)); None when none is found.

    ``d0``: (|P|, 2) relative displacements of P when open (m; normal with the ground offset, tangential slip since
    the last converged step), ``C``: (2|P|, 2|P|) compliance (m/N), ``reference`` / ``current``: the active sets of P
    that break ties (module docstring)."""
    if len(d0) <= ENUMERATED_PAIRS:
        return _enumerated(law, d0, C, reference, current)
    for known in (reference, current):
        lam, ok = _consistent(law, known, d0, C)
        if ok[0]:
            return known.copy(), lam[0].reshape(-1, 2)
    pivoted = lcp_active_set(law, d0, C)
    if pivoted is None:
        return None
    lam, ok = _consistent(law, pivoted, d0, C)
    return (pivoted, lam[0].reshape(-1, 2)) if ok[0] else None


def _enumerated(law: JointLaw, d0: np.ndarray, C: np.ndarray, reference: ContactState, current: ContactState
                ) -> "tuple[ContactState, np.ndarray] | None":
    """Every combination of states of the pairs tried; the consistent one nearest ``reference``, then ``current``."""
    p = len(d0)
    candidates = law.candidates()
    combos = np.array(list(itertools.product(range(len(candidates)), repeat=p)), dtype=int).reshape(-1, p)
    table = np.array(candidates, dtype=np.int8)
    states, signs = table[combos, 0], table[combos, 1]
    lam, ok = _consistent(law, ContactState(states.ravel(), signs.ravel()), d0, C)
    if not ok.any():
        return None
    changed = [((states != a.state) | (signs != a.sign)).sum(axis=1) for a in (reference, current)]
    best = np.flatnonzero(ok)[np.lexsort((changed[1][ok], changed[0][ok]))[0]]
    return ContactState(states[best].copy(), signs[best].copy()), lam[best].reshape(p, 2)


def _consistent(law: JointLaw, candidates: ContactState, d0: np.ndarray, C: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The forces of n combinations of states of the p pairs (``candidates``: n p pairs, combination after
    combination) from their equations, (n, 2p) in N, and whether the law's classification keeps each combination as
    it is (n,). A combination whose equations are singular is not consistent."""
    p = len(d0)
    n = len(candidates.state) // p
    tiled = law.tiled(n)
    matrices, rhs = _equations(tiled, candidates, d0, C)
    pivots = np.abs(np.linalg.svd(matrices, compute_uv=False))
    solvable = pivots[:, -1] > SINGULAR_RTOL * np.maximum(pivots[:, 0], 1e-300)
    lam = np.zeros((n, 2 * p))
    lam[solvable] = np.linalg.solve(matrices[solvable], rhs[solvable][..., None])[..., 0]
    d = d0.ravel() + lam @ C.T
    proposed, _ = tiled.classify(candidates, lam.reshape(-1, 2), d.reshape(-1, 2), np.zeros(n * p))
    kept = ((proposed.state == candidates.state) & (proposed.sign == candidates.sign)).reshape(n, p)
    return lam, solvable & kept.all(axis=1)


def lcp_active_set(law: JointLaw, d0: np.ndarray, C: np.ndarray) -> ContactState | None:
    """The active set of the solution of the law's complementarity problem on ``d = d0 + C lam``
    (:meth:`bridgefem.laws.base.JointLaw.complementarity`) by Lemke's method; None when the law has none or the
    method ends on a ray."""
    problem = law.complementarity(d0, C)
    z = None if problem is None else lemke(*problem)
    if z is None:
        return None
    return law.lcp_state(z, PIVOT_TOL)


def lemke(M: np.ndarray, q: np.ndarray) -> np.ndarray | None:
    """A solution z of the LCP ``w = q + M z``, w >= 0, z >= 0, w z = 0 by Lemke's complementary pivoting with the
    covering vector of ones and the lexicographic ratio test (Cottle, Pang & Stone 1992, Algorithm 4.4.5 and
    sec. 4.9); None when it ends on a secondary ray or after ``PIVOTS_PER_UNKNOWN`` pivots per unknown. Unknowns
    are numbered w_0 .. w_(n-1), z_0 .. z_(n-1), then the artificial z_a; the tableau holds B^-1 [q, I, -M, -1]."""
    n = len(q)
    if np.all(q >= 0):
        return np.zeros(n)
    tableau = np.hstack([q[:, None], np.eye(n), -M, -np.ones((n, 1))])
    basis = np.arange(n)
    artificial = 2 * n
    row, entering = int(np.argmin(q)), artificial
    for _ in range(PIVOTS_PER_UNKNOWN * n):
        leaving = basis[row]
        _pivot(tableau, row, entering + 1)
        basis[row] = entering
        if leaving == artificial:
            z = np.zeros(n)
            in_z = (basis >= n) & (basis < 2 * n)
            z[basis[in_z] - n] = np.maximum(tableau[in_z, 0], 0.0)
            return z
        entering = leaving + n if leaving < n else leaving - n  # the complement of the unknown that left
        row = _ratio_test(tableau, entering + 1, basis == artificial)
        if row is None:
            return None
    return None


def _pivot(tableau: np.ndarray, row: int, column: int) -> None:
    """Gauss-Jordan pivot of the tableau on (row, column), in place."""
    pivot_row = tableau[row] / tableau[row, column]
    tableau -= np.outer(tableau[:, column], pivot_row)
    tableau[row] = pivot_row


def _ratio_test(tableau: np.ndarray, column: int, artificial: np.ndarray) -> int | None:
    """The row that leaves when the unknown of ``column`` enters: the least ratio (basic value / column entry) over
    the rows with a positive entry, ties broken lexicographically by the rows of B^-1 (no cycling on degenerate
    rows), the artificial unknown's row first among ties (it ends the method). None: the column is a ray."""
    a = tableau[:, column]
    rows = np.flatnonzero(a > PIVOT_TOL)
    if len(rows) == 0:
        return None
    n = tableau.shape[0]
    for k in range(n + 1):  # columns of [q, B^-1]: at most n + 1 ties to break
        ratios = tableau[rows, k] / a[rows]
        rows = rows[ratios <= ratios.min() + PIVOT_TOL * (1.0 + abs(ratios.min()))]
        if k == 0 and artificial[rows].any():
            return int(rows[artificial[rows]][0])
        if len(rows) == 1:
            break
    return int(rows[0])


def is_p_matrix(M: np.ndarray) -> bool:
    """Whether every principal minor of the square matrix M is positive (a P-matrix: the linear complementarity
    problem w = q + M z, w, z >= 0, w z = 0 has exactly one solution for every q; Cottle, Pang & Stone 1992,
    Thm 3.3.7). For the normal block of a condensed compliance: pushing any subset of the pairs apart opens them."""
    n = len(M)
    subsets = (np.array(s) for k in range(1, n + 1) for s in itertools.combinations(range(n), k))
    return all(np.linalg.det(M[np.ix_(s, s)]) > 0 for s in subsets)


def opens_when_pulled(C: np.ndarray) -> bool:
    """Whether the normal block C_nn of a condensed compliance C (2p, 2p) is a P-matrix (pushing any subset of the
    pairs apart opens them, :func:`is_p_matrix`): exactly up to ``ENUMERATED_PAIRS`` pairs (2^p principal minors),
    above by the sufficient test that its symmetric part is positive definite (then x^T C_nn x > 0 for every
    x != 0, so no principal submatrix has a real eigenvalue <= 0 and every principal minor is positive). A P-matrix
    that fails the sufficient test is declined: the caller then holds the other sliding pairs stuck."""
    normal = C[0::2, 0::2]
    if len(normal) <= ENUMERATED_PAIRS:
        return is_p_matrix(normal)
    return bool(np.linalg.eigvalsh(0.5 * (normal + normal.T))[0] > 0)


def pulled_margin(C: np.ndarray) -> float:
    """How far the normal block C_nn of a condensed compliance C (2p, 2p, m/N) that passes :func:`opens_when_pulled`
    is from failing it (m/N): the 2-norm of the smallest perturbation of C_nn that can change the test's verdict is
    at least this. Up to ``ENUMERATED_PAIRS`` pairs, the least singular value of its principal submatrices: for
    |E|_2 below it every M_S + t E_S (0 <= t <= 1) is nonsingular, so no principal minor changes sign; above, the
    least eigenvalue of its symmetric part, which a perturbation moves by at most |E|_2 (Weyl). 0 when it fails."""
    normal = C[0::2, 0::2]
    if not opens_when_pulled(C):
        return 0.0
    if len(normal) > ENUMERATED_PAIRS:
        return float(np.linalg.eigvalsh(0.5 * (normal + normal.T))[0])
    subsets = (np.array(s) for k in range(1, len(normal) + 1) for s in itertools.combinations(range(len(normal)), k))
    return min(float(np.linalg.svd(normal[np.ix_(s, s)], compute_uv=False)[-1]) for s in subsets)


def _equations(tiled: JointLaw, candidates: ContactState, d0: np.ndarray, C: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """The joint law's rows for n combinations of the states of the p pairs (``candidates``: n p pairs, the law
    ``tiled`` n times) on d = d0 + C lam: ``a c (d0 + C lam) + b lam + e lam_n = 0`` per pair and direction
    (:class:`bridgefem.laws.base.LawRows`). Returns the matrices (n, 2p, 2p) and right-hand sides (n, 2p)."""
    p = len(d0)
    n = len(candidates.state) // p
    rows = tiled.rows(candidates)
    a = np.column_stack([rows.a_n, rows.a_t]).reshape(n, 2 * p) * np.repeat(tiled.c.reshape(n, p), 2, axis=1)
    b = np.column_stack([rows.b_n, rows.b_t]).reshape(n, 2 * p)
    matrices = a[:, :, None] * C[None] + b[:, :, None] * np.eye(2 * p)[None]
    k = np.arange(p)
    matrices[:, 2 * k + 1, 2 * k] += rows.e_t.reshape(n, p)
    return matrices, -a * d0.ravel()[None]
