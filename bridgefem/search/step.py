"""One load step of the limit search, solved, judged and recorded (:mod:`bridgefem.search.pathfollow`): the step
recorder that every stage of the search calls, the flat-curve test of a converged step, and the deflections it
measures. Levels in N per unit load factor, deflections in m (down positive), stiffnesses in N/m (load level over
deflection).

A step is solved by the contact solver (:meth:`bridgefem.solver.newton.ContactSolver.solve_step`) from a converged
start, optionally from an estimate of its displacements and joint forces (the search's *Predictor*), and recorded as
a :class:`bridgefem.search.records.LoadStep` for the observers.

**Flat curve.** A structure whose mechanism is restrained by a soft or yielding fill never loses equilibrium
exactly: its load-deflection curve flattens towards a plateau, the plastic limit. With ``stiffness_drop`` set:

1. the tangent stiffness after self-weight, k0, is measured once (:func:`tangent_stiffness`: the live load's
   response with the joints' active set held and the fill's consistent tangent, one solve);
2. each converged step's secant stiffness s from the state it started from (load increment dP over deflection
   increment) is measured, and the tangent stiffness k of its converged state where s is not below
   ``stiffness_drop`` x k0 or the step starts from the settled state;
3. where the lesser is below ``stiffness_drop`` x k0, the plateau the curve approaches is estimated: the
   exponential approach P = P_inf - A exp(-delta / c), whose tangent falls in proportion to the load still to come
   (P_inf - P = c k), through the step's end and the two converged states before it on the search's path (its
   start and the start of the step that reached it: :func:`plateau_through`), or, where the step starts from the
   settled state, fitted to the step's secant and its end tangent (:func:`plateau_reserve`); the reserve
   R = P_inf - P is the load still to come above the step's end, at least up to the highest level at which a step
   has converged (flat or not: an equilibrium exists there, so the plateau lies no lower);
4. a step whose reserve is within the bracket's tolerance of its level (R <= tolerance x P) counts as failed, with a
   mechanism: the curve is flat at its plateau; but not below a level that a lower bound of the rigid-plastic
   collapse proves carried (``floor``: a fill's conic lower bound, whose static programme is optimal). A step whose
   curve is not softening (its secant not below the one before it, or its tangent not below its secant) has no
   plateau in sight and converges.

On a softening (concave) curve the secant over a step exceeds the tangent at its end, so such a failure is as
decisive as a lost equilibrium, and the bracket rule is unchanged: the bracket closes where the plateau lies within
its tolerance above the step, not where the stiffness first falls below the threshold (on a curve that softens
slowly the plastic limit can lie several per cent above that point). Each measure covers the other's blind spot:
the secant averages the curve over the step, so a long step from below the flat level to above it would converge;
the tangent holds the joints' active set, so where the flattening comes from joints that open or slide further
within the next increment it stays well above the secant, and only the secant sees it. For the same reason the
plateau is fitted to the path's converged points, not to the tangent, wherever the path has them.

**Collapse state.** A structure whose collapse a reading of its converged state shows by itself
(``at_collapse``, :class:`bridgefem.search.records.CollapseCheck`: under an elastic fill, the rings under the loads
the fill transmits at their collapse, evidence 5 of :mod:`bridgefem.analysis.evidence`): each converged live-load
step whose state the reading finds at collapse counts as failed, with a mechanism, after the flat-curve test; the
bracket rule then closes on the first load at which it does, whatever the path beyond.

Safeguards:

- *Secant and tangent*: either alone misses a flat curve (above); the tangent's solve is spent only where the
  secant has not already shown the curve below the threshold, or where the plateau is fitted to it.
- *Threshold before plateau*: the plateau is estimated only below ``stiffness_drop`` x k0, so a curve that bends
  early (joints opening in a still stiff structure) is never read as near its plateau.
- *An equilibrium is a floor* (step 3): an exponential fitted across a knee of the curve (a long stiff step, then a
  short soft one) puts its plateau just above the step; a level at which a step converged, even one counted as flat,
  keeps the bracket from closing below it.
- *A proof is a floor* (step 4): the exponential is an estimate; a curve that creeps (a plastic fill, crushing
  joints whose stress blocks form over large rotations) approaches its plateau more slowly than it, and the fit
  through three nearby states can put the plateau below a level the static theorem proves carried. The bound is
  asked for only where a step would otherwise read flat (it may still be computing), with that step's level. It
  only keeps the estimate from closing the bracket: a search whose steps fail below it (non-associative friction
  or flow can collapse there) ends by the bracket rule as before.
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
from scipy.optimize import brentq

from ..solver.newton import ContactSolver, Iterate, PairPrediction, StepOutcome
from ..status import FLAT_CURVE
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
    tolerance: float  # the bracket's relative width: a plateau within it above a step is reached (*Flat curve*)
    observers: SearchObservers
    steps: list[LoadStep] = field(default_factory=list)
    k_initial: float = math.inf
    at_collapse: Callable[[float, Iterate], tuple[bool, str]] | None = None
    floor: Callable[[float], float | None] | None = None  # a level proved carried (*Flat curve*, step 4); collective
    # the converged live-load states of the path: level -> (its deflection in m, the level of the state its step
    # started from; None for the settled state)
    path: dict[float, tuple[float, float | None]] = field(default_factory=dict)
    highest: float = 0.0  # the highest live-load level at which a step converged, flat or not

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
            self.highest = max(self.highest, level)
            if start_level not in self.path:  # the settled state, or a start the path has not recorded
                self.path[start_level] = (self.deflection(start), None)
            flat = self._flat(level, start_level, reached, out)
            out, reached = (flat, None) if flat is not None else (out, reached)
        if reached is not None and self.at_collapse is not None and level > 0:
            collapsed, check = self.at_collapse(level, out.iterate)
            if collapsed:
                out, reached = StepOutcome(False, f"the converged state is a collapse state: {check}", out.iterations,
                                           out.residual, out.factorisations, mechanism=True, equilibrium=True), None
        step = LoadStep(len(self.steps), level, out.converged, out.reason, out.iterations, out.factorisations,
                        out.residual, reached, out.counts, time.perf_counter() - t0, solver.movement,
                        _raised_cohesion(solver), out.mechanism,
                        solver.friction_factor if solver.friction_factor != 1.0 else None)
        self.steps.append(step)
        self.observers.report(step)
        if step.converged:
            if self.k_initial < math.inf and level > 0:
                self.path[level] = (reached, start_level)
            self.observers.converged(step, out.iterate)
        return out

    def _flat(self, level: float, start_level: float, reached: float, out: StepOutcome) -> StepOutcome | None:
        """The converged ``out`` at ``level`` (its deflection ``reached``, m) as a failed step with a mechanism when
        the load-deflection curve is flat there (module docstring, *Flat curve*): its secant stiffness from the
        converged state at ``start_level`` (N per unit load factor) or its tangent stiffness below ``stiffness_drop``
        x ``k_initial``, and the curve's plateau within ``tolerance`` x ``level`` above it, ``level`` not below the
        ``floor``; else None."""
        start, before = self.path[start_level]
        load, rise = level - start_level, reached - start
        secant = load / rise if rise > 0 else math.inf
        threshold = self.stiffness_drop * self.k_initial
        # the tangent (one solve) where the secant has not shown the curve below the threshold, or where the plateau
        # is fitted to it (a step from the settled state)
        needed = secant >= threshold or before is None
        tangent = tangent_stiffness(self.solver, self.deflection, out.iterate) if needed else None
        if min(secant, tangent or math.inf) >= threshold:
            return None
        if before is None:
            reserve, fit = plateau_reserve(load, secant, tangent or 0.0), "the step's secant and end tangent"
        else:
            reserve = plateau_through((before, self.path[before][0]), (start_level, start), (level, reached))
            fit = "the path's last three converged states"
        reserve = max(reserve, self.highest - level)
        if reserve > self.tolerance * level or (self.floor is not None and level < (self.floor(level) or 0.0)):
            return None
        at_end = f"tangent {tangent:.3g} N/m at its end" if tangent else (
            "no tangent at its end" if needed else "tangent not needed")
        return StepOutcome(False, f"{FLAT_CURVE}: secant stiffness {secant:.3g} N/m over the step, "
                                  f"{at_end}, below {self.stiffness_drop:g} x the initial {self.k_initial:.3g} "
                                  f"N/m; its plateau, fitted to {fit}, {reserve:.3g} N per unit load factor above "
                                  f"it, within the tolerance (collapse)", out.iterations, out.residual,
                           out.factorisations, mechanism=True, equilibrium=True)


def plateau_through(first: tuple[float, float], second: tuple[float, float], third: tuple[float, float]) -> float:
    """The load still to come (N per unit load factor) above the ``third`` of three points (load level, deflection
    in m) of a load-deflection curve, rising in both, on the exponential approach to a plateau through them,
    P = P_inf - A exp(-delta / c) (module docstring, *Flat curve*, step 3): with the increments (a, u) and (b, v)
    between them, 1 / c = L solves exp(-u L) (1 - exp(-v L)) / (1 - exp(-u L)) = b / a, and the reserve is
    b / (exp(v L) - 1). inf where the second secant b / v is not below the first a / u (no softening) or the points
    do not rise."""
    (p0, d0), (p1, d1), (p2, d2) = first, second, third
    a, u, b, v = p1 - p0, d1 - d0, p2 - p1, d2 - d1
    if min(a, u, b, v) <= 0 or (b / v) >= (a / u) * (1.0 - 1e-12):
        return math.inf

    def excess(rate: float) -> float:  # the model's b / a at 1 / c = rate, less the points'; falls from v/u - b/a
        return math.exp(-u * rate) * -math.expm1(-v * rate) / -math.expm1(-u * rate) - b / a

    low, high = 1e-9 / max(u, v), 1.0 / min(u, v)
    while excess(high) > 0:
        high *= 2.0
    rate = brentq(excess, low, high, xtol=1e-300, rtol=1e-13) if excess(low) > 0 else low
    x = v * rate
    return b * math.exp(-x) / -math.expm1(-x)  # b / (exp(x) - 1), without overflow where the curve is flat


def plateau_reserve(load: float, secant: float, tangent: float) -> float:
    """The load still to come (N per unit load factor) above the end of a converged step of ``load`` (its increment,
    N per unit load factor) on the exponential approach to a plateau, P = P_inf (1 - exp(-delta / c)), fitted to the
    step's ``secant`` stiffness and the ``tangent`` stiffness at its end (N/m): R = P_inf - P_end solves
    ln(1 + x) / x = tangent / secant with x = load / R (module docstring, *Flat curve*, step 3). 0 where the tangent
    is 0 (the curve at its peak), inf where it is not below the secant (the curve not softening over the step)."""
    ratio = tangent / secant if secant < math.inf else 0.0
    if ratio >= 1.0:
        return math.inf
    if ratio <= 0.0:
        return 0.0
    if ratio > 1.0 - 1e-8:  # ln(1 + x) / x = 1 - x / 2 + O(x^2): x = 2 (1 - ratio)
        return load / (2.0 * (1.0 - ratio))
    # ln(1 + x) - ratio x is positive at x = 1 - ratio ((1 - ratio)^2 / 2 + ...) and negative at the upper end
    x = brentq(lambda x: math.log1p(x) - ratio * x, 1.0 - ratio, 2.0 / ratio * math.log(2.0 / ratio) + 1.0,
               xtol=1e-14, rtol=1e-12)
    return load / x


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
