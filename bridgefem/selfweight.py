"""The self-weight state: the start of every limit search (:mod:`bridgefem.pathfollow`).

1. The whole self-weight in one step from the unloaded state (every joint closed and sticking).
2. When that step fails without proof of a mechanism, a *continuation* reaches the same self-weight through a
   strengthened structure whose strength is then lowered back to the scene's, every step solved from the last
   converged state (incremental friction: a converged state of the path is an equilibrium of the scene's laws):

   - a plastic fill whose cohesion is below its overburden stress (unit weight x fill height): the *cohesion
     continuation*, the fill's cohesion first raised to the overburden stress (which keeps the fill nearly elastic);
   - a ring without a plastic fill: the *friction continuation*, every joint's Coulomb coefficient first raised to
     ``FRICTION_RAISE`` times the scene's. The one-step Newton iteration starts from bonded joints, whose elastic
     thrust can exceed the friction of the springings (a thick semicircle at mu = 0.35); it then proposes slip and
     opening at many joints at once and wanders into mechanisms. Lowering the friction lets the springings slip and
     the joints crack gradually, as the thrust falls to what friction can carry.

   When the continuation fails without showing a mechanism where the one step did, the one step's outcome is the
   answer (its mechanism, proved or confirmed by the LP, or not: :mod:`bridgefem.evidence`). Each continuation step
   keeps ``RAMP_RATIO`` of the excess over the scene's value, the excess dropped after
   ``RAMP_STEPS`` steps; a failed step is halved (at most ``RAMP_HALVINGS`` times in all). A mechanism at a raised
   strength is a mechanism of the scene (a weaker structure carries no more); any other failure is a solver
   failure that names the strength it failed at.

A fraction of the self-weight would not help: elasticity, unilateral contact, Coulomb friction and a cohesionless
fill are positively homogeneous in the loads, so a fraction of the self-weight from the unloaded state is the same
problem scaled and fails alike. A raised strength at the whole self-weight is what a self-weight fraction is for a
cohesive material (stresses scale with the load, so the weight g with cohesion c is the weight 1 with cohesion c / g).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np
from mpi4py import MPI

from .solver import RETRIES, ContactSolver, Iterate, StepOutcome, retried

RAMP_RATIO = 0.5  # a continuation step keeps this fraction of the raised strength's excess over the scene's
RAMP_STEPS = 7  # steps with a raised strength (the last keeps RAMP_RATIO ** (RAMP_STEPS - 1) of the excess)
RAMP_END = 1.5  # an excess below this multiple of the last raised step's goes to 0 next (between that step's
# excess and the one before it, so that rounding adds no step)
RAMP_HALVINGS = 6  # failed continuation steps halved at most this many times in all
FRICTION_RAISE = 8.0  # the friction continuation starts at this multiple of the joints' Coulomb coefficients
# (mu = 0.3 -> 2.4: the bonded thrust of a thick ring is well inside that cone)

SELF_WEIGHT_RETRIES = tuple(s for s in RETRIES if not s.fresh)  # the self-weight starts all closed and sticking
Attempt = Callable[[float, Iterate], StepOutcome]


def carry_self_weight(solver: ContactSolver, attempt: Attempt) -> StepOutcome:
    """The self-weight state (module docstring): one step, else the continuation that fits the structure, and when
    that fails without proof, both again with each of ``SELF_WEIGHT_RETRIES``.
    ``attempt(level, start)`` solves and records one step. Returns the last step's outcome."""
    out = _carry(solver, attempt)
    if out.converged or out.proved:
        return out
    return retried(solver, lambda: _carry(solver, attempt), out, SELF_WEIGHT_RETRIES)


def _carry(solver: ContactSolver, attempt: Attempt) -> StepOutcome:
    """One step, else the continuation that fits the structure."""
    first = attempt(0.0, solver.initial_iterate())
    if first.converged or first.proved:
        return first
    fill = solver.material
    if fill is None and solver.comm.allreduce(float(np.max(solver.friction, initial=0.0)), op=MPI.MAX) > 0:
        out = friction_continuation(solver, attempt)
        return out if out.converged or out.mechanism or not first.mechanism else first  # the stronger evidence
    if fill is not None and not first.mechanism and fill.cohesion < fill.overburden:
        return cohesion_continuation(solver, attempt)
    return first


def cohesion_continuation(solver: ContactSolver, attempt: Attempt) -> StepOutcome:
    """The self-weight with the fill's cohesion raised to its overburden stress, then lowered to the scene's."""
    fill = solver.material
    target, raised = fill.cohesion, fill.overburden

    def describe() -> str:
        return f"self-weight with the fill's cohesion raised to {fill.material.cohesion:.4g} Pa (continuation to " \
               f"{target:.4g} Pa)"

    try:
        return _ramp(solver, attempt, lambda excess: fill.set_cohesion(target + excess * (raised - target)), describe)
    finally:
        fill.set_cohesion(target)


def friction_continuation(solver: ContactSolver, attempt: Attempt) -> StepOutcome:
    """The self-weight with every joint's friction raised to ``FRICTION_RAISE`` x the scene's, then lowered to it."""
    scene = solver.friction

    def describe() -> str:
        return f"self-weight with the joints' friction raised to {solver.friction_factor:.4g} x the scene's " \
               "(continuation to 1)"

    try:
        return _ramp(solver, attempt, lambda excess: solver.set_friction(scene, 1.0 + excess * (FRICTION_RAISE - 1.0)),
                     describe)
    finally:
        solver.set_friction(scene, 1.0)


def _ramp(solver: ContactSolver, attempt: Attempt, strengthen: Callable[[float], None],
          describe: Callable[[], str]) -> StepOutcome:
    """Solve the self-weight with the strength's excess 1 (``strengthen(excess)`` sets it), then lowered to 0 in
    steps (module docstring), each from the last converged state: the outcome of the last step, at the scene's
    strength when it converged, else the failure with the strength it failed at (``describe()``)."""
    state, done, excess, halvings = solver.initial_iterate(), None, 1.0, 0  # done: the last converged excess
    while True:
        strengthen(excess)
        out = attempt(0.0, state)
        if out.converged and excess == 0.0:
            return out
        if out.converged:
            state, done = solver.converged_slip_reference(out.iterate), excess
            excess = excess * RAMP_RATIO if excess > RAMP_END * RAMP_RATIO ** (RAMP_STEPS - 1) else 0.0
            continue
        if done is None or out.proved or halvings == RAMP_HALVINGS:
            return replace(out, reason=f"{describe()}: {out.reason}")
        excess, halvings = 0.5 * (done + excess), halvings + 1
