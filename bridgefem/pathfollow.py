"""Load incrementation to the limit load: self-weight first, then the live load until no equilibrium exists.

The live-load level grows with adaptive steps from the last converged state: a failed step is halved and
retried from there, a converged one keeps its size (doubled after an easy step). The limit load is the
bracket [last converged, first failed] once the failing step is within ``tolerance`` of the last converged
level: a failure reached by a large step proves nothing, so it is never used as a bound. Failed steps are
discarded (incremental friction makes the response path dependent).

Statuses: "limit load found", "unstable under self-weight", "stable under self-weight" (no live load),
"no collapse up to the maximum load (locked)", "solver failure: <reason>" (a failure that shows no mechanism,
or a bracket not closed within the step budget).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .solver import ContactSolver, Iterate, StepOutcome

LIMIT_FOUND = "limit load found"
UNSTABLE = "unstable under self-weight"
LOCKED = "no collapse up to the maximum load (locked)"
STABLE = "stable under self-weight"


@dataclass
class LoadStep:
    """One attempted step; ``level`` in N per unit load factor, ``deflection`` (m, down positive) under the load."""

    index: int
    level: float
    converged: bool
    reason: str
    iterations: int
    factorisations: int
    residual: float
    deflection: float | None
    counts: dict
    seconds: float


@dataclass
class LimitSearch:
    """Outcome of the search; ``lower``/``upper`` bracket the limit level (N per unit load factor)."""

    status: str
    lower: float
    upper: float | None
    tolerance: float
    steps: list[LoadStep] = field(default_factory=list)
    last: Iterate | None = None
    failure: str = ""


def find_limit_load(solver: ContactSolver, deflection: Callable[[Iterate], float], *, tolerance: float,
                    initial_step: float, max_load: float, max_steps: int,
                    report: Callable[[LoadStep], None] = lambda s: None) -> LimitSearch:
    """Run self-weight then the live-load search (all arguments in N except the relative ``tolerance``)."""
    steps: list[LoadStep] = []

    def attempt(level: float, start: Iterate) -> StepOutcome:
        t0 = time.perf_counter()
        out = solver.solve_step(level, start)
        step = LoadStep(len(steps), level, out.converged, out.reason, out.iterations, out.factorisations,
                        out.residual, deflection(out.iterate) if out.converged else None, out.counts,
                        time.perf_counter() - t0)
        steps.append(step)
        report(step)
        return out

    first = attempt(0.0, solver.initial_iterate())
    if not first.converged:
        status = UNSTABLE if first.mechanism else f"solver failure: {first.reason}"
        return LimitSearch(status, 0.0, 0.0 if first.mechanism else None, tolerance, steps, None, first.reason)
    state = solver.converged_slip_reference(first.iterate)
    if max_load <= 0:
        return LimitSearch(STABLE, 0.0, None, tolerance, steps, state)
    lower, step, recent_failure = 0.0, initial_step, False
    while len(steps) < max_steps:
        if lower >= max_load:
            return LimitSearch(LOCKED, lower, None, tolerance, steps, state)
        trial = min(lower + step, max_load)
        out = attempt(trial, state)
        if out.converged:
            lower, state = trial, solver.converged_slip_reference(out.iterate)
            if out.iterations <= 4 and not recent_failure:
                step *= 2.0
            recent_failure = False
        elif trial - lower <= tolerance * max(lower, 1e-9 * initial_step):
            status = LIMIT_FOUND if out.mechanism else f"solver failure: {out.reason}"
            return LimitSearch(status, lower, trial, tolerance, steps, state, out.reason)
        else:
            step, recent_failure = 0.5 * (trial - lower), True
    status = f"solver failure: bracket not closed within {max_steps} load steps"
    return LimitSearch(status, lower, None, tolerance, steps, state)


def monitor_deflection(solver: ContactSolver, monitor: np.ndarray) -> Callable[[Iterate], float]:
    """Mean downward displacement (m) of the monitored nodes (blocked owned indices) over all ranks."""
    comm = solver.comm

    def deflection(it: Iterate) -> float:
        u = it.x.array[:solver.n_u]
        local = (-u[2 * monitor + 1].sum(), len(monitor))
        total, count = comm.allreduce(np.array(local, dtype=float))
        return float(total / count) if count else float("nan")

    return deflection
