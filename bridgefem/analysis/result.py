"""What a limit analysis produced (:func:`bridgefem.analysis.runner.run_analysis`), as plain data: the model it
built, the search's outcome, the mechanism, the checks and the warnings. Every attribute is local: whatever needs
the other MPI ranks (the fill's conic bounds, the ring check under the transmitted loads, the collapse mode, the
warnings that read them) is computed once, on every rank, inside ``run_analysis``.

Units: loads in N for the scene's width (a *load level* is N per unit load factor: the live load is the level x
``load_total``), lengths in m, times in s.

**Warnings** (:func:`user_warnings`): what a user must know before trusting the bracket, each a safeguard against
a class of wrong answers that the verdict's evidence does not catch:

- *Small displacements* ``SMALL_DISPLACEMENT``: a deflection beyond that fraction of the span voids the
  small-displacement model (a masonry Young's modulus too low), whose limit is that of the undeformed arch.
- *Short voussoirs*: a voussoir shorter than an element is not resolved by the mesh, and the FE can stop below the
  limit.
- *FE/LP ratio* ``LP_RATIO_RANGE``: on a bare ring without FE sliding (nor a confirmed collapse state that
  slides), elastic blocks stop at most a little below the rigid-block LP and never above it; a ratio outside the
  range points at the mesh, the tolerance or the mechanism.
- *Conic upper bound* ``FILL_BOUND_TOL``: an FE limit above the rigid-plastic upper bound of the bridge with its
  fill (:func:`bridgefem.limit.bounds.fill_bounds`) is a fill mesh that has not converged.
- *Conic lower bound* ``FILL_BOUND_TOL``: an FE bracket below the rigid-plastic lower bound stopped before that
  model's collapse (the flat-curve test, the fill's flow rule, non-associative friction, crushing joints); where
  that bound is undecided (its static programme stopped short of full accuracy above the FE, its value still
  falling: :func:`bridgefem.limit.bounds.fill_bounds`), a value of that programme more than ``FILL_BOUND_TOL`` above
  the bracket says the same, as a value to read with its status.
- *A bracket wider than its tolerance*: one that a collapse state ends after every solver setting failed its closing
  trial (:mod:`bridgefem.search.target`, *Collapse state*, step 5) reaches up to that state's rigid-block collapse
  level; its width says how far the two readings leave the limit.
- *A failed self-weight that the conic lower bound shows standing*: a self-weight without an FE equilibrium under a
  fill whose static programme carries the dead load (a lower bound of the bridge with its fill) is the solver's
  failure, not the bridge's; the warning says so, with that bound (the converse, a proof that no equilibrium exists,
  makes the run "unstable": :mod:`bridgefem.analysis.evidence`, evidence 6).

The verdict's own warnings (:mod:`bridgefem.analysis.evidence`) follow.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..fe.mesh import BlockMesh
from ..fe.model import ElasticModel
from ..fe.pairs import JointPairs
from ..geometry.ring import ArchRing
from ..limit.rigid_block import LPResult
from ..scene.model import Scene
from ..search.records import LimitSearch
from ..solver.newton import ContactSolver
from ..status import COLLAPSE_END, Status
from .evidence import StaticBound, Verdict
from .mechanism import JointState

LP_RATIO_RANGE = (0.98, 1.01)  # FE/LP flagged outside it: elastic blocks stop <= 2 % below the LP, never 1 % above
FILL_BOUND_TOL = 0.01  # FE carrying more than this above the rigid-plastic upper bound: a discretisation error
SMALL_DISPLACEMENT = 0.01  # deflections beyond this fraction of the span void the small-displacement model


@dataclass
class ConvergedState:
    """One converged load step kept for the output time series and a re-run's coarser path: ``step`` its index in the
    history, ``load`` the live load (N), ``u`` the owned displacement dofs (m), ``pair_state`` the joint law's state
    codes of the local joint pairs, ``lam`` their forces (N) and ``d`` their relative displacements (m), each (pairs, 2)
    as (normal, tangential)."""

    step: int
    load: float
    u: np.ndarray
    pair_state: np.ndarray
    lam: np.ndarray
    d: np.ndarray



@dataclass(frozen=True)
class MeshRefinement:
    """A run that a finer mesh replaced: its ``elements_through_thickness``, the status it ended with, its
    ``seconds`` (wall time of all its phases) and its linear ``solves``."""

    elements_through_thickness: int
    status: str
    seconds: float
    solves: int


@dataclass
class TransmittedLoadCheck:
    """The ring's rigid-block LP under the loads the fill transmits
    (:func:`bridgefem.analysis.interface.transmitted_load_check`).

    ``fe_level``: the FE's last converged load level P_L (N per unit load factor); ``lp_level``: the LP's
    collapse load level lambda (same unit) under dead load = ring weight + interface forces after self-weight and live
    load = (interface forces at P_L - those after self-weight) / P_L; ``ratio`` = lambda / P_L (None when the LP
    finds no limit load); ``lp``: the LP result (its mechanism)."""

    fe_level: float
    lp_level: float | None
    ratio: float | None
    lp: LPResult



@dataclass
class Analysis:
    """Everything a run produced (module docstring): the scene, the model built for it, the search's outcome with
    its verdict, the mechanism at the last converged step (``joints``), the rigid-block LP on the same joints
    (``lp``) and the static theorem's bound of a bare ring (``static``), the converged states, the runs a finer mesh
    replaced (``refinements``), ``timings`` in s per phase; and, filled in at the end of ``run_analysis``: the conic
    bounds of the bridge with its fill (``fill_bounds``, N; None without a fill), the ring under the loads the fill
    transmits (``ring_check``; None without a fill), the blocks' rigid motion over the last converged increment
    (``collapse_mode``, :func:`bridgefem.analysis.mechanism.collapse_mode`) and the ``warnings``."""

    scene: Scene
    ring: ArchRing
    block_mesh: BlockMesh
    model: ElasticModel
    pairs: JointPairs
    solver: ContactSolver
    search: LimitSearch
    joints: list[JointState]
    lp: LPResult
    timings: dict = field(default_factory=dict)
    converged: list[ConvergedState] = field(default_factory=list)
    verdict: Verdict | None = None
    refinements: list[MeshRefinement] = field(default_factory=list)
    static: StaticBound | None = None  # the static theorem's bound of a bare ring (evidence.StaticBound)
    fill_bounds: dict | None = None
    ring_check: TransmittedLoadCheck | None = None
    collapse_mode: np.ndarray | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def load_total(self) -> float:
        """Total live load (N) per unit load level (1 without live loads)."""
        return self.scene.live_per_level

    @property
    def n_dofs(self) -> int:
        """Unknowns of the FE system: displacement dofs and joint forces, over all ranks."""
        return self.solver.system.N

    @property
    def fe_lp_ratio(self) -> float | None:
        """FE bracket midpoint over the LP's collapse load (None without a closed bracket or an LP limit)."""
        s = self.search
        if not self.lp.load or not s.upper:
            return None
        return 0.5 * (s.lower + s.upper) * self.load_total / self.lp.load

    @property
    def shortest_voussoir(self) -> float:
        """The shortest distance between the centres of a voussoir's two joints, over every ring (m)."""
        joints = self.ring.ring_joints
        return min(float(np.linalg.norm(b.centre - a.centre)) for a, b in zip(joints[:-1], joints[1:])
                   if a.right is not None and a.right == b.left)


def user_warnings(an: Analysis) -> list[str]:
    """What a user must know before trusting the bracket (module docstring, *Warnings*): voussoirs shorter than an
    element, a deflection beyond :data:`SMALL_DISPLACEMENT` of the span, an FE/LP ratio outside
    :data:`LP_RATIO_RANGE` on a bare ring without FE sliding, an FE limit above the conic upper bound of a fill
    or below its lower bound (``an.fill_bounds``, computed before), and the verdict's warnings. Local."""
    out = []
    deflections = [abs(st.deflection) for st in an.search.steps if st.converged and st.deflection is not None]
    span = an.scene.arch.span
    if deflections and max(deflections) > SMALL_DISPLACEMENT * span:
        out.append(f"deflection {max(deflections):.3g} m exceeds {SMALL_DISPLACEMENT:.0%} of the span: the "
                   "small-displacement model is outside its validity (masonry Young's modulus too low?); the "
                   "limit load is the rigid-block one of the undeformed arch")
    shortest, size = an.shortest_voussoir, an.block_mesh.element_size
    if shortest < size:
        out.append(f"voussoirs as short as {shortest:.3g} m are shorter than one element ({size:.3g} m): the FE "
                   "can stop below the limit load; raise [mesh] elements_through_thickness or use fewer voussoirs")
    ratio = an.fe_lp_ratio
    sliding = any(j.sliding for j in an.joints) or (an.verdict is not None and an.verdict.slides)
    if ratio is not None and not sliding and an.scene.fill is None \
            and not LP_RATIO_RANGE[0] <= ratio <= LP_RATIO_RANGE[1]:
        out.append(f"FE/LP limit-load ratio {ratio:.4f} is outside {list(LP_RATIO_RANGE)} on a case without FE "
                   "sliding: check the mesh, the tolerance and the mechanism")
    bounds = an.fill_bounds or {}
    if bounds.get("upper") and an.search.lower * an.load_total > (1 + FILL_BOUND_TOL) * bounds["upper"]:
        out.append(f"FE limit above the conic upper bound of the bridge with its fill ({bounds['upper'] / 1e3:.6g} "
                   "kN, fill_bounds): the FE's fill mesh is not converged (docs/fill.md: bridgefem converge)")
    upper, lower, tolerance = an.search.upper, an.search.lower, an.search.tolerance
    if upper is not None and lower > 0 and upper - lower > tolerance * lower * (1 + 1e-9):
        why = ("no solver setting found an equilibrium above its lower end, and its upper end is where the rigid "
               "blocks of that state, with its friction capacities, collapse" if COLLAPSE_END in an.search.failure
               else "its upper end is not a failed load step")
        out.append(f"the bracket is {upper / lower - 1:.3%} wide, wider than the tolerance {tolerance:g}: {why} "
                   "(failure_reason)")
    causes = ("the flat-curve test, its fill's flow rule, its non-associative friction, or crushing joints whose "
              "stress blocks are still forming")
    static = (bounds.get("programmes") or {}).get("lower") or {}
    if bounds.get("lower") and upper is not None and upper * an.load_total < (1 - FILL_BOUND_TOL) * bounds["lower"]:
        out.append(f"FE limit below the conic lower bound of the bridge with its fill ({bounds['lower'] / 1e3:.6g} "
                   f"kN, fill_bounds): the FE stops before the rigid-plastic collapse ({causes}); read the bracket "
                   "with the bounds")
    elif bounds.get("lower") is None and static.get("load") and upper is not None \
            and upper * an.load_total < (1 - FILL_BOUND_TOL) * static["load"]:
        out.append(f"the conic lower bound of the bridge with its fill is undecided: its static programme stopped "
                   f"({static['status']}, {static['iterations']} iterations) at {static['load'] / 1e3:.6g} kN, "
                   f"{static['load'] / (upper * an.load_total) - 1:.1%} above the FE's bracket, its value still "
                   f"falling (fill_bounds.programmes.lower); if the bound is near it, the FE stops before the "
                   f"rigid-plastic collapse ({causes})")
    if an.search.settled is None and Status.of(an.search.status) is Status.FAILURE and bounds.get("lower"):
        out.append(f"the bridge with its fill stands: the conic lower bound (fill_bounds) carries its self-weight and "
                   f"{bounds['lower'] / 1e3:.6g} kN of live load, so this failure to find its self-weight state is "
                   "the solver's, not a collapse")
    return out + (list(an.verdict.warnings) if an.verdict else [])
