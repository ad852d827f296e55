"""Re-runs of a limit analysis on finer meshes (:func:`bridgefem.analysis.runner.run_analysis`): when a finer mesh
can settle a run, and how the re-runs follow one another.

A joint of linear elements has one pair more than the thickness has elements: with n elements through the thickness
it opens and slides an n-th of the thickness at a time. Near the limit the Newton method's proposals can then turn
into inadmissible modes that a finer joint settles; a collapse state with sliding joints (evidence 3 of
:mod:`bridgefem.analysis.evidence`) has normal forces, and so a level, that move with the mesh; and near its least
thickness a ring stands with hundreds of joint pairs open, which the Newton method, proposing too many openings at
once from the bonded start, reaches only where the voussoirs are an element long or more.

**Cases a finer mesh settles** (:func:`refinement_reason`):

- a confirmed non-associative collapse state below the associative LP, or a failed run whose limit depends on the
  mesh (both ``Verdict.mesh_dependent``);
- a live-load trial that failed without proof where the rigid-block LP finds the ring standing, on a bare ring or,
  under a fill, on voussoirs shorter than an element;
- a self-weight that failed without proof where the LP finds the ring standing: on voussoirs shorter than an
  element, and on longer ones of a bare structure (no fill) unless a linear solve failed;
- under a Mohr-Coulomb fill, a limit whose bracket carries more than the rigid-plastic upper bound of the bridge with
  its fill (:func:`bridgefem.limit.bounds.fill_bounds`, the conic bounds: an upper bound of every collapse load of the
  blocks and the fill with associated flow, which bounds the FE's with its own flow rule too): the FE's fill mesh has
  not converged (its discrete fill is stiffer and stronger than the continuum, docs/fill.md); a finer one comes
  down towards the bound.
- with a compressive strength, joints whose pairs crush as a polygon more than ``AGREEMENT`` stronger than the
  rectangular stress block (the rigid-block LP on the FE's joints against the LP on the parabola,
  :func:`coarse_stress_block`): the FE's answer is then its mesh's, not the strength's; unless the finer mesh's
  joints could have no more elements (:func:`finer_joints`: graded joints at the size budget of both meshes, which
  a re-run would grade the same), when the run warns instead.

A self-weight on longer voussoirs whose linear solve failed is not re-run (a PETSc option that breaks the linear
solve, or MUMPS out of memory: a finer mesh cannot mend it), nor a fill's failure on longer voussoirs (the fill's
restraint decides its limit, and its re-runs are costly). A bare structure's self-weight that cycles or runs out of
iterations is: its joints' active set settles as the joints' pairs get finer, as under live load.

**The loop** (:func:`refine`):

1. Run the scene on its mesh.
2. A re-run of a confirmed run that failed leaves the confirmed run standing, the failed run listed: a solver failure
   on the finer mesh does not undo a confirmed answer on the coarser one.
3. Stop when no case above applies, when the run's last converged level moved by at most ``SETTLED_MOVE`` (or the
   search's tolerance, if larger) from the run before (with an error of first order in the element size, the finer
   run's error is about its move), after ``max_refinements`` re-runs, or when twice the elements exceed
   ``REFINED_ELEMENTS_MAX`` or the size estimate (:func:`refined_elements`). The decision is rank 0's, broadcast:
   every rank re-runs or none.
4. Otherwise run again with twice the elements through the thickness: its first live-load step and its search's
   target are the level the run before it reached, or the conic upper bound's where that level exceeds it
   (:func:`exceeded_bound`: a level above an upper bound is no estimate of the limit;
   :func:`bridgefem.analysis.runner.first_step`; :mod:`bridgefem.search.target`, *Guess*); a bare ring's re-run
   starts its trials from that run's converged path (:mod:`bridgefem.search.coarser_path`); a re-run of a confirmed
   run may spend ``REFINEMENT_BUDGET`` times that run's linear solves, at least ``REFINEMENT_FLOOR``, exactly (the
   solve past it is never made: :meth:`bridgefem.solver.linear.CheckedSolve.limited`), and one that spends it
   unsettled is a failure "not settled within its budget" (step 2); a re-run that converges more than
   ``SETTLED_MOVE`` (or the search's tolerance) above the confirmed run's level has shown that run's limit to be
   its mesh's, no answer it refines, and its budget is lifted (:func:`bridgefem.analysis.runner.run_analysis`). A
   limit above the conic upper bound is not confirmed (an independent bound contradicts it): its re-run has no
   budget, and its failure is the answer. Go to step 2.

The last run is the answer, the runs it replaced listed in ``Analysis.refinements``; its verdict needs the same
evidence as any other.

Safeguards:

- *Settled move* ``SETTLED_MOVE``: a finer mesh that did not move the limit shows that these elements do not decide
  it, so no finer one is tried.
- *Caps* ``MAX_REFINEMENTS``, ``REFINED_ELEMENTS_MAX`` and the size estimate: the re-runs' cost and memory stay
  bounded.
- *Budget of a confirmed run's re-run* ``REFINEMENT_BUDGET``, ``REFINEMENT_FLOOR``: such a re-run can only refine
  an answer already confirmed, so it may not cost more than a few times that answer, until it carries more than
  that answer (step 4).
- *The confirmed run stands* (step 2): a finer mesh's solver failure never replaces a confirmed answer.
"""
from __future__ import annotations

from typing import Callable

from mpi4py import MPI

from ..limit.collapse import collapse_load
from ..scene.keys import SceneError
from ..scene.model import Scene, with_mesh
from ..search.coarser_path import CoarserPath
from ..status import LINEAR_SOLVER_FAILED, Status
from ..structure.sizing import MAX_DOFS, check_size, most_graded_elements
from .evidence import AGREEMENT
from .result import Analysis, MeshRefinement

MAX_REFINEMENTS = 2  # re-runs of a limit that depends on the mesh, each with twice the elements through the thickness
REFINED_ELEMENTS_MAX = 16  # elements through the thickness a re-run may reach
SETTLED_MOVE = AGREEMENT  # a re-run whose limit moved by less than this fraction (or the search's tolerance, if
# larger) is not re-run again
REFINEMENT_BUDGET = 2  # a re-run of a confirmed run may spend this many times the linear solves of that run, ...
REFINEMENT_FLOOR = 80  # ... and at least this many

Analyse = Callable[[Scene, float | None, int | None, CoarserPath | None], Analysis]  # one run of one mesh (refine)


def refine(scene: Scene, comm: MPI.Comm, analyse: Analyse, notice: Callable[[str], None],
           max_refinements: int = MAX_REFINEMENTS, max_dofs: float = MAX_DOFS,
           upper_bound: Callable[[], float | None] = lambda: None) -> Analysis:
    """The scene's run, re-run on finer meshes while they can settle it (module docstring, *The loop*);
    ``analyse(scene, coarser, budget, path)`` runs one mesh given the level the run before it reached (None on a
    first run), its budget of linear solves (None: none) and the bare ring's path of the run before it (None: none);
    ``notice(line)`` announces each re-run. Collective."""
    refinements, previous, start, confirmed, path = [], None, None, None, None
    while True:
        budget = max(REFINEMENT_FLOOR, REFINEMENT_BUDGET * refinements[-1].solves) if confirmed is not None \
            else None
        an = analyse(scene, start, budget, path)
        ett, carried = scene.mesh.elements_through_thickness, an.search.lower
        failed = Status.of(an.search.status) is Status.FAILURE
        if failed and confirmed is not None:
            notice(f"the re-run with {ett} elements through the thickness failed ({an.search.status}): the "
                   f"confirmed run with {confirmed.scene.mesh.elements_through_thickness} stands")
            confirmed.refinements = refinements[:-1] + [_replaced(an, ett)]
            return confirmed
        moved = previous is None or abs(carried - previous) > max(an.search.tolerance, SETTLED_MOVE) * previous
        above = exceeded_bound(an, upper_bound)
        finer, why = None, refinement_reason(an, ett, above)
        if comm.rank == 0 and why and moved and len(refinements) < max_refinements:
            finer = refined_elements(scene, max_dofs)
        finer = comm.bcast(finer, root=0)
        if finer is None:
            an.refinements = refinements
            return an
        refinements.append(_replaced(an, ett))
        previous, confirmed = carried, None if failed or above is not None else an
        start = carried if above is None else above / an.load_total  # the bound, below the contradicted limit
        path = CoarserPath.of(an.pairs, [(c.load / an.load_total, c.lam, c.d) for c in an.converged], comm) \
            if scene.fill is None else None
        notice(f"{why}: re-running with {finer} elements through the thickness")
        del an  # free a failed coarse model before the finer one is built
        scene = with_mesh(scene, finer)


def _replaced(an: Analysis, ett: int) -> MeshRefinement:
    """The record of a run with ``ett`` elements through the thickness that another run replaces."""
    return MeshRefinement(ett, an.search.status, sum(an.timings.values()), an.solver.stats["solves"])


def refinement_reason(an: Analysis, ett: int, above: float | None = None) -> str:
    """Why a finer mesh can settle a run with ``ett`` elements through the thickness, in words (empty: it cannot;
    module docstring, *Cases a finer mesh settles*): a confirmed non-associative collapse state below the associative
    LP, or a failed run whose limit depends on the mesh (both ``Verdict.mesh_dependent``), or a run that failed
    without proof where the rigid-block LP finds the ring standing: on a live-load trial (not at the cap on the load
    steps) of a bare ring, or of a ring under a fill on voussoirs shorter than an element, or under self-weight on
    such voussoirs or, unless a linear solve failed, on a bare structure's longer ones; or a limit above ``above``,
    the conic upper bound of the scene it exceeds (N, from :func:`exceeded_bound`; None: none exceeded)."""
    coarse = coarse_stress_block(an)
    if coarse and finer_joints(an, ett):
        return coarse
    if an.verdict.mesh_dependent and Status.of(an.search.status) is Status.LIMIT:
        return (f"a non-associative collapse state {1 - an.search.upper / an.lp.level:.1%} below the rigid-block LP "
                f"({ett} elements through the thickness carry {an.search.lower * an.load_total / 1e3:.6g} kN, the LP "
                f"{an.lp.load / 1e3:.6g} kN); its joints' normal forces, and so its level, move with the mesh")
    if an.verdict.mesh_dependent:
        return (f"the limit depends on the mesh ({ett} elements through the thickness carry "
                f"{an.search.lower * an.load_total / 1e3:.6g} kN, the rigid-block LP's mechanism at "
                f"{an.lp.load / 1e3:.6g} kN)")
    if above is not None:
        return (f"{ett} elements through the thickness carry {an.search.lower * an.load_total / 1e3:.6g} kN, above "
                f"the rigid-plastic upper bound of the bridge with its fill ({above / 1e3:.6g} kN, fill_bounds): the "
                "fill mesh has not converged")
    if (Status.of(an.search.status) is not Status.FAILURE or an.search.proved
            or an.lp.status not in (Status.LIMIT, Status.STABLE, Status.UNBOUNDED)):
        return ""
    short = an.shortest_voussoir < an.block_mesh.element_size
    live = an.search.settled is not None and bool(an.search.failure)  # a failed live-load trial ended it
    if live and (short or an.scene.fill is None):
        return (f"the search failed without proof at {an.search.lower * an.load_total / 1e3:.6g} kN"
                f"{' on voussoirs shorter than an element' if short else ''} ({ett} elements through the "
                f"thickness), where the rigid-block LP finds the ring standing")
    mendable = an.scene.fill is None and LINEAR_SOLVER_FAILED not in an.search.status  # a bare structure's active set
    if an.search.last is None and (short or mendable):
        return (f"the self-weight failed without proof{' on voussoirs shorter than an element' if short else ''} "
                f"({ett} elements through the thickness), where the rigid-block LP finds the ring standing")
    return ""


def exceeded_bound(an: Analysis, upper_bound: Callable[[], float | None]) -> float | None:
    """The conic upper bound ``upper_bound()`` of the scene (N; collective, asked only here: after a limit under a
    Mohr-Coulomb fill) when the run's limit carries more than it, else None. Such a limit is contradicted by an
    independent bound: its re-run starts at the bound and is not the re-run of a confirmed run (:func:`refine`)."""
    if Status.of(an.search.status) is not Status.LIMIT or an.scene.fill is None \
            or an.scene.fill.material != "mohr-coulomb":
        return None
    upper = upper_bound()
    return upper if upper is not None and an.search.lower * an.load_total > upper else None


def coarse_stress_block(an: Analysis) -> str:
    """With a compressive strength: why the FE's joints are too coarse a stress block (empty: they are not). The FE's
    pairs through a joint crush one at a time, a polygon around the rectangular stress block's parabola
    (:mod:`bridgefem.laws.crushing`); the rigid-block LP on the FE's joints (``an.lp``) and on the parabola (within
    1/K^2 of it) differ by more than ``AGREEMENT`` where the FE's answer is set by its mesh, not by f_c. On rank 0."""
    masonry = getattr(an.scene, "masonry", None)  # (a scene's stand-in without one: no strength)
    if getattr(masonry, "compressive_strength", None) is None or an.lp.status != Status.LIMIT:
        return ""
    try:
        block = collapse_load(an.scene)
    except (RuntimeError, ValueError):
        return ""
    if block.level is None or an.lp.level <= (1 + AGREEMENT) * block.level:
        return ""
    return (f"the FE's {an.scene.mesh.elements_through_thickness} elements through the thickness crush a joint "
            f"{an.lp.level / block.level - 1:.1%} stronger than the rectangular stress block (rigid-block LP on its "
            f"joints {an.lp.load / 1e3:.6g} kN, on the stress block {block.load / 1e3:.6g} kN)")


def finer_joints(an: Analysis, ett: int) -> bool:
    """Whether twice ``ett`` elements through the thickness may give the ring joints more elements than the run
    ``an``'s: always for even joints, for graded ones when the size budget of the finer mesh
    (:func:`bridgefem.structure.sizing.most_graded_elements`) allows more than the run's joints have."""
    nodes = an.block_mesh.joint_nodes
    return nodes is None or most_graded_elements(with_mesh(an.scene, 2 * ett)) > len(nodes) - 1


def refined_elements(scene: Scene, max_dofs: float = MAX_DOFS) -> int | None:
    """Twice the scene's elements through the ring thickness, or None when that exceeds :data:`REFINED_ELEMENTS_MAX` or
    the size estimate refuses it (:func:`bridgefem.structure.sizing.check_size` with at most ``max_dofs`` unknowns)."""
    ett = 2 * scene.mesh.elements_through_thickness
    if ett > REFINED_ELEMENTS_MAX:
        return None
    try:
        check_size(with_mesh(scene, ett), max_dofs=max_dofs)
    except SceneError:
        return None
    return ett
