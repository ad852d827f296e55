"""The FE limit analysis of a scene (:func:`run_analysis`): the live load at which no equilibrium of elastic voussoirs
with unilateral frictional joints exists, bracketed by load incrementation and checked against the rigid-block limit
analysis of the same joints (the method of the seed paper, Drosopoulos, Stavroulakis & Massalas 2006, with the
rigid-block LP of Livesley 1978 and Gilbert & Melbourne 1994 as its independent check).

**The algorithm.** One run of one mesh (:func:`_analyse`):

1. Build the FE model: scene -> ring -> mesh -> rigid-block LP -> elastic model -> joint pairs -> contact solver
   (:mod:`bridgefem.analysis.build`).
2. On a bare ring, the static theorem's bound: the rigid-block LP on the same joints under the FE's own block loads
   bounds every FE equilibrium (:mod:`bridgefem.analysis.static_bound`; evidence 4 of
   :mod:`bridgefem.analysis.evidence`).
3. The limit search (:mod:`bridgefem.search.pathfollow`), with its settings from the scene's keys
   (:func:`search_settings`) and its guides: the LP's level as a guess (not with a fill, whose strength and stiffness
   the LP leaves out: *The LP is no guess with a fill*), the static bound, a coarser run's level and
   path, the collapse-state check at its converged states (:func:`bridgefem.analysis.checks.collapse_check`; under
   an elastic fill :func:`bridgefem.analysis.interface.fill_collapse_check`) and,
   on a bare ring, a predicted state for a failed trial (:class:`bridgefem.solver.tresca.TrescaPredictor`). It
   measures the deflection under the live load: the mean of the monitored nodes, or with a plastic fill the live
   load's work-conjugate displacement (:func:`load_displacement`).
4. The mechanism at the last converged step (:mod:`bridgefem.analysis.mechanism`) and the verdict: the search's
   outcome stands only with evidence (a proved mechanism, agreement with the LP, a collapse state of the rigid
   blocks, the static theorem: :mod:`bridgefem.analysis.evidence`, with the slip check of
   :func:`bridgefem.analysis.checks.slip_check`), else it is a solver failure.

Then, for the scene (:func:`run_analysis`):

5. Re-runs on finer meshes while a finer mesh can settle the run (:mod:`bridgefem.analysis.refinement`).
6. The collective read-outs of the last run, done once on every rank (:func:`_conclude`): the conic bounds of the
   bridge with its fill (:func:`bridgefem.limit.bounds.fill_bounds`; computed once for steps 5 and 6, by a process
   alone with a core to spare on a thread of their own from the start, beside steps 1-5:
   :class:`bridgefem.limit.bounds.SceneBounds`; they depend on the scene, not on its mesh), the verdict of a
   self-weight that found no equilibrium where those bounds prove the bridge cannot stand (evidence 6,
   :func:`bridgefem.analysis.evidence.dead_load_collapse`), the ring under the loads the fill transmits
   (:mod:`bridgefem.analysis.interface`), the collapse mode (:mod:`bridgefem.analysis.mechanism`) and the warnings
   (:mod:`bridgefem.analysis.result`). Reading the returned :class:`bridgefem.analysis.result.Analysis` is then local
   on every rank.

**Load vocabulary.** The *load level* P (N per unit ``factor``; ``LoadStep.level`` in
:mod:`bridgefem.search.records`, ``LPResult.level`` in :mod:`bridgefem.limit.rigid_block`) scales the scene's live
loads, each ``factor`` x P; the *live load* is P x the sum of the factors (N, ``Analysis.load_total`` per unit
level), the ``load`` of results.json.

Safeguards:

- *The LP is no guess with a fill* (step 3): the LP takes the fill for dead load, leaving out its strength and
  stiffness, with which the fill can carry the live load far beyond the rings' collapse (Prestwood's Mohr-Coulomb
  fill twice the LP's level, the campaign's elastic fills a median 7 times it) or fail under it first (a loading
  beam's bearing failure, far below); a search steered by that level approaches it in ever shorter steps and
  starts again from the bracket's width above it, where nothing happens. Without a guess the steps grow from the
  first one until a failure; the bracket rule, the retries, the collapse-state readings and a plastic fill's floor
  guard the verdict as before.
- *The live load's own displacement with a plastic fill* (step 3): a plastic fill can fail under the load before
  the ring does, so the flat-curve test watches the loaded road; an elastic fill cannot, and its elastic settlement
  would hide the ring's mechanism from that test, so there it watches the ring.
- *An exact solve budget* (step 5): a re-run's search that spends its budget ends as a failure that names the most
  load it carried, never as a partial bracket; a re-run that converges beyond the confirmed run's level by more
  than ``SETTLED_MOVE`` (or the search's tolerance) has its budget lifted, since it no longer refines that run.
- *Collective read-outs once* (step 6): no attribute of a result waits for the other ranks, so reading a warning on
  one rank cannot hang.
"""
from __future__ import annotations

import logging
import math
from contextlib import contextmanager
from typing import Callable

from mpi4py import MPI
from petsc4py import PETSc

from ..limit.bounds import SceneBounds, fill_bounds, spare_core
from ..limit.rigid_block import BlockModel
from ..scene.model import Scene
from ..search.coarser_path import CoarserPath
from ..search.pathfollow import find_limit_load
from ..search.records import LimitSearch, LoadStep, SearchGuides, SearchObservers, SearchSettings, StaticCap
from ..search.step import monitor_deflection
from ..solver.condensed import CondensedPredictor
from ..solver.linear import SolveBudgetSpent
from ..solver.newton import ContactSolver, Iterate
from ..solver.tresca import TrescaPredictor
from ..status import Status
from ..structure.sizing import MAX_DOFS
from .build import BridgeModel, Clock, JointLawFactory, build_model
from .checks import PairCheck, collapse_check, slip_check
from .evidence import confirm, dead_load_collapse
from .interface import fill_collapse_check, transmitted_load_check
from .mechanism import collapse_mode, joint_states
from .refinement import MAX_REFINEMENTS, SETTLED_MOVE, coarse_stress_block, refine
from .result import Analysis, ConvergedState, user_warnings
from .static_bound import fe_blocks, static_cap


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
                 max_refinements: int = MAX_REFINEMENTS, max_dofs: float = MAX_DOFS,
                 joint_law: JointLawFactory | None = None, enough: float | Callable[[], float] = math.inf
                 ) -> Analysis:
    """Compute the limit load of a scene (module docstring, steps 1-6): the ring, with its fill and elastic
    abutments when the scene has them, after the support movement it imposes. Collective over ``comm``;
    ``petsc_options`` go over the scene's; ``phase(name)`` announces each set-up phase, ``report(step)`` each load
    step and ``notice(line)`` each re-run on a finer mesh, of which there are at most ``max_refinements``, each within
    ``max_dofs`` unknowns (:mod:`bridgefem.analysis.refinement`); ``joint_law`` builds the joints' law
    (:data:`bridgefem.analysis.build.JointLawFactory`; None: the scene's,
    :func:`bridgefem.laws.crushing.scene_law_factory`). ``enough`` (N of live load): carrying it ends the search as
    "locked" for a caller that asks only whether the bridge carries it, the path unchanged; or a function giving it,
    asked before every load step (collective: the same on every rank of ``comm``), for a caller whose ``enough`` can
    fall while the run goes on (:class:`bridgefem.search.records.SearchSettings`). The last run is returned, the runs it replaced listed in
    ``Analysis.refinements``."""
    def analyse(mesh_scene: Scene, coarser: float | None, budget: int | None, path: CoarserPath | None) -> Analysis:
        return _analyse(mesh_scene, comm, petsc_options, report, phase, coarser, budget, path, joint_law, enough,
                        lower_bound)

    with quiet_compiler():
        # the conic bounds of a fill, once (steps 5-6): a process alone in its run (not one of an assessment's
        # groups) with a core to spare solves them beside the search
        plastic = scene.fill is not None and scene.fill.material == "mohr-coulomb"  # the fills the bounds cover
        known = SceneBounds(scene, comm, ahead=spare_core(MPI.COMM_WORLD)) if plastic else None
        waited: dict[str, float] = {}

        def wait_for(read: Callable[[SceneBounds], float | None]) -> float | None:
            """A bound (N) ``read`` off the scene's bounds, the wait timed as the phase "conic bounds"."""
            if known is None:
                return None
            clock = Clock(comm)
            value = read(known)
            clock.lap("conic bounds")
            waited["conic bounds"] = waited.get("conic bounds", 0.0) + clock.timings["conic bounds"]
            return value

        def upper_bound() -> float | None:  # the refinement's
            return wait_for(lambda bounds: bounds.upper())

        def lower_bound(compared: float) -> float | None:  # the search's floor (bridgefem.search.step, *Flat curve*)
            return wait_for(lambda bounds: bounds.lower(compared))
        an = refine(scene, comm, analyse, notice, max_refinements, max_dofs, upper_bound)
        _conclude(an, comm, known)
        an.timings.update(waited)
    return an


def _per_level(load: float | None, total: float) -> float | None:
    """A load (N; None: none) as a live-load level, N per unit load factor of the ``total`` live load."""
    return load / total if load else None


def _conclude(an: Analysis, comm: MPI.Comm, known: SceneBounds | None = None) -> None:
    """The collective read-outs of the run ``an`` (module docstring, step 6), done once on every rank and stored on
    it as plain data: the conic bounds of the bridge with its fill (the static programme on rank 0, the kinematic one
    on rank 1 at the same time: :func:`bridgefem.limit.bounds.fill_bounds`; broadcast; ``known``: the scene's,
    computed once, :class:`bridgefem.limit.bounds.SceneBounds`), the verdict of evidence 6 where they prove that a
    self-weight without an FE equilibrium has none, the ring under the loads the fill transmits, the collapse mode
    and the warnings; timed as the phase "checks". Collective."""
    clock = Clock(comm)
    solver_comm = an.solver.comm
    compared = an.search.upper * an.load_total if an.search.upper is not None else None  # the FE's upper end (N)
    an.fill_bounds = solver_comm.bcast(fill_bounds(an.scene, compared, solver_comm, known), root=0)
    proved = dead_load_collapse(an.search.status, an.search.settled is not None, an.fill_bounds, an.lp.status)
    if proved is not None:  # evidence 6: no equilibrium under self-weight exists
        an.verdict, an.search.status, an.search.upper = proved, proved.status, proved.upper
    an.ring_check = transmitted_load_check(an)
    an.collapse_mode = collapse_mode(an.model, an.block_mesh, an.ring, [c.u for c in an.converged])
    coarse = coarse_stress_block(an)  # with crushing: a mesh too coarse for the stress block, after the re-runs
    an.warnings = user_warnings(an) + ([f"{coarse}: the limit load is the mesh's stress block's, above the "
                                        "strength's; raise [mesh] elements_through_thickness"] if coarse else [])
    clock.lap("checks")
    an.timings.update(clock.timings)


def _analyse(scene: Scene, comm: MPI.Comm, petsc_options: dict | None,
             report: Callable[[LoadStep], None], phase: Callable[[str], None],
             coarser: float | None = None, budget: int | None = None, path: CoarserPath | None = None,
             joint_law: JointLawFactory | None = None, enough: float | Callable[[], float] = math.inf,
             lower_bound: Callable[[float], float | None] = lambda compared: None) -> Analysis:
    """One run of the scene's mesh (module docstring, steps 1-4); ``coarser``: the last converged level (N per unit
    load factor) of the run on a coarser mesh that this one re-runs (:func:`first_step`), None on a first run, and
    ``path`` that run's converged path, a bare ring's (its trials start from it: :mod:`bridgefem.search.coarser_path`);
    ``budget``: the linear solves its search may spend (None: no limit), exactly; a failure when spent; ``joint_law``
    builds the joints' law; ``enough`` as in :func:`run_analysis`; ``lower_bound(compared)``: a proved lower bound of
    the scene's collapse load (N; None: none) decided against the load ``compared`` (N), the search's floor.
    Collective."""
    clock = Clock(comm)
    fe = build_model(scene, comm, petsc_options, phase, clock, joint_law)
    phase("limit search")
    bare = scene.fill is None
    blocks = fe_blocks(scene, fe.model, fe.block_mesh, fe.ring) if bare else None  # the blocks loaded as the FE loads
    bound = static_cap(blocks, fe.model, fe.block_mesh, fe.pairs, fe.solver) if bare else None
    clock.lap("static bound")
    contacts = PairCheck.of(scene, comm, fe.lp, blocks, fe.solver, fe.pairs, fe.ring)  # a barrel: evidence 3 on pairs
    search, states = _search(scene, comm, fe, blocks, bound[1] if bound else None, report, coarser, budget, path,
                             enough, contacts, lower_bound)
    clock.lap("limit search")
    solver, lp, total = fe.solver, fe.lp, scene.live_per_level
    joints = joint_states(solver, fe.pairs, fe.ring, search.last) if search.last is not None else []
    verdict = confirm(search.status, search.lower, search.upper, search.proved, lp.status, lp.level, total,
                      fill=not bare, slip=slip_check(scene, comm, search, lp, joints, blocks, contacts),
                      static=bound[0] if bound else None, closed=search.static, failure=search.failure)
    search.status, search.upper = verdict.status, verdict.upper
    return Analysis(scene, fe.ring, fe.block_mesh, fe.model, fe.pairs, solver, search, joints, lp, clock.timings,
                    states, verdict, static=bound[0] if bound else None)


def _search(scene: Scene, comm: MPI.Comm, fe: BridgeModel, blocks: BlockModel | None, bound: StaticCap | None,
            report: Callable[[LoadStep], None], coarser: float | None, budget: int | None, path: CoarserPath | None,
            enough: float | Callable[[], float], contacts: PairCheck | None,
            lower_bound: Callable[[float], float | None]) -> tuple[LimitSearch, list[ConvergedState]]:
    """The limit search of one run (module docstring, step 3) on the model ``fe``, with the rigid ``blocks`` loaded
    as the FE loads them and the static ``bound`` (None with a fill); returns the search and its converged states,
    each kept for the output's time series and a re-run's coarser path. A search that spends its ``budget`` of linear
    solves is a failure (:func:`_analyse`); ``enough`` (N) as in :func:`run_analysis`; ``contacts``: a barrel's
    evidence 3 on its own pairs (:class:`bridgefem.analysis.checks.PairCheck`; None elsewhere); ``lower_bound``
    as in :func:`_analyse`. Collective."""
    solver, model, s = fe.solver, fe.model, scene.solver
    # a plastic fill can fail under the load before the ring does: watch the load's own displacement; an elastic
    # fill cannot, and its elastic settlement would hide the ring's mechanism from the flat-curve test
    under_load = (load_displacement(solver, model.f_live, model.live_per_level)
                  if solver.material is not None and model.live_per_level > 0
                  else monitor_deflection(solver, model.monitor))
    total = scene.live_per_level
    states: list[ConvergedState] = []
    attempted: list[LoadStep] = []

    def note(step: LoadStep) -> None:  # every attempted step, kept for a search that its budget stops
        attempted.append(step)
        report(step)

    # a failed trial's predicted state (bridgefem.solver.tresca) and a failed self-weight's
    # (bridgefem.solver.condensed): every structure without a fill
    predictor = TrescaPredictor(solver) if scene.fill is None else None
    condensed = CondensedPredictor(solver) if scene.fill is None else None
    lp = fe.lp
    # the LP leaves out a fill's strength and stiffness (module docstring, *The LP is no guess with a fill*)
    guess = lp.level if lp.status == Status.LIMIT and scene.fill is None else None
    try:
        with solver.linear.limited(budget) as lift:  # exact: the solve past it raises (bridgefem.solver.linear)
            def keep(step: LoadStep, it: Iterate) -> None:  # every converged state: the fields' time series, a
                # re-run's path; a budgeted re-run that carries a level the confirmed run did not has moved its limit
                u, lam, d = solver.system.split(it.x)
                states.append(ConvergedState(step.index, step.level * total, u.copy(), it.active.state.copy(),
                                             lam.copy(), d.copy()))
                if coarser is not None and step.level > (1 + max(s.tolerance, SETTLED_MOVE)) * coarser:
                    lift()

            guides = SearchGuides(guess=guess, bound=bound, coarser=coarser,
                                  collapse=collapse_check(scene, comm, lp, blocks, solver, fe.pairs, fe.ring,
                                                          s.tolerance, total, contacts)
                                  or fill_collapse_check(scene, solver, fe.pairs, model.V, fe.block_mesh, s.tolerance,
                                                         total),
                                  predicted=predictor.predict if predictor is not None else None,
                                  self_weight_states=condensed.states if condensed is not None else None,
                                  coarser_path=path.guide(solver) if path is not None else None,
                                  floor=lambda level: _per_level(lower_bound(level * total), total))
            level = (lambda: enough() / total) if callable(enough) else enough / total
            settings = search_settings(scene, model.dead_weight, coarser, level)
            search = find_limit_load(solver, under_load, settings,
                                     guides=guides, observers=SearchObservers(report=note, converged=keep))
    except SolveBudgetSpent as spent:
        carried = max((c.load for c in states), default=0.0)
        why = f"not settled within its budget of {spent.budget:g} linear solves (the most live load carried: " \
              f"{carried / 1e3:.6g} kN)"
        search = LimitSearch(Status.failure(why), 0.0, None, s.tolerance, attempted, failure=why)
    return search, states


def first_step(dead_weight: float, coarser: float | None = None) -> float:
    """The first live-load step (N per unit load factor) when the scene sets none: a quarter of the ring's
    ``dead_weight`` (N), or on a re-run the level the coarser mesh's run reached, ``coarser``, when that is larger.

    The step bounds every step that approaches the search's target (:mod:`bridgefem.search.schedule`, *Steps*); a
    re-run's target is at most the coarser run's level (:mod:`bridgefem.search.target`, *Guess*), which the
    approach then reaches in halves of the distance left, not in steps of a quarter of the ring's weight. The step
    sets the path, never what counts as converged or as a bracket (the bracket rule is the search's)."""
    return max(dead_weight / 4, coarser or 0.0)


def search_settings(scene: Scene, dead_weight: float, coarser: float | None = None,
                    enough: float | Callable[[], float] = math.inf) -> SearchSettings:
    """The limit search's settings from the scene's keys, their zeros resolved: the first step :func:`first_step`
    of the ring's ``dead_weight`` (N) and the ``coarser`` run's last converged level (N per unit load factor; None on
    a first run), the maximum load 100 x ``dead_weight`` (0 without live loads: self-weight only); the flat-curve
    check only with a fill, the support movement's increments only where a support moves; ``enough``: the level (N
    per unit load factor) of :func:`run_analysis`'s ``enough`` load, or the function giving it."""
    s, abutments = scene.solver, scene.abutments
    return SearchSettings(tolerance=s.tolerance, initial_step=s.initial_step or first_step(dead_weight, coarser),
                          max_load=(s.max_load or 100 * dead_weight) if scene.loads else 0.0, max_steps=s.max_steps,
                          stiffness_drop=s.stiffness_drop if scene.fill is not None else 0.0,
                          movement_steps=abutments.movement_steps if abutments.moves else 0,
                          enough=enough)


def load_displacement(solver: ContactSolver, f_live: PETSc.Vec, live: float) -> Callable[[Iterate], float]:
    """The live load's work-conjugate displacement (m, down positive): delta = f_live . u / P, P = ``live`` (N per
    unit level), i.e. the load-weighted mean settlement of the loaded road. P delta is the live load's work, so the
    curve of P against delta is the one whose flattening (tangent stiffness (f_live' K_t^-1 f_live)^-1 / P^2 -> 0)
    marks plastic collapse, whichever part (the ring's hinges or the fill under the load) gives way. Collective."""
    comm, f = solver.comm, f_live.array.copy()

    def displacement(it: Iterate) -> float:
        return comm.allreduce(float(f @ it.x.array[:solver.n_u])) / live

    return displacement
