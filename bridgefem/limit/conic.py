"""A conic programme ``min c.x  s.t.  A x + s = b,  s in K`` solved by Clarabel (Goulart & Chen 2024, an
interior-point solver for linear, second-order-cone and other conic programmes).

``K`` is the product, in this order, of a zero cone (equalities ``A x = b``), a nonnegative cone
(inequalities ``A x <= b``) and three-dimensional second-order cones ``s_0 >= |(s_1, s_2)|``. Rows are added
in sparse triplet form per cone; the programme is scaled before the solve (columns by the given magnitudes of
the unknowns, rows to unit largest entry, each second-order cone by one factor) and unscaled after it. The
duals ``z`` (one per row, KKT: ``c + A^T z = 0``) are returned in the unscaled programme.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

ZERO, NONNEG, SOC = "zero", "nonneg", "soc"
MAX_ITERATIONS = 60  # interior-point iterations; past them Clarabel reports "AlmostSolved" if its relaxed
# tolerances (1e-4 / 5e-5) are met: the upper-bound programmes of bridges with a fill can creep for hundreds of
# iterations with a primal residual near 1e-6 while the load factor falls in its fourth digit (Prestwood:
# 234.52 kN at 60 iterations, 234.45 kN at 100)
RETRY_REGULARIZATION = 1e-7  # Clarabel's static KKT regularisation (default 1e-8) for a second attempt after a
# numerical failure: the rigid rough footing (a block bonded to weightless soil, fans of tiny triangles at its edges)
# stops with NumericalError / InsufficientProgress at size B/20 under the default and solves with this
FACTORISATION = "qdldl"  # Clarabel's sparse LDL^T of the KKT system: QDLDL (its default) or faer (supernodal),
# each on one thread; on the same iterates QDLDL takes 0.4-0.75 x faer's time from about 5000 triangles and
# 0.8-1.2 x below 2500 (benchmarks/bounds_factorisation.py measures both side by side)
FACTORISATIONS = ("qdldl", "faer")
_CONES = (ZERO, NONNEG, SOC)
INFEASIBLE = "infeasible"  # Clarabel's certificate of primal infeasibility: no feasible point exists


@dataclass
class ConicSolution:
    """status: "optimal" | "optimal (reduced accuracy)" (Clarabel's AlmostSolved: the relaxed tolerances met) |
    "infeasible" | "unbounded" | "solver failure: <Clarabel status>"; x, z: unknowns and
    duals per cone type (dict cone -> array); objective c.x; iterations; seconds (solve only); sizes: unknowns,
    rows per cone type and the number of second-order cones."""

    status: str
    x: np.ndarray | None
    z: dict
    objective: float | None
    iterations: int
    seconds: float
    sizes: dict


def clarabel_solve(P: sp.csc_matrix, q: np.ndarray, A: sp.csc_matrix, b: np.ndarray, cones: list, settings):
    """Clarabel's solution of ``min 1/2 x.P x + q.x  s.t.  A x + s = b, s in cones``, or None and why when it
    raises instead: bad data raises an Exception, an internal error a Rust panic (pyo3's ``PanicException``, which
    derives from BaseException, not Exception). Either is the solver's failure, never a crash; anything else
    (e.g. KeyboardInterrupt) propagates."""
    import clarabel

    try:
        return clarabel.DefaultSolver(P, q, A, b, cones, settings).solve(), ""
    except BaseException as err:  # a panic is a BaseException; any other is re-raised
        if not isinstance(err, Exception) and type(err).__name__ != "PanicException":
            raise
        return None, f"Clarabel raised {type(err).__name__}: {err}"


class ConicProgramme:
    """Rows of a conic programme in ``n`` unknowns, collected per cone type (see the module docstring)."""

    def __init__(self, n: int):
        self.n = n
        self.parts = {cone: [] for cone in _CONES}
        self.rows = {cone: 0 for cone in _CONES}

    def add(self, cone: str, rows, cols, vals, rhs) -> np.ndarray:
        """Append ``len(rhs)`` rows to cone ``cone`` (entries at local rows ``rows``, columns ``cols``); returns
        their global indices within the cone. Second-order cones come as consecutive triples."""
        rhs = np.asarray(rhs, float).ravel()
        start = self.rows[cone]
        rows, cols, vals = (np.asarray(v).ravel() for v in (rows, cols, vals))
        self.parts[cone].append((rows + start, cols, vals.astype(float), rhs))
        self.rows[cone] += len(rhs)
        return np.arange(start, start + len(rhs))

    def matrix(self, cone: str) -> tuple[sp.csr_matrix, np.ndarray]:
        parts = self.parts[cone]
        if not parts:
            return sp.csr_matrix((0, self.n)), np.zeros(0)
        r, c, v, b = (np.concatenate(p) for p in zip(*parts))
        return sp.csr_matrix((v, (r, c)), shape=(self.rows[cone], self.n)), b

    def maximise(self, column: int, scale: np.ndarray, max_iter: int = MAX_ITERATIONS,
                 factorisation: str = FACTORISATION) -> ConicSolution:
        """Maximise the unknown ``column`` (a load factor), kept nonnegative by one more row, in at most ``max_iter``
        interior-point iterations; ``scale`` and ``factorisation`` as in :meth:`solve`."""
        self.add(NONNEG, [0], [column], [-1.0], [0.0])
        cost = np.zeros(self.n)
        cost[column] = -1.0
        return self.solve(cost, scale, max_iter, factorisation)

    def solve(self, cost: np.ndarray, scale: np.ndarray, max_iter: int = MAX_ITERATIONS,
              factorisation: str = FACTORISATION) -> ConicSolution:
        """Minimise ``cost . x``; ``scale`` (n,) are typical magnitudes of the unknowns. Clarabel's defaults
        (tolerances 1e-8) with the KKT factorisation ``factorisation`` (one of ``FACTORISATIONS``) on one thread
        (MPI ranks run their own); a numerical failure is retried once with the static regularisation
        ``RETRY_REGULARIZATION`` (iterations and seconds then count both attempts)."""
        import clarabel

        blocks, rhs, row_scale = [], [], []
        for cone in _CONES:
            a, b = self.matrix(cone)
            a = a @ sp.diags(scale)
            big = np.asarray(abs(a).max(axis=1).todense()).ravel() if a.shape[0] else np.zeros(0)
            big[big == 0] = 1.0
            if cone == SOC:
                big = np.repeat(big.reshape(-1, 3).max(axis=1), 3)
            blocks.append(sp.diags(1 / big) @ a)
            rhs.append(b / big)
            row_scale.append(1 / big)
        a = sp.vstack(blocks, format="csc")
        cones = []
        if self.rows[ZERO]:
            cones.append(clarabel.ZeroConeT(self.rows[ZERO]))
        if self.rows[NONNEG]:
            cones.append(clarabel.NonnegativeConeT(self.rows[NONNEG]))
        cones += [clarabel.SecondOrderConeT(3)] * (self.rows[SOC] // 3)
        sizes = {"unknowns": self.n, "equalities": self.rows[ZERO], "inequalities": self.rows[NONNEG],
                 "cones": self.rows[SOC] // 3}
        start, iterations = time.perf_counter(), 0
        for regularization in (None, RETRY_REGULARIZATION):
            settings = clarabel.DefaultSettings()
            settings.verbose = False
            settings.max_iter = max_iter
            settings.direct_solve_method = factorisation
            settings.max_threads = 1
            if regularization is not None:
                settings.static_regularization_constant = regularization
            sol, raised = clarabel_solve(sp.csc_matrix((self.n, self.n)), cost * scale, a, np.concatenate(rhs),
                                         cones, settings)
            if sol is None:
                return ConicSolution(f"solver failure: {raised}", None, {}, None, iterations,
                                     time.perf_counter() - start, sizes)
            iterations += sol.iterations
            name = str(sol.status).split(".")[-1]
            if name not in ("NumericalError", "InsufficientProgress"):
                break
        seconds = time.perf_counter() - start
        status = {"Solved": "optimal", "AlmostSolved": "optimal (reduced accuracy)", "PrimalInfeasible": INFEASIBLE,
                  "DualInfeasible": "unbounded"}.get(name, f"solver failure: Clarabel {name}")
        if not status.startswith("optimal"):
            return ConicSolution(status, None, {}, None, iterations, seconds, sizes)
        z = np.asarray(sol.z) * np.concatenate(row_scale)
        bounds = np.cumsum([0] + [self.rows[c] for c in _CONES])
        x = np.asarray(sol.x) * scale
        return ConicSolution(status, x, {c: z[bounds[i]:bounds[i + 1]] for i, c in enumerate(_CONES)},
                             float(cost @ x), iterations, seconds, sizes)
