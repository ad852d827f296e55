"""The self-weight state: the start of every limit search (:mod:`bridgefem.search.pathfollow`, step 1).

The dead load (the voussoirs', the abutments' and the fill's weight) is applied from the unloaded state, every
joint closed and sticking:

1. The whole self-weight in one step, with the whole iteration budget. A ring whose springings both slide (its
   thrust mu W / 2 at each) translates freely once every pair of both springings slides; the solver's repair then
   sticks the springing that the translation's forces choose, not one chosen by rounding
   (:mod:`bridgefem.solver.mechanism`, step 1), or freezes the last pair on its cone (:mod:`bridgefem.solver.newton`,
   *Pairs on the cone*), so that the one step converges.
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

   - a structure without a plastic fill or a compressive strength whose friction continuation failed without a
     mechanism (or that has no friction): the *tension continuation*, every joint given a tensile strength, first the largest tensile stress
     (N per m of joint) of the bonded self-weight state (every pair closed and holding: one linear solve), so that
     the bonded state is admissible (:meth:`bridgefem.solver.newton.ContactSolver.set_tension`: each pair clamped
     by that stress times its length). From the bonded start the Newton iteration proposes hundreds of pairs
     opening at once on a bridge of many voussoirs on tall piers, and wanders; lowering the tensile strength opens
     the joints in the order of their tension, a few at a time, as cracks form in a real structure.

   Each continuation step keeps ``RAMP_RATIO`` of the excess over the scene's value, the excess dropped after
   ``RAMP_STEPS`` steps; a failed step is halved (at most ``RAMP_HALVINGS`` times in all). A mechanism at a raised
   strength is a mechanism of the scene (a weaker structure carries no more); any other failure is a solver failure
   that names the strength it failed at. When the continuation fails without showing a mechanism where the one step
   did, the one step's outcome is the answer (its mechanism, proved or confirmed by the LP, or not:
   :mod:`bridgefem.analysis.evidence`). The continuation's last state has the pairs that slid as the friction was
   lowered sliding; a first live-load trial that would slide them backwards proposes them sticking
   (:mod:`bridgefem.solver.newton`, *Reversed slips*).
   *Condensed states.* When the friction continuation fails without a mechanism and the search has them
   (``states``: :class:`bridgefem.solver.condensed.CondensedPredictor`, every structure without a fill), the one
   step is solved again from each state of the Tresca fixed point on the joint problem condensed onto the joint
   forces, with ``CONDENSED_TRIAL`` iterations each, until one converges (once per self-weight, not again in its
   retries). On barrels of rings the ring interfaces' active set keeps changing from the bonded start whatever the
   friction (``docs/robustness.md``, *Rings*), while the fixed point's states carry their forces to the precision
   the Newton test asks for.
3. When the static theorem shows that no equilibrium under self-weight exists (``falls``: the rigid blocks under the
   FE's own dead loads need joint tension or cohesion beyond what any converged FE state's tolerances can hide,
   :class:`bridgefem.analysis.evidence.StaticBound`), a failed one step is the answer, a mechanism: no continuation
   or retry can converge where no equilibrium exists.
4. A self-weight that fails without proof is solved again with each of ``SELF_WEIGHT_RETRIES``: a continuation that
   converged some of its steps resumes from its last converged state at the strength it failed at (a converged
   state of the path is an equilibrium of the scene's laws at its strength, whatever setting found it), else the one
   step and the continuation run again from the start.

*Budget.* From every joint closed and sticking the active-set iteration finds the joints' states a few at a time,
so a structure of many joints (a long ring, a barrel, several spans on piers) may need more iterations for its
self-weight than ``[solver] max_iterations`` gives a load step: every self-weight step gets one iteration per joint
of the structure when that is more (:func:`self_weight_budget`); the live-load steps, which start from a converged
state, keep ``max_iterations``.

A fraction of the self-weight would not help: elasticity, unilateral contact, Coulomb friction and a cohesionless
fill are positively homogeneous in the loads, so a fraction of the self-weight from the unloaded state is the same
problem scaled and fails alike. A raised strength at the whole self-weight is what a self-weight fraction is for a
cohesive material (stresses scale with the load, so the weight g with cohesion c is the weight 1 with cohesion c / g).

Safeguards:

- *Continuation through a stronger structure* (step 2): a one step that wanders into mechanisms from the bonded
  start reaches the same equilibrium gradually.
- *The stronger evidence* (step 2): a continuation that fails without a mechanism never replaces the one step's
  mechanism.
- *No continuation where no equilibrium exists* (step 3): the static theorem's answer saves the continuation's and
  the retries' cost.
- *Ramp steps and halvings* ``RAMP_RATIO``, ``RAMP_STEPS``, ``RAMP_HALVINGS``: larger ramp steps save solves on
  most rings but leave a last step that fails on some, so the ramp halves the excess and caps the halvings.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Iterator

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..solver.newton import RETRIES, ContactSolver, Iterate, StepOutcome, retried

RAMP_RATIO = 0.5  # a continuation step keeps this fraction of the raised strength's excess over the scene's
RAMP_STEPS = 7  # steps with a raised strength (the last keeps RAMP_RATIO ** (RAMP_STEPS - 1) of the excess)
RAMP_END = 1.5  # an excess below this multiple of the last raised step's goes to 0 next (between that step's
# excess and the one before it, so that rounding adds no step)
RAMP_HALVINGS = 6  # failed continuation steps halved at most this many times in all
FRICTION_RAISE = 8.0  # the friction continuation starts at this multiple of the joints' Coulomb coefficients
# (mu = 0.3 -> 2.4: the bonded thrust of a thick ring is well inside that cone)

CONDENSED_TRIAL = 10  # Newton iterations of the one step from each condensed state (module docstring, step 2)

SELF_WEIGHT_RETRIES = tuple(s for s in RETRIES if not s.fresh)  # the self-weight starts all closed and sticking
Attempt = Callable[..., StepOutcome]
States = Callable[[float, Iterate], Iterator[PETSc.Vec]]


@dataclass
class Progress:
    """Where the self-weight stands: the one step's outcome (None: not solved yet) and the continuation's last
    converged state ``state`` at strength excess ``done`` (None: no step converged; ``state`` the unloaded one),
    the excess to solve next, the halvings spent and whether the condensed states were tried (module docstring)."""

    state: Iterate
    first: StepOutcome | None = None
    done: float | None = None
    excess: float = 1.0
    halvings: int = 0
    condensed: bool = False  # the condensed states were tried


def self_weight_budget(solver: ContactSolver) -> int:
    """Newton iterations of a self-weight step (module docstring, *Budget*): the solver's ``max_iterations``, or one
    per joint of the structure when it has more. Collective."""
    joints = solver.comm.allreduce(int(np.max(solver.pairs.joint, initial=-1)) + 1, op=MPI.MAX)
    return max(solver.max_iterations, joints)


def carry_self_weight(solver: ContactSolver, attempt: Attempt, falls: bool = False, states: States | None = None
                      ) -> StepOutcome:
    """The self-weight state (module docstring): one step, else the continuation that fits the structure (and the
    condensed ``states``), and when that fails without proof, resumed or both again with each of
    ``SELF_WEIGHT_RETRIES``, every step within :func:`self_weight_budget`; ``falls``: the static theorem shows that
    no equilibrium exists (step 3: the one step's failure is the answer, as a mechanism). ``attempt(level, start)``
    solves and records one step. Returns the last step's outcome."""
    progress = Progress(solver.initial_iterate())
    scene_budget, solver.max_iterations = solver.max_iterations, self_weight_budget(solver)
    try:
        out = _carry(solver, attempt, progress, falls, states)
        if out.converged or out.proved or falls:
            return out
        return retried(solver, lambda: _carry(solver, attempt, progress), out, SELF_WEIGHT_RETRIES)
    finally:
        solver.max_iterations = scene_budget


def _carry(solver: ContactSolver, attempt: Attempt, progress: Progress, falls: bool = False,
           states: States | None = None) -> StepOutcome:
    """One step, else (unless ``falls``) the continuation that fits the structure, then the condensed ``states``;
    a continuation with a converged step resumes."""
    if progress.done is None:
        progress.first = attempt(0.0, solver.initial_iterate())
    first = progress.first
    if first.converged or first.proved:
        return first
    if falls:
        return replace(first, mechanism=True, reason=f"{first.reason}; no equilibrium exists (static theorem: the "
                                                     "rigid blocks under the FE's self-weight cannot stand)")
    fill = solver.material
    if fill is None:
        rough = solver.comm.allreduce(float(np.max(solver.friction, initial=0.0)), op=MPI.MAX) > 0
        out = friction_continuation(solver, attempt, progress) if rough else first
        if not (out.converged or out.mechanism):
            out = tension_continuation(solver, attempt) or out
        if rough and not (out.converged or out.mechanism or progress.condensed) and states is not None:
            progress.condensed = True
            out = condensed_self_weight(attempt, solver.initial_iterate(), states) or out
        return out if out.converged or out.mechanism or not first.mechanism else first  # the stronger evidence
    if fill is not None and not first.mechanism and fill.cohesion < fill.overburden:
        return cohesion_continuation(solver, attempt, progress)
    return first


def condensed_self_weight(attempt: Attempt, start: Iterate, states: States) -> StepOutcome | None:
    """The one step from ``start`` solved again by ``attempt`` (each try recorded) from each of the condensed
    ``states`` (module docstring, step 2, *Condensed states*) with ``CONDENSED_TRIAL`` iterations, until one
    converges: that step; None when none converges. Collective."""
    for x in states(0.0, start):
        out = attempt(0.0, start, predictor=x, iterations=CONDENSED_TRIAL)
        if out.converged:
            return out
    return None


def cohesion_continuation(solver: ContactSolver, attempt: Attempt, progress: Progress | None = None
                          ) -> StepOutcome:
    """The self-weight with the fill's cohesion raised to its overburden stress, then lowered to the scene's
    (from ``progress``, by default from the unloaded state)."""
    fill = solver.material
    target, raised = fill.cohesion, fill.overburden

    def describe() -> str:
        return f"self-weight with the fill's cohesion raised to {fill.material.cohesion:.4g} Pa (continuation to " \
               f"{target:.4g} Pa)"

    try:
        return _ramp(solver, attempt, lambda excess: fill.set_cohesion(target + excess * (raised - target)), describe,
                     progress)
    finally:
        fill.set_cohesion(target)


def friction_continuation(solver: ContactSolver, attempt: Attempt, progress: Progress | None = None
                          ) -> StepOutcome:
    """The self-weight with every joint's friction raised to ``FRICTION_RAISE`` x the scene's, then lowered to it
    (from ``progress``, by default from the unloaded state)."""
    def describe() -> str:
        return f"self-weight with the joints' friction raised to {solver.friction_factor:.4g} x the scene's " \
               "(continuation to 1)"

    try:
        return _ramp(solver, attempt, lambda excess: solver.set_friction_factor(1.0 + excess * (FRICTION_RAISE - 1.0)),
                     describe, progress)
    finally:
        solver.set_friction_factor(1.0)


def tension_continuation(solver: ContactSolver, attempt: Attempt) -> StepOutcome | None:
    """The self-weight with every joint given the tensile strength of the bonded state's largest tensile stress, then
    lowered to none (module docstring, step 2), from the unloaded state; None when no pair of the bonded state is in
    tension, or when the joints crush (the clamp would lower their compressive strength by as much: no stronger
    structure). Collective."""
    if solver.law.crushes:
        return None
    stress = solver.comm.allreduce(float(np.max(solver.bonded_tensile_stress(), initial=0.0)), op=MPI.MAX)
    if stress <= 0.0:
        return None
    raised = stress  # the tensile strength the steps are solved with (N per m)

    def strengthen(excess: float) -> None:
        nonlocal raised
        raised = excess * stress
        solver.set_tension(raised * solver.pairs.length if excess > 0 else None)

    def describe() -> str:
        return f"self-weight with the joints' tensile strength raised to {raised:.4g} N per m (continuation to 0)"

    try:
        return _ramp(solver, attempt, strengthen, describe, Progress(solver.initial_iterate()))
    finally:
        solver.set_tension(None)


def _ramp(solver: ContactSolver, attempt: Attempt, strengthen: Callable[[float], None], describe: Callable[[], str],
          progress: Progress | None) -> StepOutcome:
    """Solve the self-weight with the strength's excess lowered from ``progress.excess`` to 0 in steps (module
    docstring; ``strengthen(excess)`` sets it), each from the last converged state, ``progress`` kept up to date:
    the outcome of the last step, at the scene's strength when it converged, else the failure with the strength it
    failed at (``describe()``)."""
    p = progress or Progress(solver.initial_iterate())
    while True:
        strengthen(p.excess)
        out = attempt(0.0, p.state)
        if out.converged and p.excess == 0.0:
            return out
        if out.converged:
            p.state, p.done = solver.converged_slip_reference(out.iterate), p.excess
            p.excess = p.excess * RAMP_RATIO if p.excess > RAMP_END * RAMP_RATIO ** (RAMP_STEPS - 1) else 0.0
            continue
        if p.done is None or out.proved or p.halvings == RAMP_HALVINGS:
            return replace(out, reason=f"{describe()}: {out.reason}")
        p.excess, p.halvings = 0.5 * (p.done + p.excess), p.halvings + 1
