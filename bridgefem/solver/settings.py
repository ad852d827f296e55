"""The algorithmic settings of a load step and the retries of a step that failed without proof.

A setting decides only how the Newton iteration searches, never what counts as converged or as a proof: a retry
changes how often the method finds the answer, never what counts as one (:mod:`bridgefem.solver.newton`, *Retries*).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Setting:
    """The algorithmic choices of a load step: ``scale`` multiplies the Alart-Curnier constants (they weigh forces
    against displacements in the classification only), ``fresh`` starts from every joint closed and holding instead
    of the converged start's active set, ``patient`` lets damping chains recover without limit, ``line_search``
    backtracks every Newton step of a ring without a plastic fill too (a damped semismooth Newton method on the joint
    law's residual), ``through_stick`` proposes a reversed slip as holding (without it, as the law classifies it)."""

    scale: float = 1.0
    fresh: bool = False
    patient: bool = False
    line_search: bool = False
    through_stick: bool = True


DEFAULT_SETTING = Setting()
RETRIES = (Setting(fresh=True), Setting(scale=10.0), Setting(scale=0.1), Setting(line_search=True),
           Setting(fresh=True, patient=True, through_stick=False))
"""The settings a load step that failed without proof is solved again with, in this order."""
