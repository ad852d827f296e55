"""Lower and upper collapse bounds of a bridge with its fill, by conic optimisation (an independent check).

The rigid-plastic model of :mod:`bridgefem.limit.bounds_model` (rigid voussoirs and abutment blocks with
no-tension Coulomb joints as in the rigid-block LP; the fill a plane-strain Mohr-Coulomb continuum with
associated flow on a triangle mesh; no-tension Coulomb arch-fill interface; fixed fill base, roller ends; dead
load = voussoirs' and fill's weight; the scene's live-load pattern on the road) has a collapse load factor
between the static bound of :mod:`bridgefem.limit.bounds_lower` and the kinematic bound of
:mod:`bridgefem.limit.bounds_upper`. Without a fill both equal the rigid-block LP. Loads in N for the arch's width.

:func:`collapse_bounds`:

1. builds the problem (:func:`bridgefem.limit.bounds_model.bridge_problem`): the ring's blocks, the fill's triangles
   at the mesh size ``min(ring thickness / 2, fill depth over the crown) / refine`` near the ring, a rigid loading
   beam under each patch;
2. solves the static programme (Makrodimopoulos & Martin 2006) for the lower bound and its stress field;
3. solves the kinematic programme (Makrodimopoulos & Martin 2007) for the upper bound and its mechanism, the block
   and soil velocities being its equality duals;
4. reports the blocks' part of that mechanism as the rigid-block LP does (:func:`upper_mechanism`).

Steps 2 and 3 are independent: under MPI (two ranks or more) each runs on its own rank at the same time, and a
process alone with a core to spare (:func:`spare_core`) solves them on two threads at once (:func:`problem_bounds`;
Clarabel releases Python's lock while it iterates). :class:`SceneBounds` solves both on a thread of their own while
its caller goes on with other work (the FE search), the problem built first on the caller's thread (Gmsh is one
state per process: never two meshes at once).

Both are second-order cone programmes solved by Clarabel (:mod:`bridgefem.limit.conic`); a refinement narrows the
gap between them at a cost that grows faster than the number of triangles.

**Accuracy.** Clarabel stops each programme at ``conic.MAX_ITERATIONS`` iterations, reporting "optimal (reduced
accuracy)" where its relaxed tolerances (residuals within 1e-4 of the data's scale) are met. Both programmes
maximise the load factor; their iterates satisfy the equalities only to the tolerance reached, and in every case
measured (docs/bounds.md) the objective falls towards the optimum as the iterations go on. A capped upper bound is
then looser, not wrong. A capped lower bound is usually within 1e-4 of its optimum, but where the live load is small
against the fill's weight an equilibrium residual within the tolerance carries several per cent of it, and the
capped value can lie above the collapse load. :func:`fill_bounds` therefore:

1. solves both programmes with the cap;
2. where the lower bound is compared with a load (the FE bracket's upper end) and its programme stopped short of
   Clarabel's full tolerances, either above that load or without a value (not even the relaxed tolerances within the
   cap), solves the static programme again with up to ``CHECK_ITERATIONS`` iterations;
3. reports that solve's value as the lower bound when it reached the full tolerances, fell to the compared load or
   below, or stayed within ``SETTLED`` of the capped value (the cap had reached the optimum); else no lower bound,
   the value still falling above the compared load (or none): the comparison is undecided.
"""
from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..scene.keys import SceneError
from ..scene.model import Scene
from .bounds_lower import lower_bound
from .bounds_model import LimitProblem, bridge_problem
from .bounds_upper import upper_bound
from .rigid_block import joint_mechanism, joint_motion

CHECK_ITERATIONS = 200  # the static programme's interior-point iterations where its capped value lies above the
# load it is compared with (module docstring, *Accuracy*): Clarabel's own default cap
SETTLED = 1e-3  # a solve with more iterations within this fraction of the capped value: the cap had reached the optimum
BOUNDS_MODEL = ("rigid voussoirs with no-tension Coulomb joints (associative), the fill a plane-strain "
                "Mohr-Coulomb continuum (associated flow; cut-off on the in-plane mean stress), no-tension Coulomb "
                "arch-fill interface, fixed fill base, roller ends")


@dataclass
class Bound:
    """One bound: status ("optimal", "optimal (reduced accuracy)", "infeasible" = the dead load cannot be
    carried, "unbounded" = no collapse, or "solver failure: ..."), load (N; None unless optimal), level,
    Clarabel iterations, seconds, sizes (unknowns, equalities, inequalities, cones)."""

    status: str
    load: float | None
    level: float | None
    iterations: int
    seconds: float
    sizes: dict


@dataclass
class Bounds:
    """Lower and upper bounds of a scene, the mesh (triangles, size near the ring in m; None without fill),
    wall time per phase (s), and the fields: fill stresses (ne, 3 vertices, sx sy txy; Pa) of the lower bound,
    block velocities (nb, 3: u, v, omega; live-load power 1; voussoirs, abutment blocks, then the loading
    beams) and soil node velocities (n, 2) of the upper bound (for plots)."""

    lower: Bound
    upper: Bound
    mesh: dict | None
    timings: dict
    stress: np.ndarray | None = None
    block_velocities: np.ndarray | None = None
    soil_velocities: np.ndarray | None = None
    problem: LimitProblem | None = field(default=None, repr=False)
    capped: Bound | None = None  # the static programme's bound at its cap, once solved again (:func:`decide_lower`)


def _bound(problem: LimitProblem, solve) -> tuple[Bound, object, dict]:
    sol, layout = solve(problem)
    lam = sol.x[layout["factor"]] if sol.status.startswith("optimal") else None
    load = None if lam is None else float(lam * problem.live_total)
    return Bound(sol.status, load, None if lam is None else float(lam), sol.iterations, sol.seconds,
                 sol.sizes), sol, layout


def spare_core(comm=None) -> bool:
    """Whether this process runs alone (``comm``, every process of the run, None or of one rank) and may use more
    than one core: then independent work can go on a thread of its own (under MPI every rank keeps its core busy;
    Open MPI binds each of a few ranks to one core)."""
    return (comm is None or comm.size == 1) and len(os.sched_getaffinity(0)) > 1


class OnThread:
    """A call on a daemon thread of its own (a process that ends does not wait for it), started at once;
    :meth:`result` waits for it and returns its value or raises its exception on the caller's thread."""

    def __init__(self, call: Callable[[], object]):
        self._out: dict = {}
        self._thread = threading.Thread(target=self._run, args=(call,), daemon=True)
        self._thread.start()

    def _run(self, call: Callable[[], object]) -> None:
        try:
            self._out["value"] = call()
        except BaseException as err:  # handed to the caller's thread by result()
            self._out["error"] = err

    def result(self):
        self._thread.join()
        if "error" in self._out:
            raise self._out["error"]
        return self._out["value"]


def problem_bounds(problem: LimitProblem, comm=None, threads: bool = False) -> Bounds | None:
    """Both bounds of a :class:`LimitProblem`. With ``comm`` of two ranks or more (an mpi4py communicator; None: this
    process alone) the two programmes are independent work: rank 0 solves the static one and rank 1 the kinematic
    one at the same time, and rank 0 returns the bounds, the other ranks None; a process alone with ``threads``
    solves the static one on a thread of its own while it solves the kinematic one. Collective over ``comm``."""
    rank, size = (0, 1) if comm is None else (comm.rank, comm.size)
    if size == 1 and threads:
        static = OnThread(lambda: _static_part(problem))
        upper = _kinematic_part(problem)
        lower = static.result()
    else:
        lower = _static_part(problem) if rank == 0 else None
        upper = _kinematic_part(problem) if rank == min(1, size - 1) else None
    if size > 1:
        upper = comm.gather(upper, root=0)
        upper = upper[1] if rank == 0 else None
    if rank != 0:
        return None
    (lo, stress, t_lower), (up, block_velocities, soil_velocities, t_upper) = lower, upper
    mesh = problem.mesh
    return Bounds(lo, up, None if mesh is None else {"triangles": mesh.n_triangles, "size": problem.size},
                  {"lower": t_lower, "upper": t_upper}, stress, block_velocities, soil_velocities, problem=problem)


def _static_part(problem: LimitProblem) -> tuple[Bound, np.ndarray | None, float]:
    """The lower bound, its fill stresses (None without a fill or an optimum) and its wall time (s)."""
    start = time.perf_counter()
    lower, sol, layout = _bound(problem, lower_bound)
    stress = sol.x[layout["stress"]].reshape(-1, 3, 3) if lower.load is not None and problem.mesh is not None else None
    return lower, stress, time.perf_counter() - start


def _kinematic_part(problem: LimitProblem) -> tuple[Bound, np.ndarray | None, np.ndarray | None, float]:
    """The upper bound, its block and soil velocities (None without an optimum; soil: without a fill) and its wall
    time (s)."""
    start = time.perf_counter()
    upper, sol, layout = _bound(problem, upper_bound)
    blocks = soil = None
    if upper.load is not None:
        z = layout["velocities"] @ sol.z["zero"]
        n_free = len(layout["free"])
        blocks = z[n_free:].reshape(-1, 3)
        if problem.mesh is not None:
            v = np.zeros(2 * (len(problem.mesh.x) + len(problem.mesh.edges)))
            v[layout["free"]] = z[:n_free]
            soil = v.reshape(-1, 2)
    return upper, blocks, soil, time.perf_counter() - start


def collapse_bounds(scene: Scene, refine: float = 1.0, comm=None) -> Bounds | None:
    """Lower and upper collapse bounds of a scene (mesh size ``min(ring thickness / 2, fill depth over the crown) /
    refine`` near the ring); with ``comm``, the programmes shared out as :func:`problem_bounds` does (None on ranks
    other than 0), on two threads where this process alone has a core to spare. Collective over ``comm``."""
    start = time.perf_counter()
    return _timed(bridge_problem(scene, refine), start, comm, threads=spare_core(comm))


def _timed(problem: LimitProblem, start: float, comm=None, threads: bool = False) -> Bounds | None:
    """:func:`problem_bounds` of a problem built since ``start`` (:func:`time.perf_counter`), with the timings of
    :func:`collapse_bounds`: its mesh (start to now), each programme and the total (start to the end)."""
    t_mesh = time.perf_counter() - start
    out = problem_bounds(problem, comm, threads)
    if out is not None:
        out.timings = {"mesh": t_mesh, **out.timings, "total": time.perf_counter() - start}
    return out


class SceneBounds:
    """The collapse bounds of one scene (:func:`collapse_bounds`, ``refine`` 1), computed once for all who read them
    (an FE run's mesh refinement and its read-outs: they depend on the scene, not on the FE's mesh).

    1. ``ahead`` (a process alone with a core to spare, :func:`spare_core`): the problem is built now on the
       caller's thread (its fill mesh: Gmsh is one state per process) and both programmes are solved on a thread of
       their own (:class:`OnThread`) while the caller goes on; Clarabel releases Python's lock while it iterates.
       Otherwise they are solved at the first :meth:`result`, shared out over ``comm`` as :func:`problem_bounds` does.
    2. :meth:`result` returns the :class:`Bounds` (rank 0's; None on the other ranks) with the timings of
       :func:`collapse_bounds` (``total``: from the start to the end of the programmes), or raises the scene's
       :class:`SceneError` (a model the bounds do not cover) or the thread's error.
    3. :meth:`upper` is the upper bound (N) on every rank, None where there is none; :meth:`lower` the lower bound (N)
       on every rank where its static programme is optimal, once :func:`decide_lower` has compared it with a load,
       else None."""

    def __init__(self, scene: Scene, comm=None, ahead: bool = False):
        self.scene, self.comm = scene, comm
        self._done, self._bounds, self._error = False, None, None
        self._pending: OnThread | None = None
        if ahead:
            start = time.perf_counter()
            try:
                problem = bridge_problem(scene, 1.0)
            except SceneError as err:
                self._done, self._error = True, err
                return
            self._pending = OnThread(lambda: _timed(problem, start))

    def result(self) -> Bounds | None:
        if not self._done:
            try:
                self._bounds = self._pending.result() if self._pending else collapse_bounds(self.scene, comm=self.comm)
            except SceneError as err:
                self._error = err
            self._done = True
        if self._error is not None:
            raise self._error
        return self._bounds

    def upper(self) -> float | None:
        return self._load(lambda b: b.upper.load)

    def lower(self, compared: float) -> float | None:
        return self._load(lambda b: b.lower.load if decide_lower(b, compared) and b.lower.status == "optimal" else None)

    def _load(self, read: Callable[[Bounds], float | None]) -> float | None:
        """``read`` of rank 0's bounds (N) on every rank; None without bounds. Collective."""
        try:
            b = self.result()
        except SceneError:
            return None
        load = None if b is None else read(b)
        return load if self.comm is None or self.comm.size == 1 else self.comm.bcast(load, root=0)


def upper_mechanism(b: Bounds) -> dict | None:
    """The upper bound's mechanism of the blocks by the structure's joints: joints with a relative rotation (hinges) or
    slip (sliding), ring interfaces that open (separated), as the rigid-block LP reports them, relative to the largest
    block or fill speed (a local failure of the fill moves no joint; None without an upper bound)."""
    if b.block_velocities is None or not b.problem.blocks.n_joints:
        return None
    fill = 0.0 if b.soil_velocities is None else float(np.linalg.norm(b.soil_velocities, axis=1).max())
    mech = joint_mechanism(b.problem.blocks, joint_motion(b.problem.blocks, b.block_velocities, fill))
    return {"hinges": mech.hinges, "sliding": mech.sliding, "separated": mech.separated}


def bounds_summary(b: Bounds) -> dict:
    """The JSON form: lower, upper (N), unit, model, mesh, time (s), the upper bound's mechanism, and per
    programme its status, level (load factor) and load (N; both None without a value), iterations, seconds and
    sizes."""
    return {"lower": b.lower.load, "upper": b.upper.load, "unit": "N", "model": BOUNDS_MODEL, "mesh": b.mesh,
            "time": b.timings["total"], "mechanism": upper_mechanism(b),
            "programmes": {name: {"status": x.status, "level": x.level, "load": x.load, "iterations": x.iterations,
                                  "seconds": x.seconds, **x.sizes} for name, x in (("lower", b.lower),
                                                                                    ("upper", b.upper))}}


def fill_bounds(scene: Scene, compared: float | None = None, comm=None, known: SceneBounds | None = None
                ) -> dict | None:
    """The ``fill_bounds`` entry of results.json: None without a fill; with a fill whose model the bounds do not
    cover (elastic fill, point loads) ``{"lower": None, "upper": None, "unit": "N", "status": reason}``.
    ``compared``: the load (N) the lower bound is compared with (the FE bracket's upper end; None: none); a static
    programme that stopped short of full accuracy above it, or at its cap without a value, is solved again, and its
    lower bound is None when that solve does not decide the comparison (module docstring, *Accuracy*, steps 2-3;
    iterations and seconds then count both solves). With ``comm`` (mpi4py; None: this process alone) the programmes
    are shared out as :func:`problem_bounds` does and the entry is rank 0's (None elsewhere with a fill); ``known``:
    the scene's bounds computed once (:class:`SceneBounds`, over the same ``comm``). Collective over ``comm``."""
    if scene.fill is None:
        return None
    try:
        b = known.result() if known is not None else collapse_bounds(scene, comm=comm)
    except SceneError as err:
        return {"lower": None, "upper": None, "unit": "N", "status": str(err)}
    if b is None:
        return None
    decided = decide_lower(b, compared)
    summary = bounds_summary(b)
    return summary if decided else {**summary, "lower": None}


def decide_lower(b: Bounds, compared: float | None) -> bool:
    """Whether the lower bound of ``b`` decides its comparison with the load ``compared`` (N; None: no comparison,
    True) after its static programme is solved again where it stopped short of Clarabel's full tolerances above that
    load or without a value (module docstring, *Accuracy*, steps 2-3), once: that solve replaces ``b.lower``, its
    iterations and seconds counting both solves, and the capped bound is kept as ``b.capped``."""
    capped = b.capped or b.lower
    stopped = capped.load is None and capped.status.startswith("solver failure")  # at the cap, without a value
    if compared is None or capped.status == "optimal" or not (stopped or capped.load is not None
                                                              and capped.load > compared):
        return True
    if b.capped is None:
        again, _, _ = _bound(b.problem, lambda problem: lower_bound(problem, CHECK_ITERATIONS))
        b.capped, b.lower = capped, replace(again, iterations=capped.iterations + again.iterations,
                                            seconds=capped.seconds + again.seconds)
        b.timings["total"] += again.seconds
    again = b.lower
    return again.load is not None and (again.status == "optimal" or again.load <= compared or (
        capped.load is not None and abs(capped.load - again.load) <= SETTLED * again.load))


