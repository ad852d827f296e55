"""The verdicts of a run: one vocabulary for the FE limit search, the rigid-block LP and the command line.

A status is written as its value; a solver failure carries its reason after a colon
(``"solver failure: <reason>"``, :meth:`Status.failure`), and :meth:`Status.of` reads any status text back.
The command line exits with :attr:`Status.exit_code`: 0 for a verdict, 1 for a solver failure.
"""
from __future__ import annotations

from enum import StrEnum


class Status(StrEnum):
    """What a limit analysis found."""

    LIMIT = "limit load found"  # a bracket [lower, upper]: equilibrium at lower, none at upper
    UNSTABLE = "unstable under self-weight"  # no equilibrium without live load
    STABLE = "stable under self-weight"  # equilibrium, and no live load to apply
    LOCKED = "no collapse up to the maximum load (locked)"  # the FE search reached its maximum load
    UNBOUNDED = "no collapse (unbounded)"  # the LP: no live load collapses the structure
    FAILURE = "solver failure"  # no verdict: the reason follows the colon

    @staticmethod
    def failure(reason: str) -> str:
        """The status text of a solver failure: ``"solver failure: <reason>"``."""
        return f"{Status.FAILURE}: {reason}"

    @classmethod
    def of(cls, text: str) -> "Status":
        """The status of a status text (a failure's reason dropped); ValueError for an unknown text."""
        return cls.FAILURE if text.startswith(cls.FAILURE + ":") else cls(text)

    @property
    def exit_code(self) -> int:
        """The command line's exit code: 1 for a solver failure, 0 for any verdict."""
        return 1 if self is Status.FAILURE else 0

    @property
    def no_collapse(self) -> bool:
        """Locked (FE) or unbounded (LP): no live load found that collapses the structure."""
        return self in (Status.LOCKED, Status.UNBOUNDED)


FLAT_CURVE = "load-deflection curve flat"  # opens the reason of a step read off a flat curve (bridgefem.search.step,
# *Flat curve*), read back by the verdict under a fill
RINGS_UNDER_FILL = "the rings under the loads the fill transmits"  # names evidence 5 of
# bridgefem.analysis.evidence in a failure's reason, read back by the verdict and the command line
COLLAPSE_END = "the bracket's upper end is its rigid blocks' collapse level"  # a bracket that a collapse state ends
# after every solver setting failed its closing trial (bridgefem.search.target, *Collapse state*, step 5), in the
# failure's reason, read back by the command line and the warnings
LINEAR_SOLVER_FAILED = "linear solver failed"  # a failed linear solve in a failure's reason (its factorisation or
# its PETSc options: bridgefem.solver.linear), read back by the re-runs on a finer mesh (bridgefem.analysis.refinement)
