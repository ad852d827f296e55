"""A re-run's trials start from its coarser run's load path (:mod:`bridgefem.analysis.refinement`: re-runs on a
finer mesh; :mod:`bridgefem.search.pathfollow`, *Predictor*).

A bare ring re-run with twice the elements through the thickness has the same joints, each with twice the node
pairs, and a limit close to the coarser run's. Along most of the path the joints that open and slide at a level are,
joint by joint, where the coarser run's opened and slid at that level. Levels are in N per unit load factor.

1. :class:`CoarserPath` keeps the coarser run's converged states as joint tractions (N/m) and relative
   displacements (m) along each joint, linear between its converged levels.
2. For a trial at ``trial`` from the finer run's converged state at ``lower`` it proposes that state plus the
   coarser path's increment over the step, interpolated along each joint at the finer pairs,

       lam = lam_f(lower) + [t_c(trial) - t_c(lower)] l_f,    d = d_f(lower) + [d_c(trial) - d_c(lower)],

   with l_f the finer pairs' tributary lengths (m).
3. The proposal is the Newton method's first active set (:class:`bridgefem.solver.newton.PairPrediction`), never
   what counts as converged.

Safeguards:

- *The increment, not the coarser state*: the two meshes' elastic joint displacements differ, and a sticking pair
  would be proposed to slip by that difference.
- *The whole path, never beyond it*: near its end the coarser run slides on its own collapse mechanism at its own
  level, which the finer mesh may move; that mechanism's joints are still where the finer run's open and slide, so
  the path starts trials up to its last converged level, and beyond it none is extrapolated.
- *Live load only*: the self-weight starts as on any run; from the coarser run's self-weight state a re-run's
  self-weight can spend its budget unconverged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from mpi4py import MPI

from ..fe.pairs import JointPairs
from ..solver.newton import ContactSolver, Iterate, PairPrediction


@dataclass(frozen=True)
class CoarserPath:
    """The converged states of a bare ring's run, for a re-run on a finer mesh (module docstring). ``levels``: the
    states' live-load levels, increasing (N per unit load factor; the first 0, the settled self-weight state);
    ``keys``: the ring's pairs sorted by joint, then position along it (joint x ``stride`` + position, m);
    ``traction`` (N/m) and ``d`` (m): per state and sorted pair, (normal, tangential)."""

    levels: np.ndarray
    keys: np.ndarray
    stride: float
    traction: np.ndarray
    d: np.ndarray

    @classmethod
    def of(cls, pairs: JointPairs, states: list[tuple[float, np.ndarray, np.ndarray]], comm: MPI.Comm
           ) -> "CoarserPath | None":
        """The path of a run's converged ``states``, each (level, lam, d) of this rank's ``pairs`` (N, m) in the order
        they converged (a level reached twice: the later state; self-weight states at level 0: the last), gathered
        from every rank; None without a live-load state. Collective."""
        by_level = {level: (lam, d) for level, lam, d in states}
        levels = np.array(sorted(by_level))
        if len(levels) < 2 or levels[0] != 0.0:
            return None
        ring = pairs.joint >= 0
        local = [np.stack([by_level[level][k][ring] for level in levels]) for k in (0, 1)]
        length = np.concatenate(comm.allgather(pairs.length[ring]))
        traction, d = (np.concatenate(comm.allgather(a), axis=1) for a in local)
        joint, position = (np.concatenate(comm.allgather(a[ring])) for a in (pairs.joint, pairs.position))
        stride = 2.0 * float(position.max()) + 1.0
        keys = joint * stride + position
        order = np.argsort(keys, kind="stable")
        return cls(levels, keys[order], stride, traction[:, order] / length[order, None], d[:, order])

    def at(self, level: float) -> tuple[np.ndarray, np.ndarray]:
        """The path's tractions (N/m) and relative displacements (m) at ``level``, linear between its converged
        levels (within them)."""
        i = int(np.clip(np.searchsorted(self.levels, level) - 1, 0, len(self.levels) - 2))
        w = (level - self.levels[i]) / (self.levels[i + 1] - self.levels[i])
        return ((1 - w) * self.traction[i] + w * self.traction[i + 1], (1 - w) * self.d[i] + w * self.d[i + 1])

    def start(self, pairs: JointPairs, lam: np.ndarray, d: np.ndarray, lower: float, trial: float
              ) -> PairPrediction | None:
        """The start of a trial at ``trial`` from the finer run's converged state at ``lower`` whose pairs ``pairs``
        carry ``lam`` (N) with relative displacements ``d`` (m) (module docstring); None beyond the path's
        last converged level (pairs off the ring's joints keep their state)."""
        if trial > self.levels[-1]:
            return None
        (t1, d1), (t0, d0) = self.at(trial), self.at(lower)
        ring = pairs.joint >= 0
        keys = pairs.joint[ring] * self.stride + pairs.position[ring]
        lam, d = lam.copy(), d.copy()
        for k in (0, 1):
            lam[ring, k] += np.interp(keys, self.keys, t1[:, k] - t0[:, k]) * pairs.length[ring]
            d[ring, k] += np.interp(keys, self.keys, d1[:, k] - d0[:, k])
        return PairPrediction(lam, d)

    def guide(self, solver: ContactSolver) -> Callable[[float, float, Iterate], PairPrediction | None]:
        """``start`` for ``solver``'s pairs, as ``(trial, lower, state)`` from its converged ``state``."""
        def starts(trial: float, lower: float, state: Iterate) -> PairPrediction | None:
            _, lam, d = solver.system.split(state.x)
            return self.start(solver.pairs, lam, d, lower, trial)
        return starts
