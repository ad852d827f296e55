"""Why a barrel's self-weight step fails: the one step of the self-weight (every joint closed and sticking at the
start, the whole dead load at once: :mod:`bridgefem.search.selfweight`, step 1) solved on a scene's FE model under
changed joint laws, one at a time, printing for each whether it converged, its active-set iterations and how many
pairs are open and how many changed state at each of its last iterations.

1. The model is built as ``bridgefem run`` builds it (:func:`bridgefem.analysis.build.build_model`).
2. For each ``--friction`` factor f every Coulomb coefficient is f x the scene's (f = 1e6: every closed pair sticks,
   so that what remains is the normal contact alone); for each ``--ring-constant`` factor the ring interfaces'
   Alart-Curnier constants are that many times the model's.
3. Each variant solves the one step with ``--iterations`` active-set iterations (default: the self-weight's own
   budget, :func:`bridgefem.search.selfweight.self_weight_budget`).

Run on a barrel of the rings campaign (``benchmarks/campaign.py --rings --check-only`` writes its scenes):

    ./run python benchmarks/barrel_self_weight.py SCENE.toml --friction 1 8 1e6 --ring-constant 1 1e-2

Serial (one process): the counts are the solver's, not the machine's.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

from bridgefem.analysis.build import Clock, build_model
from bridgefem.scene.reader import load_scene
from bridgefem.search.selfweight import self_weight_budget

SHOWN = 5  # iterations whose counts are printed, the last ones of each variant


def one_step(solver, iterations: int) -> tuple[bool, int, str, list[tuple[int, int]]]:
    """The self-weight's one step from the bonded start: converged, iterations, why it ended, and per iteration
    (open pairs, pairs changed from the iteration before)."""
    counts, previous = [], [None]
    solve = solver._solve_set

    def counted(step):
        failure = solve(step)
        state = step.active.state.copy()
        changed = -1 if previous[0] is None else int((previous[0] != state).sum())
        previous[0] = state
        counts.append((int((state == solver.law.OPEN).sum()), changed))
        return failure

    solver._solve_set, solver.max_iterations = counted, iterations
    try:
        out = solver.solve_step(0.0, solver.initial_iterate())
    finally:
        del solver._solve_set
    return out.converged, out.iterations, out.reason, counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("--friction", type=float, nargs="+", default=[1.0])
    parser.add_argument("--ring-constant", type=float, nargs="+", default=[1.0])
    parser.add_argument("--iterations", type=int, default=None)
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    fe = build_model(load_scene(args.scene), comm, None, lambda name: None, Clock(comm))
    solver, law = fe.solver, fe.solver.law
    ring = np.asarray(fe.pairs.kind) == "ring"
    print(f"{args.scene}: {solver.system.n_u} displacement unknowns, {len(fe.pairs)} pairs ({ring.sum()} on ring "
          "interfaces)")
    constants = law.c.copy()
    for friction in args.friction:
        for scale in args.ring_constant:
            solver.set_friction_factor(friction)
            law.c = np.where(ring, scale * constants, constants)
            start = time.perf_counter()
            converged, iterations, reason, counts = one_step(solver, args.iterations or self_weight_budget(solver))
            tail = ", ".join(f"{o} open / {c} changed" for o, c in counts[-SHOWN:])
            print(f"friction x {friction:g}, ring constants x {scale:g}: "
                  f"{'converged' if converged else 'failed'} after {iterations} iterations "
                  f"({time.perf_counter() - start:.1f} s){'' if converged else ': ' + reason[:100]}\n  last: {tail}")
    law.c = constants
    solver.set_friction_factor(1.0)


if __name__ == "__main__":
    main()
