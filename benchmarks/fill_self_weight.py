"""Why a Mohr-Coulomb fill's self-weight fails: the self-weight of a scene (:mod:`bridgefem.search.selfweight`: the one
step, the cohesion continuation, the retries) solved as the search solves it, printing every step tried and, for a
failed one, what its last iterations changed and which pairs changed most often.

1. The model is built as ``bridgefem run`` builds it (:func:`bridgefem.analysis.build.build_model`); ``--elements``
   overrides ``[mesh] elements_through_thickness``.
2. The self-weight runs through :func:`bridgefem.search.selfweight.carry_self_weight`; each step tried prints the
   fill's cohesion (Pa), whether it converged, its Newton iterations, seconds and the pairs open / stick / slip.
3. A failed step prints its last ``SHOWN`` iterations: the arch-fill interface pairs and the ring's joint pairs that
   the iteration's proposal changed, the fill's quadrature points whose plastic strain differs from the step's start,
   and the scaled out-of-balance force; then the ``CHURNING`` pairs changed by the most proposals (local index, joint
   or ``F`` for the arch-fill interface, position in m, proposals). A repeating pattern of the residual is a cycle.

Run on a campaign scene (``benchmarks/campaign.py`` writes its scenes):

    ./run nice python benchmarks/fill_self_weight.py /tmp/c41/scene_0015/scene.toml --elements 4

Serial (one process): the counts are the solver's, not the machine's.
"""
from __future__ import annotations

import argparse
import time
import tomllib

import numpy as np
from mpi4py import MPI

from bridgefem.analysis.build import Clock, build_model
from bridgefem.fe.pairs import ARCH_FILL
from bridgefem.scene.reader import scene_from_dict
from bridgefem.search.selfweight import carry_self_weight

SHOWN = 8  # last iterations printed of a failed step
CHURNING = 10  # pairs printed of a failed step, those its proposals changed most often


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("--elements", type=int, default=None, help="elements through the ring's thickness")
    args = parser.parse_args()
    with open(args.scene, "rb") as f:
        d = tomllib.load(f)
    if args.elements:
        d.setdefault("mesh", {})["elements_through_thickness"] = args.elements
    comm = MPI.COMM_WORLD
    start = time.perf_counter()
    fe = build_model(scene_from_dict(d), comm, None, lambda name: None, Clock(comm))
    solver, fill, pairs = fe.solver, fe.solver.material, fe.pairs
    interface = pairs.joint == ARCH_FILL
    print(f"{args.scene}: {solver.system.n_u} displacement unknowns, {len(pairs)} pairs ({interface.sum()} arch-fill), "
          f"overburden {fill.overburden:.4g} Pa, scene's cohesion {fill.cohesion:.4g} Pa")
    rows, previous, solve = [], [None], solver._solve_set

    def counted(step):
        if previous[0] is not None:
            changed = step.active.differs(previous[0])
            plastic = np.abs(step.plastic - step.task.start.plastic_strain).max(axis=1) > 0
            rows.append((step.it, int(changed[interface].sum()), int(changed[~interface].sum()), int(plastic.sum()),
                         step.residual, changed))
        previous[0] = step.active.copy()
        return solve(step)

    def attempt(level, begin, **kwargs):
        rows.clear()
        previous[0] = None
        t = time.perf_counter()
        out = solver.solve_step(level, begin, **kwargs)
        states = "/".join(str(out.counts.get(k, "-")) for k in ("open", "stick", "slip"))
        ending = f"  open/stick/slip {states}" if out.converged else f": {out.reason}"
        print(f"cohesion {fill.material.cohesion:10.1f} Pa: {'converged' if out.converged else 'failed'} after "
              f"{out.iterations} iterations ({time.perf_counter() - t:.1f} s){ending}")
        if not out.converged and rows:
            for it, arch_fill, joints, plastic, residual, _ in rows[-SHOWN:]:
                print(f"  iteration {it}: {arch_fill} arch-fill and {joints} joint pairs changed, {plastic} fill "
                      f"points yielding, residual {residual:.2e}")
            churn = np.sum([r[5] for r in rows], axis=0)
            top = np.argsort(-churn, kind="stable")[:CHURNING]
            print("  churning: " + ", ".join(
                f"{k} ({'F' if interface[k] else pairs.joint[k]}, {pairs.position[k]:.2f} m) x{churn[k]}"
                for k in top if churn[k] > 0))
        return out

    solver._solve_set = counted
    try:
        out = carry_self_weight(solver, attempt)
    finally:
        del solver._solve_set
    print(f"self-weight {'carried' if out.converged else 'failed: ' + out.reason} "
          f"({time.perf_counter() - start:.1f} s in all)")


if __name__ == "__main__":
    main()
