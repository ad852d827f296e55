"""One load step of the limit search, solved, judged and recorded (:mod:`bridgefem.search.pathfollow`): the step
recorder that every stage of the search calls, the flat-curve test of a converged step, and the deflections it
measures. Levels in N per unit load factor, deflections in m (down positive), stiffnesses in N/m (load level over
deflection).

A step is solved by the contact solver (:meth:`bridgefem.solver.newton.ContactSolver.solve_step`) from a converged
start, optionally from an estimate of its displacements and joint forces (the search's *Predictor*), and recorded as
a :class:`bridgefem.search.records.LoadStep` for the observers.

**Flat curve.** A structure whose mechanism is restrained by a soft or yielding fill never loses equilibrium
exactly: its load-deflection curve flattens. With ``stiffness_drop`` set:

1. the tangent stiffness after self-weight, k0, is measured once (:func:`tangent_stiffness`: the live load's
   response with the joints' active set held and the fill's consistent tangent, one solve);
2. each converged step's secant stiffness from the state it started from (load over deflection increment) is
   compared with ``stiffness_drop`` x k0, and where the secant is not below it, so is the tangent stiffness of its
   converged state;
3. a step with either below counts as failed, with a mechanism.

On a softening (concave) curve the secant over a step exceeds the tangent at its end, so such a failure is as
decisive as a lost equilibrium, and the bracket rule is unchanged. Each measure covers the other's blind spot: the
secant averages the curve over the step, so a long step from below the flat level to above it would converge; the
tangent holds the joints' active set, so where the flattening comes from joints that open or slide further within
the next increment it stays well above the secant, and only the secant sees it.

**Collapse state.** A structure whose collapse a reading of its converged state shows by itself
(``at_collapse``, :class:`bridgefem.search.records.CollapseCheck`: under an elastic fill, the rings under the loads
the fill transmits at their collapse, evidence 5 of :mod:`bridgefem.analysis.evidence`): each converged live-load
step whose state the reading finds at collapse counts as failed, with a mechanism, after the flat-curve test; the
bracket rule then closes on the first load at which it does, whatever the path beyond.

Safeguards:

- *Secant and tangent*: either alone misses a flat curve (above); the tangent's solve is spent only where the
  secant has not already shown the curve flat.
- *Displaced start keeps the converged state's active set*: an estimate changes where the Newton iteration starts,
  never what counts as converged.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from petsc4py import PETSc

from ..solver.newton import ContactSolver, Iterate, PairPrediction, StepOutcome
from .records import LoadStep, SearchObservers


@dataclass
class StepRecorder:
    """Solves and records one load step (``LoadStep``), as ``attempt(level, start, ...)`` for the self-weight, the
    support movement and the live-load search; collective. ``k_initial``: the tangent stiffness after self-weight
    (N/m; inf: no flatness check, module docstring, *Flat curve*); ``at_collapse(level, state)``: whether a converged
    live-load state is a collapse state by itself, with the check in words (None: no such reading, module
    docstring, *Collapse state*)."""

    solver: ContactSolver
    deflection: Callable[[Iterate], float]
    stiffness_drop: float
    observers: SearchObservers
    steps: list[LoadStep] = field(default_factory=list)
    k_initial: float = math.inf
    at_collapse: Callable[[float, Iterate], tuple[bool, str]] | None = None

    def __call__(self, level: float, start: Iterate, start_level: float = 0.0, *,
                 predictor: PETSc.Vec | PairPrediction | None = None,
                 give_up: bool = False, iterations: int | None = None, estimate: PETSc.Vec | None = None
                 ) -> StepOutcome:
        """Solve ``level`` from the converged ``start`` at ``start_level`` (N per unit load factor), starting from
        the ``estimate``'s displacements and joint forces when given (:func:`_displaced`), and record the step;
        ``predictor``, ``give_up`` and ``iterations`` go to
        :meth:`bridgefem.solver.newton.ContactSolver.solve_step`."""
        t0 = time.perf_counter()
        begin = _displaced(start, estimate) if estimate is not None else start
        solver = self.solver
        out = solver.solve_step(level, begin, predictor, give_up, iterations)
        reached = self.deflection(out.iterate) if out.converged else None
        if reached is not None and self.k_initial < math.inf:
            flat = self._flat(level - start_level, reached - self.deflection(start), out)
            out, reached = (flat, None) if flat is not None else (out, reached)
        if reached is not None and self.at_collapse is not None and level > 0:
            collapsed, check = self.at_collapse(level, out.iterate)
            if collapsed:
                out, reached = StepOutcome(False, f"the converged state is a collapse state: {check}", out.iterations,
                                           out.residual, out.factorisations, mechanism=True), None
        step = LoadStep(len(self.steps), level, out.converged, out.reason, out.iterations, out.factorisations,
                        out.residual, reached, out.counts, time.perf_counter() - t0, solver.movement,
                        _raised_cohesion(solver), out.mechanism,
                        solver.friction_factor if solver.friction_factor != 1.0 else None)
        self.steps.append(step)
        self.observers.report(step)
        if step.converged:
            self.observers.converged(step, out.iterate)
        return out

    def _flat(self, load: float, rise: float, out: StepOutcome) -> StepOutcome | None:
        """The converged ``out`` as a failed step with a mechanism when the load-deflection curve is flat there
        (module docstring, *Flat curve*): its secant stiffness over the step (``load`` in N per unit load factor
        over the deflection ``rise`` in m) or its tangent stiffness below ``stiffness_drop`` x ``k_initial``; else
        None."""
        secant = load / rise if rise > 0 else math.inf
        flat = self.stiffness_drop * self.k_initial
        # the tangent (one solve) only where the secant has not already shown the curve flat
        tangent = tangent_stiffness(self.solver, self.deflection, out.iterate) if secant >= flat else None
        if min(secant, tangent or math.inf) >= flat:
            return None
        at_end = f"tangent {tangent:.3g} N/m at its end" if tangent else "tangent not needed"
        return StepOutcome(False, f"load-deflection curve flat: secant stiffness {secant:.3g} N/m over the step, "
                                  f"{at_end}: the lesser is below {self.stiffness_drop:g} x the initial "
                                  f"{self.k_initial:.3g} N/m (collapse)", out.iterations, out.residual,
                           out.factorisations, mechanism=True)


def _displaced(state: Iterate, predictor: PETSc.Vec) -> Iterate:
    """The converged ``state`` with its displacements and joint forces replaced by the ``predictor``'s (the Newton
    iteration's first linearisation point, and the origin of the modes its diverging solves are judged by, which
    are beyond a million times the self-weight response); its active set, slip reference and plastic strain stay the
    converged state's (:mod:`bridgefem.search.pathfollow`, *Predictor*)."""
    return Iterate(predictor, state.active, state.slip_ref, state.plastic_strain)


def tangent_stiffness(solver: ContactSolver, deflection: Callable[[Iterate], float], state: Iterate
                       ) -> float | None:
    """Tangent stiffness dP/d(delta) (N/m) of the load-deflection curve at the converged ``state`` with its joints'
    active set held (:meth:`ContactSolver.live_load_tangent`; call it right after the step that reached the state):
    one solve. None when that system cannot be solved or its deflection is not positive (no tangent). Collective."""
    tangent = solver.live_load_tangent(state)
    compliance = deflection(tangent) if tangent is not None else 0.0
    return 1.0 / compliance if compliance > 0 else None


def _raised_cohesion(solver: ContactSolver) -> float | None:
    """The fill's cohesion (Pa) while the self-weight's cohesion continuation raises it, else None."""
    fill = solver.material
    if fill is None or fill.material.cohesion == fill.cohesion:
        return None
    return fill.material.cohesion


def monitor_deflection(solver: ContactSolver, monitor: np.ndarray) -> Callable[[Iterate], float]:
    """Mean downward displacement (m) of the monitored nodes (blocked owned indices) over all ranks."""
    comm = solver.comm

    def deflection(it: Iterate) -> float:
        u = it.x.array[:solver.n_u]
        local = (-u[2 * monitor + 1].sum(), len(monitor))
        total, count = comm.allreduce(np.array(local, dtype=float))
        return float(total / count) if count else float("nan")

    return deflection
