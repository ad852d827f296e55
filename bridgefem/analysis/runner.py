"""The FE limit analysis of a scene: scene -> ring -> mesh -> elastic model -> joint pairs -> solver -> search.

Also reads the collapse mechanism off the last converged state: per joint the resultant normal force N (N,
compression positive), shear V (N), eccentricity e (m, from the joint centre, positive towards the extrados)
and the open part of its length. A *hinge* is a cracked joint (open over at least half its length, or with
its thrust within 1 % of the length from a face: with one element through the thickness a joint has only two
pairs) whose |e| is the largest of its run of consecutive such joints (the thrust line touches the ring there;
|e| that agree within ``HINGE_TIE`` of the length, e.g. thrusts on the edge pair, tie and the largest opening
wins, not rounding); it sits at the intrados when e < 0 and at the extrados when e > 0 (for an abutment's base: at
its inner and outer edge); a run only continues through joints that share a block. A *sliding* joint has every
closed pair slipping one way.

With a fill, the forces the fill exerts on the ring across the arch-fill interface (:func:`interface_forces`) load
the ring's rigid-block LP in :func:`transmitted_load_check`: the ring under the loads the fill transmits.

Load vocabulary: the *load level* P (N per unit ``factor``; ``LoadStep.level`` in :mod:`bridgefem.search.pathfollow`,
``LPResult.level`` in :mod:`bridgefem.limit.rigid_block`) scales the scene's live loads, each ``factor`` x P; the
*live load* is P x the sum of the factors (N, ``Analysis.load_total`` per unit level), the ``load`` of results.json.
"""
from __future__ import annotations

import logging
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from ..fe.fill import PlasticFill
from ..fe.mesh import EXTRADOS_TAG, BlockMesh, build_block_mesh
from ..fe.model import ElasticModel, build_elastic_model, node_blocks
from ..fe.pairs import ARCH_FILL, JointPairs, build_pairs, ground_offsets
from ..fe.sizing import MAX_DOFS, check_size
from ..geometry.ring import ArchRing, fill_outline
from ..laws.coulomb import OPEN, SLIP
from ..limit.bounds import fill_bounds
from ..limit.collapse import collapse_load, collapse_state_from
from ..limit.rigid_block import BlockModel, LPResult, frozen_capacity_collapse, solve_blocks
from ..limit.ring_blocks import ring_under_forces
from ..scene.schema import Scene, SceneError, with_mesh
from ..search.coarser_path import CoarserPath
from ..search.pathfollow import (
    CollapseCheck,
    LimitSearch,
    LoadStep,
    SearchGuides,
    SearchObservers,
    SearchSettings,
    find_limit_load,
    monitor_deflection,
)
from ..solver.linear import SolveBudgetSpent
from ..solver.newton import ContactSolver, Iterate
from ..solver.tresca import TrescaPredictor
from ..status import Status
from ..structure.ring import scene_ring
from ..structure.supports import support_motion
from .evidence import AGREEMENT, SlipCheck, StaticBound, Verdict, confirm, coulomb_limited, needs_slip_check
from .static_bound import fe_blocks, static_cap

HINGE_OPEN_FRACTION = 0.5  # a hinge joint is open over at least this fraction of its length,
HINGE_ECCENTRICITY = 0.49  # or its thrust is this close to a face (fraction of its length from the centre)
HINGE_TIE = 1e-6  # eccentricities (fraction of the length) that agree this closely tie; the largest opening wins
FORCE_TOL = 1e-10  # contact-state hysteresis as a fraction of the ring's weight (N/N)
RING_JOINT_SCALE = 0.1  # Alart-Curnier constant of the ring's joints, of E w L / h: it only weighs forces against
# displacements when the active set is classified; on the seeded campaign (benchmarks/campaign.py, seed 1, the 34
# scenes both finished) 0.1 gave no solver failure where 1 gave two, and at most 106 solves per limit against 231
LP_RATIO_RANGE = (0.98, 1.01)  # FE/LP flagged outside it: elastic blocks stop <= 2 % below the LP, never 1 % above
FILL_BOUND_TOL = 0.01  # FE carrying more than this above the rigid-plastic upper bound: a discretisation error
SMALL_DISPLACEMENT = 0.01  # deflections beyond this fraction of the span void the small-displacement model
MAX_REFINEMENTS = 2  # re-runs of a limit that depends on the mesh, each with twice the elements through the thickness
REFINED_ELEMENTS_MAX = 16  # elements through the thickness a re-run may reach (campaign scenes 2, 193, 297 at 16:
# within 0.65 % of the LP; docs/joints-and-lp.md)
SETTLED_MOVE = AGREEMENT  # a re-run whose limit moved by less than this fraction (or the search's tolerance, if
# larger) is not re-run again. Campaigns seeds 1-7: of the 24 bare rings re-run up to 16 elements, 18 had moved by
# 0.02-0.34 % from 4 to 8 elements, and 16 elements moved those (17 settled) by at most 0.10 % more
REFINEMENT_BUDGET = 2  # a re-run of a confirmed run may spend this many times the linear solves of that run, ...
REFINEMENT_FLOOR = 80  # ... and at least this many. The re-runs of confirmed runs that settled on the campaigns
# (seeds 1 and 2, 12 re-runs) spent 0.19-1.46 times the solves of the run they re-ran (seed 1: #2 38/26, #297 42/134
# and 44/42, #76 78/183, #124 38/67, #220 45/80, #184 36/107, #193 43/163; seed 2: #55 51/40 and 63/51, #73 59/65,
# #12 32/32) and 32-78 solves in all (seed 1 #193 with 16 elements: 46/43, within 0.08 % of the LP)


@dataclass
class ConvergedState:
    """One converged load step kept for the output time series and a re-run's coarser path: ``step`` its index in the
    history, ``load`` the live load (N), ``u`` the owned displacement dofs (m), ``pair_state`` OPEN/STICK/SLIP of the
    local joint pairs, ``lam`` their forces (N) and ``d`` their relative displacements (m), each (pairs, 2) as (normal,
    tangential)."""

    step: int
    load: float
    u: np.ndarray
    pair_state: np.ndarray
    lam: np.ndarray
    d: np.ndarray


@dataclass
class JointState:
    """Resultants and state of one joint at the last converged step (forces in N, lengths in m); ``opening``: the
    largest normal gap of its pairs (m, 0 when closed)."""

    id: int
    normal_force: float
    shear_force: float
    eccentricity: float
    open_fraction: float
    opening: float
    sliding: int
    hinge: str = ""


@dataclass(frozen=True)
class MeshRefinement:
    """A run that a finer mesh replaced: its ``elements_through_thickness``, the status it ended with, its
    ``seconds`` (wall time of all its phases) and its linear ``solves``."""

    elements_through_thickness: int
    status: str
    seconds: float
    solves: int


@dataclass
class Analysis:
    """Everything a run produced; ``timings`` in seconds per phase."""

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

    @property
    def load_total(self) -> float:
        """Total live load (N) per unit load level (1 without live loads)."""
        return sum(ld.factor for ld in self.scene.loads) or 1.0

    @property
    def n_dofs(self) -> int:
        return self.solver.system.N

    @property
    def fe_lp_ratio(self) -> float | None:
        """FE bracket midpoint over the LP's collapse load (None without a closed bracket or an LP limit)."""
        s = self.search
        if not self.lp.load or not s.upper:
            return None
        return 0.5 * (s.lower + s.upper) * self.load_total / self.lp.load

    @cached_property
    def fill_bounds(self) -> dict | None:
        """Lower and upper collapse bounds of the bridge with its fill, rigid-plastic, by conic optimisation
        (:func:`bridgefem.limit.bounds.fill_bounds`; None without a fill). Solved on rank 0 and broadcast (collective)."""
        comm = self.solver.comm
        return comm.bcast(fill_bounds(self.scene) if comm.rank == 0 else None, root=0)

    @cached_property
    def ring_check(self) -> TransmittedLoadCheck | None:
        """The ring under the loads the fill transmits (:func:`transmitted_load_check`; collective)."""
        return transmitted_load_check(self)

    @property
    def warnings(self) -> list[str]:
        """What a user must know before trusting the bracket: voussoirs shorter than an element, a deflection
        beyond :data:`SMALL_DISPLACEMENT` of the span, an FE/LP ratio outside :data:`LP_RATIO_RANGE` on a bare
        ring without FE sliding, an FE limit above the conic upper bound of a fill, and the verdict's warnings."""
        out = []
        deflections = [abs(st.deflection) for st in self.search.steps if st.converged and st.deflection is not None]
        span = self.scene.arch.span
        if deflections and max(deflections) > SMALL_DISPLACEMENT * span:
            out.append(f"deflection {max(deflections):.3g} m exceeds {SMALL_DISPLACEMENT:.0%} of the span: the "
                       "small-displacement model is outside its validity (masonry Young's modulus too low?); the "
                       "limit load is the rigid-block one of the undeformed arch")
        shortest, size = self.shortest_voussoir, self.block_mesh.element_size
        if shortest < size:
            out.append(f"voussoirs as short as {shortest:.3g} m are shorter than one element ({size:.3g} m): the FE "
                       "can stop below the limit load; raise [mesh] elements_through_thickness or use fewer voussoirs")
        ratio, sliding = self.fe_lp_ratio, any(j.sliding for j in self.joints)
        if ratio is not None and not sliding and self.scene.fill is None \
                and not LP_RATIO_RANGE[0] <= ratio <= LP_RATIO_RANGE[1]:
            out.append(f"FE/LP limit-load ratio {ratio:.4f} is outside {list(LP_RATIO_RANGE)} on a case without FE "
                       "sliding: check the mesh, the tolerance and the mechanism")
        bounds = self.fill_bounds or {}
        if bounds.get("upper") and self.search.lower * self.load_total > (1 + FILL_BOUND_TOL) * bounds["upper"]:
            out.append(f"FE limit above the conic upper bound of the bridge with its fill ({bounds['upper'] / 1e3:.6g} "
                       "kN, fill_bounds): the FE's fill mesh is not converged (docs/fill.md: bridgefem converge)")
        return out + (list(self.verdict.warnings) if self.verdict else [])

    @property
    def shortest_voussoir(self) -> float:
        """The shortest distance between neighbouring joint centres (m)."""
        centres = np.array([jt.centre for jt in self.ring.joints[:self.ring.n_voussoirs + 1]])
        return float(np.linalg.norm(np.diff(centres, axis=0), axis=1).min())

    def voussoir_motion(self, u: np.ndarray) -> np.ndarray:
        """Least-squares rigid motion (ux m, uy m, rotation rad, anticlockwise) of each block (voussoirs, abutments,
        then the fill) under the owned displacement dofs ``u`` (m), one row per block (collective)."""
        V, bm = self.model.V, self.block_mesh
        n_owned = V.dofmap.index_map.size_local
        n_blocks = self.ring.n_blocks + (bm.fill_block is not None)  # the same on every rank
        blk = node_blocks(V, bm)[:n_owned]
        x = V.tabulate_dof_coordinates()[:n_owned, :2]
        u = u[:2 * n_owned].reshape(-1, 2)
        comm = V.mesh.comm

        def total(w):
            return comm.allreduce(np.bincount(blk, weights=w, minlength=n_blocks))

        count = total(np.ones(len(blk)))
        xc = np.column_stack([total(x[:, 0]), total(x[:, 1])]) / count[:, None]
        r = x - xc[blk]
        theta = total(r[:, 0] * u[:, 1] - r[:, 1] * u[:, 0]) / total((r ** 2).sum(axis=1))
        mean_u = np.column_stack([total(u[:, 0]), total(u[:, 1])]) / count[:, None]
        return np.column_stack([mean_u - np.column_stack([-theta * xc[:, 1], theta * xc[:, 0]]), theta])

    def collapse_mode(self) -> np.ndarray | None:
        """The blocks' rigid motion over the last converged increment of live load (the motion the mechanism
        starts with; :meth:`voussoir_motion` rows), or over the whole path when only one state converged; None
        without a converged state. Collective."""
        if not self.converged:
            return None
        last = self.converged[-1].u
        before = self.converged[-2].u if len(self.converged) > 1 else np.zeros_like(last)
        return self.voussoir_motion(last - before)


@contextmanager
def quiet_compiler():
    """Silence the C compiler's log of DOLFINx's just-in-time forms (INFO records that the compiler's build step
    sends to the root logger on a first run) while inside; warnings and errors still show."""
    previous = logging.root.manager.disable
    logging.disable(max(previous, logging.INFO))
    try:
        yield
    finally:
        logging.disable(previous)


def run_analysis(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD, petsc_options: dict | None = None,
                 report: Callable[[LoadStep], None] = lambda s: None,
                 phase: Callable[[str], None] = lambda name: None,
                 notice: Callable[[str], None] = lambda line: None,
                 max_refinements: int = MAX_REFINEMENTS, max_dofs: float = MAX_DOFS) -> Analysis:
    """Compute the limit load of a scene: the ring, with its fill and elastic abutments when the scene has them,
    after the support movement it imposes (collective over ``comm``); ``phase(name)`` announces each set-up phase
    and ``report(step)`` each load step.

    A run that fails where a finer mesh can settle it (:func:`refinement_reason`: a limit that depends on the mesh,
    ``Verdict.mesh_dependent``, the associative LP's mechanism a little below the LP's level; a failure without proof
    under live load, with a fill only on voussoirs shorter than an element, or under self-weight on such voussoirs) is
    run again with twice the elements through the thickness (:func:`refined_elements`, within ``max_dofs`` unknowns), at
    most ``max_refinements`` times, and not again when the re-run's last converged load is within ``SETTLED_MOVE`` (or
    the search's tolerance, if larger) of the previous one's: the limit is then settled on these elements (with an error
    of first order in the element size, the finer run's error is about its move); ``notice(line)`` announces each
    re-run, whose first live-load step and whose search's target are the level the run before it reached
    (:func:`first_step`; :mod:`bridgefem.search.pathfollow`, *Guess*); a bare ring's re-run starts its trials from that run's
    converged path (:mod:`bridgefem.search.coarser_path`). The last run is returned, the runs it replaced listed in
    ``Analysis.refinements``; its verdict needs the same evidence. A confirmed run that is re-run (a collapse state of
    evidence 3 below the associative LP) is kept when the finer run fails: a solver failure on the finer mesh does not
    undo a confirmed answer on the coarser one (the failed run is listed in ``Analysis.refinements``). Such a re-run can
    only refine the answer, so its search gets a budget of ``REFINEMENT_BUDGET`` times the linear solves of the
    confirmed run, at least ``REFINEMENT_FLOOR``, its self-weight included; it holds exactly (the solve past it is never
    made, whatever asks for it: :meth:`bridgefem.solver.linear.CheckedSolve.limited`), and a re-run that spends it unsettled
    is a failure "not settled within its budget".
    The decision is rank 0's, broadcast (every rank re-runs or none)."""
    refinements, previous, confirmed, path = [], None, None, None
    with quiet_compiler():
        while True:
            budget = max(REFINEMENT_FLOOR, REFINEMENT_BUDGET * refinements[-1].solves) if confirmed is not None \
                else None
            an = _analyse(scene, comm, petsc_options, report, phase, previous, budget, path)
            ett, carried = scene.mesh.elements_through_thickness, an.search.lower
            failed = Status.of(an.search.status) is Status.FAILURE
            if failed and confirmed is not None:
                notice(f"the re-run with {ett} elements through the thickness failed ({an.search.status}): the "
                       f"confirmed run with {confirmed.scene.mesh.elements_through_thickness} stands")
                confirmed.refinements = refinements[:-1] + [_replaced(an, ett)]
                return confirmed
            moved = previous is None or abs(carried - previous) > max(an.search.tolerance, SETTLED_MOVE) * previous
            finer, why = None, refinement_reason(an, ett)
            if comm.rank == 0 and why and moved and len(refinements) < max_refinements:
                finer = refined_elements(scene, max_dofs)
            finer = comm.bcast(finer, root=0)
            if finer is None:
                an.refinements = refinements
                return an
            refinements.append(_replaced(an, ett))
            previous, confirmed = carried, None if failed else an
            path = CoarserPath.of(an.pairs, [(c.load / an.load_total, c.lam, c.d) for c in an.converged], comm) \
                if scene.fill is None else None
            notice(f"{why}: re-running with {finer} elements through the thickness")
            del an  # free a failed coarse model before the finer one is built
            scene = with_mesh(scene, finer)


def _replaced(an: Analysis, ett: int) -> MeshRefinement:
    """The record of a run with ``ett`` elements through the thickness that another run replaces."""
    return MeshRefinement(ett, an.search.status, sum(an.timings.values()), an.solver.stats["solves"])


def refinement_reason(an: Analysis, ett: int) -> str:
    """Why a finer mesh can settle a run with ``ett`` elements through the thickness (empty: it cannot): a confirmed
    non-associative collapse state below the associative LP, or a failed run whose limit depends on the mesh (both
    ``Verdict.mesh_dependent``), or a run that failed without proof where the rigid-block LP finds the ring standing:
    on a live-load trial (not at the cap on the load steps) of a bare ring, or of a ring under a fill on voussoirs
    shorter than an element, or under self-weight on such voussoirs.
    Near its least thickness such a ring stands with hundreds of joint pairs open; from the bonded start the Newton
    method proposes too many openings at once, most of them mechanisms, and damping spends the iteration budget
    (campaign seed 1, #251, 0.3 % above its least thickness: with 4 elements through the thickness no solver setting
    converges within 60 iterations, six of ten in 66-303; with 8, where the voussoirs are an element long or more,
    five of eight in 20-52). Under live load a joint of ``ett`` + 1 pairs opens and slides an ``ett``-th of the
    thickness at a time; near the limit the Newton method's proposals then turn into inadmissible modes, and a finer
    joint settles it (campaign seed 4, #38, 166 voussoirs of 0.27 m: with 4 elements every trial from 0.87 of the LP
    diverged with every setting, its re-run with 8 a confirmed collapse state at 1691 kN in 90 solves; seed 4, #10,
    a ring 0.044 m thick: stalled at 0.91 of the LP with 4, the static theorem's bracket at the LP with 8; seed 1,
    #181 under an elastic fill: 1961 solves to a failure with 4, the limit in 979 more with 8). A self-weight
    failure on longer voussoirs is not re-run: that is where a PETSc option that breaks the linear solve fails, and
    a finer mesh cannot mend it. Nor is a fill's failure on longer voussoirs, where the fill's restraint decides the
    limit and the re-runs are costly (the reference arch under a stiff rough fill: 22 s to its failure with 2
    elements, 329 s with its re-runs on finer meshes). The re-run's verdict needs the same evidence."""
    if an.verdict.mesh_dependent and Status.of(an.search.status) is Status.LIMIT:
        return (f"a non-associative collapse state {1 - an.search.upper / an.lp.level:.1%} below the rigid-block LP "
                f"({ett} elements through the thickness carry {an.search.lower * an.load_total / 1e3:.6g} kN, the LP "
                f"{an.lp.load / 1e3:.6g} kN); its joints' normal forces, and so its level, move with the mesh")
    if an.verdict.mesh_dependent:
        return (f"the limit depends on the mesh ({ett} elements through the thickness carry "
                f"{an.search.lower * an.load_total / 1e3:.6g} kN, the rigid-block LP's mechanism at "
                f"{an.lp.load / 1e3:.6g} kN)")
    if (Status.of(an.search.status) is not Status.FAILURE or an.search.proved
            or an.lp.status not in (Status.LIMIT, Status.STABLE, Status.UNBOUNDED)):
        return ""
    short = an.shortest_voussoir < an.block_mesh.element_size
    live = an.search.settled is not None and bool(an.search.failure)  # a failed live-load trial ended it
    if live and (short or an.scene.fill is None):
        return (f"the search failed without proof at {an.search.lower * an.load_total / 1e3:.6g} kN"
                f"{' on voussoirs shorter than an element' if short else ''} ({ett} elements through the "
                f"thickness), where the rigid-block LP finds the ring standing")
    if an.search.last is None and short:
        return (f"the self-weight failed without proof on voussoirs shorter than an element ({ett} elements through "
                f"the thickness), where the rigid-block LP finds the ring standing")
    return ""


def refined_elements(scene: Scene, max_dofs: float = MAX_DOFS) -> int | None:
    """Twice the scene's elements through the ring thickness, or None when that exceeds
    :data:`REFINED_ELEMENTS_MAX` or the size estimate refuses it (:func:`bridgefem.fe.sizing.check_size` with at most
    ``max_dofs`` unknowns)."""
    ett = 2 * scene.mesh.elements_through_thickness
    if ett > REFINED_ELEMENTS_MAX:
        return None
    try:
        check_size(with_mesh(scene, ett), max_dofs=max_dofs)
    except SceneError:
        return None
    return ett


def first_step(dead_weight: float, coarser: float | None = None) -> float:
    """The first live-load step (N per unit load factor) when the scene sets none: a quarter of the ring's
    ``dead_weight`` (N), or on a re-run the level the coarser mesh's run reached, ``coarser``, when that is larger.

    The step bounds every step that approaches the search's target (:mod:`bridgefem.search.pathfollow`, *Steps*); a
    re-run's target is at most the coarser run's level (*Guess*: the two agree within 2 % on the campaigns'
    re-runs), which the approach then reaches in halves of the distance left, not in steps of a quarter of the
    ring's weight (campaign seed 1, #220: 47 linear solves for its re-run with 8 elements, 95 with the quarter; #124:
    38 against 58). The step sets the path, never what counts as converged or as a bracket (the bracket rule is the
    search's)."""
    return max(dead_weight / 4, coarser or 0.0)


def search_settings(scene: Scene, dead_weight: float, coarser: float | None = None) -> SearchSettings:
    """The limit search's settings from the scene's keys, their zeros resolved: the first step :func:`first_step`
    of the ring's ``dead_weight`` (N) and the ``coarser`` run's last converged level (N per unit load factor; None on
    a first run), the maximum load 100 x ``dead_weight`` (0 without live loads: self-weight only); the flat-curve
    check only with a fill, the support movement's increments only where a support moves."""
    s, abutments = scene.solver, scene.abutments
    return SearchSettings(tolerance=s.tolerance, initial_step=s.initial_step or first_step(dead_weight, coarser),
                          max_load=(s.max_load or 100 * dead_weight) if scene.loads else 0.0, max_steps=s.max_steps,
                          stiffness_drop=s.stiffness_drop if scene.fill is not None else 0.0,
                          movement_steps=abutments.movement_steps if abutments.moves else 0)


def _analyse(scene: Scene, comm: MPI.Comm, petsc_options: dict | None,
             report: Callable[[LoadStep], None], phase: Callable[[str], None],
             coarser: float | None = None, budget: int | None = None, path: CoarserPath | None = None
             ) -> Analysis:
    """One run of the scene's mesh (:func:`run_analysis`); ``coarser``: the last converged level (N per unit load
    factor) of the run on a coarser mesh that this one re-runs (:func:`first_step`), None on a first run, and
    ``path`` that run's converged path, a bare ring's (its trials start from it: :mod:`bridgefem.search.coarser_path`);
    ``budget``: the linear solves its search may spend (None: no limit), exactly; a failure when spent."""
    timings = {}
    t = time.perf_counter()

    def lap(name):
        nonlocal t
        now = time.perf_counter()
        timings[name] = comm.allreduce(now - t, op=MPI.MAX)
        t = now

    a = scene.arch
    ring = scene_ring(scene)  # SceneError naming the loads when they cannot have their joints
    fill = scene.fill
    outline = (fill_outline(ring, fill.depth, fill.extension, scene.load_edges_x()) if fill is not None else None)
    lap("geometry")
    phase("meshing")
    bm = build_block_mesh(ring, scene.mesh.elements_through_thickness, comm, outline,
                          fill.element_size if fill is not None else 0.0, loading_beams(scene))
    lap("mesh")
    lp = rigid_block_check(scene, comm)  # the search's guess, the verdict's evidence, the side of a load on a joint
    lap("rigid-block LP")
    phase("assembling")
    model = build_elastic_model(bm, ring, scene, lp.load_sides if fill is None and lp.load_sides else None)
    lap("assembly")
    phase("pairing the joints")
    pairs = build_pairs(model.V, bm, ring, match_tol=1e-9 * a.span)  # coincident joint nodes, up to round-off
    lap("pairing")
    young, friction = pair_properties(scene, ring, pairs)
    c = young * a.width * pairs.length / bm.element_size  # Alart-Curnier constant: the softer side's stiffness,
    c[pairs.joint != ARCH_FILL] *= RING_JOINT_SCALE  # scaled down at the ring's joints (see the constant)
    material = PlasticFill(model.V, bm, scene, model.bcs) if fill and fill.material == "mohr-coulomb" else None
    motion = support_motion(scene, ring)
    phase("setting up the solver (first factorisation)")
    solver = ContactSolver(model.K, model.f_dead, model.f_live, pairs, friction, c,
                           FORCE_TOL * model.dead_weight, scene.solver.max_iterations,
                           {**scene.solver.petsc, **(petsc_options or {})}, material, ground_offsets(pairs, motion))
    lap("solver setup")
    s = scene.solver
    phase("limit search")
    # a plastic fill can fail under the load before the ring does: watch the load's own displacement; an elastic
    # fill cannot, and its elastic settlement would hide the ring's mechanism from the flat-curve test
    under_load = (load_displacement(solver, model.f_live, model.live_per_level)
                  if material is not None and model.live_per_level > 0 else monitor_deflection(solver, model.monitor))
    total = sum(ld.factor for ld in scene.loads) or 1.0  # N of live load per unit level
    states: list[ConvergedState] = []
    attempted: list[LoadStep] = []

    def note(step: LoadStep) -> None:  # every attempted step, kept for a search that its budget stops
        attempted.append(step)
        report(step)

    def keep(step: LoadStep, it: Iterate) -> None:  # every converged state: the fields' time series, a re-run's path
        u, lam, d = solver.system.split(it.x)
        states.append(ConvergedState(step.index, step.level * total, u.copy(), it.active.state.copy(), lam.copy(),
                                     d.copy()))

    blocks = fe_blocks(scene, model, bm) if fill is None else None  # the rigid blocks loaded as the FE loads them
    bound = static_cap(blocks, model, bm, pairs, solver) if fill is None else None
    lap("static bound")
    # a failed trial's predicted state (bridgefem.solver.tresca): every bare ring
    predictor = TrescaPredictor(solver) if fill is None else None
    try:
        with solver.linear.limited(budget):  # exact: the solve past it raises (bridgefem.solver.linear)
            guides = SearchGuides(guess=lp.level if lp.status == Status.LIMIT else None,
                                  bound=bound[1] if bound else None, coarser=coarser,
                                  collapse=collapse_check(scene, comm, lp, blocks, solver, pairs, ring, s.tolerance,
                                                          total),
                                  predicted=predictor.predict if predictor is not None else None,
                                  coarser_path=path.guide(solver) if path is not None else None)
            search = find_limit_load(solver, under_load, search_settings(scene, model.dead_weight, coarser),
                                     guides=guides, observers=SearchObservers(report=note, converged=keep))
    except SolveBudgetSpent as spent:
        carried = max((c.load for c in states), default=0.0)
        why = f"not settled within its budget of {spent.budget:g} linear solves (the most live load carried: " \
              f"{carried / 1e3:.6g} kN)"
        search = LimitSearch(Status.failure(why), 0.0, None, s.tolerance, attempted, failure=why)
    lap("limit search")
    joints = joint_states(solver, pairs, ring, search.last) if search.last is not None else []
    verdict = confirm(search.status, search.lower, search.upper, search.proved, lp.status, lp.level, total,
                      fill=fill is not None, slip=slip_check(scene, comm, search, lp, joints, blocks),
                      static=bound[0] if bound else None, closed=search.static)
    search.status, search.upper = verdict.status, verdict.upper
    return Analysis(scene, ring, bm, model, pairs, solver, search, joints, lp, timings, states, verdict,
                    static=bound[0] if bound else None)


def loading_beams(scene: Scene) -> tuple[tuple[float, float], ...]:
    """The x-ranges (m) of the loading beams: one per patch load on a fill with ``[fill] loading_beam`` (the scene
    keeps them apart), none otherwise."""
    if scene.fill is None or not scene.fill.loading_beam:
        return ()
    return tuple(sorted(ld.x_range(scene.arch.span) for ld in scene.loads if ld.kind == "patch"))


def load_displacement(solver: ContactSolver, f_live: PETSc.Vec, live: float) -> Callable[[Iterate], float]:
    """The live load's work-conjugate displacement (m, down positive): delta = f_live . u / P, P = ``live`` (N per
    unit level), i.e. the load-weighted mean settlement of the loaded road. P delta is the live load's work, so the
    curve of P against delta is the one whose flattening (tangent stiffness (f_live' K_t^-1 f_live)^-1 / P^2 -> 0)
    marks plastic collapse, whichever part (the ring's hinges or the fill under the load) gives way. Collective."""
    comm, f = solver.comm, f_live.array.copy()

    def displacement(it: Iterate) -> float:
        return comm.allreduce(float(f @ it.x.array[:solver.n_u])) / live

    return displacement


def rigid_block_check(scene: Scene, comm: MPI.Comm) -> LPResult:
    """The rigid-block LP of the scene's ring on the same joints (:func:`bridgefem.limit.collapse.collapse_load`,
    associative friction), solved on rank 0 and broadcast: the search's guess and the evidence for its verdict. An
    LP that fails gives the status "LP failed: ..." (no guess, no evidence)."""
    lp = None
    if comm.rank == 0:
        try:
            lp = collapse_load(scene)
        except (RuntimeError, ValueError) as err:  # the LP is a check: its failure is reported, not raised
            lp = LPResult(None, None, f"LP failed: {err}")
    return comm.bcast(lp, root=0)


def slip_check(scene: Scene, comm: MPI.Comm, search: LimitSearch, lp: LPResult, joints: list[JointState],
               blocks: BlockModel | None) -> SlipCheck | None:
    """The non-associative rigid-block check (:func:`slip_state`) of an unproven limit with sliding joints that the
    associative LP does not confirm (:func:`bridgefem.analysis.evidence.needs_slip_check`), from the joint forces of the last
    converged step on the rigid ``blocks`` loaded as the FE loads them (None with a fill: no check). Collective; None
    when no check is needed."""
    if not needs_slip_check(search.status, search.lower, search.upper, search.proved, lp.status, lp.level,
                            scene.fill is not None, any(j.sliding for j in joints)):
        return None
    return slip_state(scene, comm, lp, joints, blocks)


def slip_state(scene: Scene, comm: MPI.Comm, lp: LPResult, joints: list[JointState], blocks: BlockModel,
               fixed_point: bool = True) -> SlipCheck:
    """The non-associative rigid-block check of a converged state's ``joints`` (evidence 3 of
    :mod:`bridgefem.analysis.evidence`): the rigid ``blocks`` loaded as the FE loads its voussoirs
    (:func:`bridgefem.analysis.static_bound.fe_blocks`) with their shear capacities frozen at the joints' friction x normal
    force (:func:`frozen_collapse`) and, with ``fixed_point``, the Tresca fixed point from them (its LPs are the
    check's dearest; none of evidence 3's rules asks for it), and the frozen LP under the scene's own block loads
    (:func:`bridgefem.limit.collapse.collapse_state_from`).
    The LPs on rank 0, broadcast (collective)."""
    sliding = tuple(j.id for j in joints if j.sliding)
    out = None
    if comm.rank == 0:
        try:
            normal, frozen, limited = frozen_collapse(joints, blocks)
            fixed = (solve_blocks(blocks, "non-associative", seed=normal) if fixed_point
                     else LPResult(None, None, "not computed", converged=False, iterations=0))
            exact = collapse_state_from(scene, normal, lp.load_sides, max_iterations=1)
            out = SlipCheck(sliding, frozen.level, tuple(frozen.sliding), tuple(frozen.hinges), limited,
                            exact.level, fixed.converged, fixed.level, tuple(fixed.sliding), tuple(fixed.hinges),
                            fixed.iterations)
        except (RuntimeError, ValueError):  # a check that fails confirms nothing
            out = SlipCheck(sliding, None, (), (), (), None, False, None, (), (), 0)
    return comm.bcast(out, root=0)


def frozen_collapse(joints: list[JointState], blocks: BlockModel) -> tuple[np.ndarray, LPResult, tuple[int, ...]]:
    """The ``blocks`` with each joint's shear capacity frozen at mu x its normal force in ``joints``
    (:func:`bridgefem.limit.rigid_block.frozen_capacity_collapse`): the normal forces (N per joint), the LP's result and
    those of its sliding joints where the joints' forces are at their Coulomb limit against the slip
    (:func:`bridgefem.analysis.evidence.coulomb_limited`). Raises RuntimeError or ValueError when the LP fails."""
    normal, shear = np.zeros(blocks.n_joints), np.zeros(blocks.n_joints)
    ids = [j.id for j in joints]
    normal[ids], shear[ids] = [j.normal_force for j in joints], [j.shear_force for j in joints]
    frozen = frozen_capacity_collapse(blocks, normal)
    limited = () if frozen.level is None else coulomb_limited(normal, shear, blocks.friction, frozen.joint_slip,
                                                               frozen.sliding)
    return normal, frozen, limited


def collapse_check(scene: Scene, comm: MPI.Comm, lp: LPResult, blocks: BlockModel | None, solver: ContactSolver,
                   pairs: JointPairs, ring: ArchRing, tolerance: float, unit: float) -> CollapseCheck | None:
    """Evidence 3 at the search's converged states (:class:`bridgefem.search.pathfollow.CollapseCheck`): the frozen LP's
    level of a state whose mechanism slides only where the state's joints are at their Coulomb limit
    (:func:`frozen_collapse`; the search's estimate of the limit), and whether a state at ``lower`` settles the
    bracket [``lower``, ``trial``] of relative width ``tolerance`` (:meth:`bridgefem.analysis.evidence.SlipCheck.settles`),
    with the check in words (``unit``: N of live load per unit level), on the rigid ``blocks`` loaded as the FE loads
    them. None with a fill (``blocks`` None) or without an LP limit (evidence 3 does not apply). Collective."""
    if blocks is None or lp.status != Status.LIMIT or lp.level is None:
        return None

    def level(state: Iterate) -> float | None:
        joints, out = joint_states(solver, pairs, ring, state), None
        if comm.rank == 0:
            try:
                _, frozen, limited = frozen_collapse(joints, blocks)
                out = frozen.level if frozen.sliding and set(frozen.sliding) == set(limited) else None
            except (RuntimeError, ValueError):  # no estimate
                out = None
        return comm.bcast(out, root=0)

    def settles(lower: float, trial: float, state: Iterate) -> tuple[bool, str]:
        slip = slip_state(scene, comm, lp, joint_states(solver, pairs, ring, state), blocks, fixed_point=False)
        return slip.settles(lower, trial, lp.level, tolerance), slip.describe(unit)

    return CollapseCheck(level, settles)


def pair_properties(scene: Scene, ring: ArchRing, pairs: JointPairs) -> tuple[np.ndarray, np.ndarray]:
    """Per local pair: the Young's modulus (Pa) of the softer side and the Coulomb coefficient. Ring joints:
    the masonry's and the joints' mu; on elastic abutments the springing and base joints take the softer of
    masonry and abutment, and the bases the abutments' mu; the arch-fill interface: the fill's."""
    young = np.full(len(pairs), scene.masonry.young)
    friction = np.full(len(pairs), scene.joints.friction)
    ab, fill = scene.abutments, scene.fill
    if ab.elastic:
        bases = [j.id for j in ring.bases]
        young[np.isin(pairs.joint, [j.id for j in ring.springings] + bases)] = min(ab.young, scene.masonry.young)
        friction[np.isin(pairs.joint, bases)] = ab.friction
    if fill is not None:
        interface = pairs.joint == ARCH_FILL
        young[interface], friction[interface] = fill.young, fill.interface_friction
    return young, friction


def joint_states(solver: ContactSolver, pairs: JointPairs, ring: ArchRing, it: Iterate) -> list[JointState]:
    """Per-joint resultants, hinges and sliding at a converged iterate (identical on every rank)."""
    _, lam, d = solver.system.split(it.x)
    local = np.column_stack([pairs.joint, lam, pairs.position, pairs.length, it.active.state, it.active.sign,
                             d[:, 0]])
    table = np.vstack(solver.comm.allgather(local))
    states = []
    for jt in (j for j in ring.joints if not j.free):
        rows = table[table[:, 0] == jt.id]
        lam_n, lam_t, pos, length, st, sign, gap = rows[:, 1:8].T
        n_force = lam_n.sum()
        ecc = float((lam_n * (pos - jt.length / 2)).sum() / n_force) if n_force > 0 else 0.0
        closed = st != OPEN
        slip_signs = set(sign[closed & (st == SLIP)])
        sliding = int(slip_signs.pop()) if closed.any() and np.all(st[closed] == SLIP) and len(slip_signs) == 1 else 0
        states.append(JointState(jt.id, float(n_force), float(lam_t.sum()), ecc,
                                 float(length[~closed].sum() / length.sum()), float(gap[~closed].max(initial=0.0)),
                                 sliding))
    _mark_hinges(states, ring)
    return states


@dataclass
class InterfaceForces:
    """What the fill exerts on the ring across the arch-fill interface at one converged state: one row per interface
    pair, identical on every rank, sorted by x. ``points`` (k, 2): the ring-side node (m); ``blocks`` (k,): the
    voussoir it belongs to; ``forces`` (k, 2): the force on that node (N, x and y, whole width); ``normal`` (k,):
    the interface's compression lam_n (N, >= 0); ``shear`` (k,): lam_t (N), the force on the fill along the pair's
    tangent (its normal, from the ring into the fill, turned +90 degrees). The ring receives
    ``-(lam_n n + lam_t tau)``: the multipliers are nodal forces, so these rows balance the ring's nodes exactly."""

    points: np.ndarray
    blocks: np.ndarray
    forces: np.ndarray
    normal: np.ndarray
    shear: np.ndarray


def interface_forces(an: Analysis, it: Iterate) -> InterfaceForces:
    """The arch-fill interface forces on the ring at a converged iterate (collective; empty without a fill)."""
    solver, pairs, V, bm = an.solver, an.pairs, an.model.V, an.block_mesh
    comm = solver.comm
    imap = V.dofmap.index_map
    n_owned = imap.size_local
    facets = bm.facet_tags.indices[bm.facet_tags.values == EXTRADOS_TAG]
    nodes = fem.locate_dofs_topological(V, 1, facets)
    nodes = nodes[nodes < n_owned]
    node_block = node_blocks(V, bm)
    coords = V.tabulate_dof_coordinates()[:, :2]
    table = np.vstack(comm.allgather(np.column_stack([imap.local_to_global(nodes.astype(np.int32)), coords[nodes],
                                                      node_block[nodes]])))
    table = table[np.argsort(table[:, 0])]
    _, lam, _ = solver.system.split(it.x)
    on = pairs.joint == ARCH_FILL
    local = np.column_stack([pairs.left[on], pairs.normal[on], pairs.tangent[on], lam[on]])
    rows = np.vstack(comm.allgather(local))
    at = np.searchsorted(table[:, 0], rows[:, 0]) if len(table) else np.zeros(0, int)
    if len(rows) and not np.array_equal(table[np.minimum(at, len(table) - 1), 0], rows[:, 0]):
        raise RuntimeError("arch-fill interface: a ring-side node is not on the extrados")
    ring_rows = table[at]
    forces = -(rows[:, 5:6] * rows[:, 1:3] + rows[:, 6:7] * rows[:, 3:5])
    order = np.argsort(ring_rows[:, 1], kind="stable")
    return InterfaceForces(ring_rows[order, 1:3], ring_rows[order, 3].astype(int), forces[order],
                           rows[order, 5], rows[order, 6])


@dataclass
class TransmittedLoadCheck:
    """The ring's rigid-block LP under the loads the fill transmits (:func:`transmitted_load_check`).

    ``fe_level``: the FE's last converged load level P_L (N per unit load factor); ``lp_level``: the LP's
    collapse load level lambda (same unit) under dead load = ring weight + interface forces after self-weight and live
    load = (interface forces at P_L - those after self-weight) / P_L; ``ratio`` = lambda / P_L (None when the LP
    finds no limit load); ``lp``: the LP result (its mechanism)."""

    fe_level: float
    lp_level: float | None
    ratio: float | None
    lp: LPResult


def transmitted_load_check(an: Analysis, friction_model: str = "associative") -> TransmittedLoadCheck | None:
    """The ring under the loads the fill transmits: a lower-bound check of the FE limit with a fill.

    The FE state at the last converged level P_L balances every voussoir (self-weight, the interface forces, the
    joint forces) with joint forces that obey no tension and Coulomb friction pair by pair, so it is statically
    admissible for the ring's rigid-block LP (:func:`bridgefem.limit.ring_blocks.ring_under_forces`) with the dead load
    F_S (interface forces after self-weight) and the live load (F_L - F_S) / P_L: the LP's lambda >= P_L (up to
    the LP's polygonal voussoirs against the mesh). When the FE limit is a mechanism of the ring (the fill only
    passes loads on), the ring under F_L is itself at collapse and lambda ~ P_L; lambda well above P_L means the
    fill carried the rest by changing how it loads the ring (its stiffness or strength restrains the mechanism).
    Computed on rank 0 and broadcast; None without a fill, a live load or a converged live-load step above 0; an LP
    that fails is reported in ``lp.status`` ("LP failed: ...").
    """
    s = an.search
    if an.scene.fill is None or not an.scene.loads or s.settled is None or s.last is None or not s.lower > 0:
        return None
    dead, live = interface_forces(an, s.settled), interface_forces(an, s.last)
    out = None
    if an.solver.comm.rank == 0:
        increment = (live.forces - dead.forces) / s.lower  # N per unit load level
        model = ring_under_forces(an.scene, dead.blocks, dead.points, dead.forces, increment)
        try:
            lp = solve_blocks(model, friction_model)
        except RuntimeError as err:  # a check, never the reason a run fails: report it
            lp = LPResult(None, None, f"LP failed: {err}", friction_model)
        ratio = lp.level / s.lower if lp.level is not None else None
        out = TransmittedLoadCheck(s.lower, lp.level, ratio, lp)
    return an.solver.comm.bcast(out, root=0)


def springing_reactions(joints: list[JointState], ring: ArchRing) -> np.ndarray:
    """Force (N; x, y) of the ground on the structure at each joint on the ground, rows in joint order: the
    springings on rigid abutments, the abutments' bases on elastic ones.

    A joint's resultant (normal force along its normal, shear along its tangent) acts on its right face, so
    the ground pushes the ring with +resultant where the ground is the left block and -resultant otherwise.
    """
    out = []
    for js in joints:
        jt = ring.joints[js.id]
        if jt.left is None or jt.right is None:
            force = js.normal_force * jt.normal + js.shear_force * jt.tangent
            out.append(force if jt.left is None else -force)
    return np.array(out)


def _mark_hinges(states: list[JointState], ring: ArchRing) -> None:
    cracked = [s.open_fraction >= HINGE_OPEN_FRACTION
               or abs(s.eccentricity) >= HINGE_ECCENTRICITY * ring.joints[s.id].length for s in states]

    def adjacent(a: JointState, b: JointState) -> bool:
        blocks = {ring.joints[a.id].left, ring.joints[a.id].right} & {ring.joints[b.id].left, ring.joints[b.id].right}
        return bool(blocks - {None})

    run: list[JointState] = []
    for s, c in zip(states + [None], cracked + [False]):
        if c and run and adjacent(s, run[-1]) and np.sign(s.eccentricity) == np.sign(run[-1].eccentricity):
            run.append(s)
            continue
        if run:
            best = max(run, key=lambda r: (round(abs(r.eccentricity) / ring.joints[r.id].length / HINGE_TIE),
                                           r.opening))
            best.hinge = "extrados" if best.eccentricity > 0 else "intrados"
        run = [s] if c else []
