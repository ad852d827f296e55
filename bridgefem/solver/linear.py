"""The linear solve of a load step: a PETSc KSP (by default MUMPS LU) whose factorisation is reused while the matrix
does not change, and a check of every solve before its result is used.

A solve fails (:class:`SolveFailure`) when PETSc raises, when the KSP reports divergence, when the solution holds
NaN, or when its normwise backward error |A x - b|_inf / (|A|_inf |x|_inf + |b|_inf) is above ``BACKWARD_TOL``: a
solver that did not solve the system (e.g. ``pc_type = none``) is a failure, never a mechanism. Only MUMPS finding
the matrix numerically singular (INFOG(1) = -10) marks a failure ``singular``. The solve after any failure uses a
new KSP: after a PETSc error inside KSPSolve, PCPreSolve's nesting count stays raised (two such errors and every
later solve fails with PETSc error 56); after a singular factorisation, MUMPS refused the next solve of the same KSP
with INFOG(1) = -3.

A caller may bound the solves (:meth:`CheckedSolve.limited`, e.g. a re-run's budget: :mod:`bridgefem.analysis.runner`):
the solve that would pass the bound raises :class:`SolveBudgetSpent` before it solves, wherever it is asked for (a
Newton iteration, a cycle's condensation, an iterative refinement), so the bound holds exactly.
"""
from __future__ import annotations

import math
import time
from contextlib import contextmanager
from typing import TYPE_CHECKING, Callable, Iterator, NamedTuple

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..petsc_start import startup_options
from ..scene.keys import SceneError
from ..scene.petsc_options import PETSC_PREFIX
from ..status import LINEAR_SOLVER_FAILED

if TYPE_CHECKING:
    from .interior import InteriorCondensation

DEFAULT_PETSC_OPTIONS = {
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
    "mat_mumps_icntl_14": 200,  # % of workspace above MUMPS's estimate: the zero diagonal of the contact laws' rows
}                               # forces delayed pivots that outgrow the default 20 % (INFOG(1) = -9)
BACKWARD_TOL = 1e-9  # a linear solve whose normwise backward error is above this did not solve (LU gives ~1e-16)


class SolveFailure(NamedTuple):
    """Why a solve failed; ``singular``: MUMPS found the matrix numerically singular."""

    message: str
    singular: bool


class SolveBudgetSpent(Exception):
    """A solve asked for beyond the bound of :meth:`CheckedSolve.limited` (``budget``: that bound's solves); nothing
    was solved."""

    def __init__(self, budget: float):
        super().__init__(f"its budget of {budget:g} linear solves is spent")
        self.budget = budget


def environment_options() -> dict:
    """The contact solver's options in the user's environment (``-bridgefem_KEY VALUE`` in PETSC_OPTIONS, or in an
    options file it names), without the prefix; a flag's value is ""."""
    return {key[len(PETSC_PREFIX):]: value for key, value in startup_options().items() if key.startswith(PETSC_PREFIX)}


class CheckedSolve:
    """The KSP of a matrix ``A`` and counters ``stats`` (factorisations, updates: new matrices solved without one,
    solves, seconds factorising and solving);
    with a ``condensation`` (:class:`bridgefem.solver.interior.InteriorCondensation`) the KSP is its reduced system's,
    each solve goes through it and is checked on ``A`` as any other, and a factorisation is the reduced system's.
    Its options (without the prefix): the defaults, overridden by the user's environment's
    (:func:`environment_options`: they replace the defaults on every run), overridden by ``options`` (the scene's
    and the command line's, which are the run's own)."""

    def __init__(self, A: PETSc.Mat, options: dict, condensation: "InteriorCondensation | None" = None):
        self.A, self.condensation = A, condensation
        self.comm = A.getComm().tompi4py()
        merged = {**DEFAULT_PETSC_OPTIONS, **environment_options(), **options}
        self.options = {k: str(v) for k, v in merged.items()}
        self.ksp = self._new_ksp()
        self.stats = {"factorisations": 0, "updates": 0, "solves": 0, "time_factorise_solve": 0.0}
        self._r = A.createVecLeft()
        self._residual, self._correction = A.createVecLeft(), A.createVecRight()
        self._broken = False
        self._norm: float | None = None  # |A|_inf of the matrix as it stands
        self._bound = (math.inf, math.inf)  # the count of solves the next may not pass, and the budget that set it

    @contextmanager
    def limited(self, budget: float | None) -> Iterator[Callable[[], None]]:
        """Within: at most ``budget`` more solves (None: no bound; an enclosing bound still holds); the next one
        raises :class:`SolveBudgetSpent` before it solves. Every solve is collective, so every rank counts the same
        solves and raises at the same one. Yields ``lift()``, which drops this bound for the rest of the block (the
        enclosing one still holds); collective by the same count."""
        outer = self._bound
        if budget is not None and self.stats["solves"] + budget < outer[0]:
            self._bound = (self.stats["solves"] + budget, budget)

        def lift() -> None:
            self._bound = outer

        try:
            yield lift
        finally:
            self._bound = outer

    def _new_ksp(self) -> PETSc.KSP:
        """A KSP of ``A`` with ``options`` under the prefix, set up (the factorisation reads its options, e.g. MUMPS
        ICNTL, now; they are then removed from the global options database)."""
        opts = PETSc.Options()
        for key, value in self.options.items():
            opts[PETSC_PREFIX + key] = value
        ksp = PETSc.KSP().create(self.operator.getComm())
        try:
            ksp.setOptionsPrefix(PETSC_PREFIX)
            ksp.setOperators(self.operator)
            ksp.setFromOptions()
            ksp.setUp()
        finally:
            for key in self.options:
                opts.delValue(PETSC_PREFIX + key)
        return ksp

    @property
    def operator(self) -> PETSc.Mat:
        """The matrix the KSP factorises: ``A``, or the condensation's reduced system."""
        return self.A if self.condensation is None else self.condensation.R

    def matrix_changed(self, law_values: np.ndarray | None = None) -> None:
        """The matrix's values changed: the next solve refactorises; with a condensation only the law's rows may
        change, and ``law_values`` are their new values (the rank's law rows, CSR order), for the reduced system,
        whose factorisation may serve them updated (:mod:`bridgefem.solver.low_rank`)."""
        self._norm = None
        if self.condensation is not None and not self.condensation.law_changed(law_values):
            self.stats["updates"] += 1
            return
        self.ksp.setOperators(self.operator)
        self.stats["factorisations"] += 1

    def solve(self, b: PETSc.Vec, x: PETSc.Vec) -> SolveFailure | None:
        """Solve A x = b; None when the solve is good (module docstring). After a failure the caller must not reuse
        the factorisation (it calls :meth:`matrix_changed` before the next solve, which then factorises). Collective;
        raises :class:`SolveBudgetSpent`, solving nothing, beyond the bound of :meth:`limited`."""
        failure = self._checked_solve(b, x)
        if failure is not None and self.condensation is not None:
            self.condensation.update.forget()
        return failure

    def _checked_solve(self, b: PETSc.Vec, x: PETSc.Vec) -> SolveFailure | None:
        """:meth:`solve` without its care for the factorisation after a failure."""
        if self.stats["solves"] + 1 > self._bound[0]:
            raise SolveBudgetSpent(self._bound[1])
        t0 = time.perf_counter()
        fallbacks = self.condensation.update.fallbacks if self.condensation is not None else 0
        try:
            if self._broken:
                self.ksp.destroy()
                self.ksp, self._broken = self._new_ksp(), False
            if self.condensation is not None:
                self.condensation.solve(self.ksp, b, x)
            else:
                self.ksp.solve(b, x)
        except PETSc.Error as err:  # e.g. MUMPS refusing to solve with a factorisation that failed
            # an error inside KSPSolve leaves the KSP unusable (PCPreSolve's nesting count is never reset: after two
            # such errors every solve fails with PETSc error 56): the next solve builds a new one
            self._broken = True
            failure = self._failure(f"PETSc error code {err.ierr}")
            return failure if failure.singular else \
                SolveFailure(f"linear solver error: PETSc error code {err.ierr} (not a proof of a mechanism)", False)
        finally:
            self.stats["time_factorise_solve"] += time.perf_counter() - t0
            self.stats["solves"] += 1
            if self.condensation is not None:  # updated solves that were factorised instead
                self.stats["factorisations"] += self.condensation.update.fallbacks - fallbacks
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            self._broken = True  # module docstring: a new KSP for the next solve
            return self._failure(reason)
        if self.comm.allreduce(int(not np.all(np.isfinite(x.array))), op=MPI.MAX):
            return SolveFailure("NaN in the solution", False)
        error = self.backward_error(b, x)
        if not error <= BACKWARD_TOL:
            return SolveFailure(f"linear solve inaccurate: backward error {error:.2e} above {BACKWARD_TOL:g} (the "
                                f"{self.ksp.getType()}/{self.ksp.getPC().getType()} solver did not solve the system; "
                                "not a proof of a mechanism)", False)
        return None

    def correction(self, b: PETSc.Vec, x: PETSc.Vec) -> "PETSc.Vec | SolveFailure":
        """One step of iterative refinement of a solve of A x = b: the correction dx = A^-1 (b - A x) with the same
        factorisation (one more solve, counted and checked as any other; Higham 2002, *Accuracy and Stability of
        Numerical Algorithms*, ch. 12). It estimates x's forward error to within a modest factor (the residual's own
        rounding is of the order of the backward error's) whenever that error is below |x|; a correction as large as
        x says that x is rounding (a nearly singular A). Returns dx (a work vector, overwritten by the next call) or
        the failure. Collective."""
        self.A.mult(x, self._residual)
        self._residual.aypx(-1.0, b)
        failure = self.solve(self._residual, self._correction)
        return self._correction if failure is None else failure

    def backward_error(self, b: PETSc.Vec, x: PETSc.Vec) -> float:
        """Normwise backward error of a solve, |A x - b|_inf / (|A|_inf |x|_inf + |b|_inf): about the machine
        precision times a modest growth factor for a backward-stable direct solve, even of a nearly singular system
        (then x is large, not the residual). Collective."""
        self.A.mult(x, self._r)
        self._r.axpy(-1.0, b)
        inf = PETSc.NormType.INFINITY
        if self._norm is None:  # |A|_inf, kept until the matrix changes
            self._norm = self.A.norm(inf)
        scale = self._norm * x.norm(inf) + b.norm(inf)
        return self._r.norm(inf) / scale if scale > 0 else 0.0

    def _failure(self, reason: int | str) -> SolveFailure:
        """Describe a failed solve (a KSP reason or an error's text); singular only when MUMPS says so."""
        names = {v: k for k, v in PETSc.KSP.ConvergedReason.__dict__.items() if isinstance(v, int)}
        pc = self.ksp.getPC()
        text = f"{LINEAR_SOLVER_FAILED}: {names.get(reason, reason)}"
        if pc.getType() == "lu" and pc.getFactorSolverType() == "mumps":
            infog = pc.getFactorMatrix().getMumpsInfog(1)
            detail = {-10: "numerically singular matrix (mechanism)", -9: "MUMPS workspace too small "
                      "(raise mat_mumps_icntl_14)", -8: "MUMPS workspace too small", -13: "out of memory"}
            return SolveFailure(f"{text}, MUMPS INFOG(1) = {infog}: {detail.get(infog, 'see the MUMPS manual')}",
                                infog == -10)
        return SolveFailure(f"{text} (the {pc.getType()} preconditioner failed; not a proof of a mechanism)", False)


def check_petsc_options(options: dict, comm, where: str | None = None) -> None:
    """Set each PETSc option (the scene's and the command line's, or those of the environment variable ``where``) on
    a throw-away solver of a tiny matrix, so that a value PETSc rejects (an unknown type, a malformed number, a
    solver package not installed, a file it cannot open) stops the run before anything is written (collective)."""
    if not options:
        return
    prefix = "bridgefem_check_"
    A = PETSc.Mat().createAIJ([(2, None), (2, None)], nnz=1, comm=comm)
    first, last = A.getOwnershipRange()
    for i in range(first, last):
        A.setValue(i, i, 1.0)
    A.assemble()
    opts = PETSc.Options()
    PETSc.Sys.pushErrorHandler("python")  # raise, without PETSc's own error print
    try:
        for key, value in options.items():
            merged = {**DEFAULT_PETSC_OPTIONS, key: value}
            for k, v in merged.items():
                opts[prefix + k] = v
            ksp = PETSc.KSP().create(comm)
            try:
                ksp.setOptionsPrefix(prefix)
                ksp.setOperators(A)
                ksp.setFromOptions()
                ksp.setUp()
            except PETSc.Error as err:
                reason = str(err).strip().splitlines()[-1].split("] ", 1)[-1].strip().replace(prefix, PETSC_PREFIX)
                name = f"PETSc option {key} = {value!r}" if where is None else \
                    f"{where}: -{PETSC_PREFIX}{key}" + (f" {value}" if value else "")
                raise SceneError(f"{name}: rejected by PETSc ({reason})") from None
            finally:
                ksp.destroy()
                for k in merged:
                    opts.delValue(prefix + k)
    finally:
        PETSc.Sys.popErrorHandler()
        A.destroy()


def check_environment_options(comm) -> None:
    """Try the contact solver's options of the user's environment (:func:`environment_options`) before the analysis,
    as :func:`check_petsc_options` tries the run's own: a value PETSc rejects is one line naming PETSC_OPTIONS."""
    check_petsc_options(environment_options(), comm, where="PETSC_OPTIONS")
