"""Is a solved active set a divergence, and what does its mode show (the contact solver's step 3).

A solve of an active set (:meth:`bridgefem.solver.system.ContactSystem.solve_set`) that succeeded can still have
run off along a (nearly) singular direction. :class:`DivergenceTest` decides it:

1. The cap: ``DIVERGENCE_FACTOR`` times the largest displacement (m) of the first solve that moves the structure
   at all (the self-weight with every joint bonded), fixed from then on. A solve whose largest displacement is
   within the cap is no divergence.
2. Beyond it, the *mode* is the solution minus the step's converged start (``origin``), at the pairs
   (:meth:`bridgefem.solver.system.ContactSystem.mode`), with the work on it of the driving load (the live load;
   the self-weight at live-load level 0) and of the whole load, each with its scale |f|_1 |u|_inf, and the power
   of the whole load and the sliding pairs' friction forces (:meth:`bridgefem.laws.base.JointLaw.sliding_forces`:
   s mu lam_n, lam_n of the last solved iterate, N) with its scale (|f|_1 + sum |s mu lam_n|) |u|_inf (all N m);
   the start's gaps narrow the repair to its first contact.
3. :func:`bridgefem.solver.mechanism.judge` gives the verdict on that mode, with what the joint law forbids a mode
   (:meth:`bridgefem.laws.base.JointLaw.mode_rules`): a wrong active set (a failure without proof,
   with the repair of the pairs it pushes into each other, and whether it slides against the friction force), a
   mechanism, or a proof of collapse (only for a linear elastic structure: a yielding fill dissipates on the mode).

The verdict is a pure function of the mode (:mod:`bridgefem.solver.mechanism`, unit-tested on made-up modes); this
module reads the mode and the loads' work off the FE system. How the solver uses the verdicts:
:mod:`bridgefem.solver.recovery`. Every reduction is over the system's communicator: the same verdict
on every MPI rank.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from petsc4py import PETSc

from ..laws.base import ContactState
from .mechanism import Mode, Verdict, judge
from .system import ContactSystem

DIVERGENCE_FACTOR = 1e6  # |u| beyond this multiple of the bonded self-weight response is divergence


class ActiveSetFailure(NamedTuple):
    """A failed solve of an active set: why, whether it shows a mechanism (``proof``: a proved one), and the local
    pairs that an inadmissible diverging mode pushes into each other, to be closed (None: no repair). Made by the
    solver from a checked linear solve that failed (:class:`bridgefem.solver.linear.SolveFailure`: a mechanism when
    singular) or by :meth:`DivergenceTest.failure`."""

    message: str
    mechanism: bool
    repair: np.ndarray | None = None
    proof: bool = False
    unbounded: bool = False  # the solve diverged (along any mode) or was singular
    slides: bool = False  # the solve diverged along a mode that slips pairs against their friction force


@dataclass(eq=False)
class DivergenceTest:
    """The divergence test of the solves of one :class:`bridgefem.solver.system.ContactSystem` (its joint law as it
    stands at each test, its pairs' joint ids for messages) and ``provable``: whether a
    diverging mode can prove collapse (no plastic fill). ``cap`` (m) is set by the first solve that moves the
    structure (module docstring, step 1) and fixed from then on."""

    system: ContactSystem
    provable: bool
    cap: float = np.inf

    def failure(self, level: float, active: ContactState, x: PETSc.Vec, origin: PETSc.Vec, forces: PETSc.Vec
                ) -> ActiveSetFailure | None:
        """None when the solution x of ``active``'s system at live-load level ``level`` (N per unit load factor) is
        within the cap, else the failure its diverging mode x - ``origin`` (the step's converged start) shows
        (:meth:`verdict`, with the normal forces of ``forces``, the last solved iterate). Collective."""
        system = self.system
        u_max = system.norm_inf(x.array[:system.n_u])
        if not np.isfinite(self.cap) and u_max > 0:
            self.cap = DIVERGENCE_FACTOR * u_max  # first solve: every joint bonded, self-weight
        if not u_max > self.cap:  # within the cap (a NaN is the checked solve's to refuse)
            return None
        text = f"diverged: displacement {u_max:.3g} m exceeds the cap {self.cap:.3g} m"
        verdict = self.verdict(level, active, x, origin, forces)
        if verdict.flaw is not None:
            return ActiveSetFailure(f"{text} along an inadmissible mode: {verdict.flaw} (a wrong active set, not a "
                                    "mechanism)", False, verdict.repair, unbounded=True, slides=verdict.slides)
        if verdict.proof:
            return ActiveSetFailure(f"{text} (no equilibrium: mechanism; proof: an admissible rigid-block mode on "
                                    "which the loads do positive work)", True, proof=True)
        return ActiveSetFailure(f"{text} (no equilibrium: mechanism)", True)

    def verdict(self, level: float, active: ContactState, x: PETSc.Vec, origin: PETSc.Vec, forces: PETSc.Vec
                ) -> Verdict:
        """What the diverging direction x - origin of a solve shows (:func:`bridgefem.solver.mechanism.judge`), with the
        power on it of the whole load and of the friction forces of ``active``'s sliding pairs, lam_n those of
        ``forces`` (the last solved iterate, N), and the gaps at ``origin`` for its repair's first contact.
        Collective."""
        system = self.system
        lam_n = system.split(forces)[1][:, 0]
        gap = system.split(origin)[2][:, 0]
        u, d = system.mode(x, origin)
        drive, name = (system.f_live, "live load") if level > 0 else (system.f_dead, "self-weight")
        total = system.loads(level)
        law = system.law
        friction = law.sliding_forces(active, lam_n)  # lam_t of the slip law
        works = system.comm.allreduce(np.array([drive.array @ u, total @ u, total @ u + friction @ d[:, 1],
                                                np.abs(drive.array).sum(), np.abs(total).sum(),
                                                np.abs(total).sum() + np.abs(friction).sum()]))
        scales = works[3:] * system.norm_inf(u)
        return judge(Mode(d, law.mode_rules(active), system.pairs.joint, tuple(works[:2]), tuple(scales[:2]), name,
                          (works[2], scales[2]), gap), provable=self.provable,
                     comm=system.comm)
