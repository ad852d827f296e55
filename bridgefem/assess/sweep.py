"""The assessment: the vehicle rolled across the bridge, its critical position and its adequacy factor.

The adequacy factor of a position is the factor by which the vehicle's axle loads (those on the span,
:mod:`bridgefem.assess.vehicle`) can grow, after the self-weight, before the bridge collapses; the bridge's is the
least over all positions (LimitState:RING's adequacy factor). Method:

1. **Screen** (rigid-block LP, milliseconds a position): the first axle at every ``step`` m from where the last
   axle enters the span to where the first leaves it; on a bare ring the LP of the scene with the axles as its loads
   (:func:`bridgefem.limit.collapse.collapse_load`: joints under the axles as the FE has them, a point axle on a
   joint carried by the least favourable voussoir), with a fill the ring's LP with the fill as dead load and each
   axle spread through it (:mod:`bridgefem.assess.dispersion`) by the scene's ``[vehicle] dispersion`` -- and, as
   a second screen each, by every other rule: how the load reaches the ring through the fill is what the LP does
   not know, and the rules put the least LP factor at different positions.
2. **Refine** around the ``confirm + 1`` least local minima of each screen: :data:`REFINE_POINTS` positions across
   two steps on each side of each, then again across two of those new steps, :data:`REFINE_LEVELS` times (a grid
   of step / 8^levels around each minimum).
3. **Confirm** with the FE limit analysis (:func:`bridgefem.analysis.runner.run_analysis`; the answer, the LP its check)
   the least refined minimum and the next local minima within :data:`CONFIRM_MARGIN` of it (up to ``confirm``
   positions): the FE's and the LP's rankings can differ where minima are close; with a fill, also each other rule's
   least position unless it is one of those (within the finest refinement's spacing): the FE, which carries the axles
   through the fill itself, may be least where another rule's LP is, a few centimetres away. The adequacy factor is the
   least FE bracket; a position whose vehicle cannot collapse the bridge is "locked", never a number. The positions are
   confirmed in the order of the factor their own screen gives them, least first.
4. **Prune**: once a confirmation of a scene has an FE bracket, every confirmation of the scene still running or
   started later stops as soon as it carries the least upper end of the scene's brackets found so far, the
   *ceiling* (the analysis's ``enough`` load, asked before every load step,
   :func:`bridgefem.analysis.runner.run_analysis`): a position that carries it cannot be critical, so its search
   need not find its own limit, nor fail trying (a search near a fill's limit takes the most steps). The ceiling
   bounds no trial, so a position that collapses below it gets the bracket it gets without one: the adequacy
   factor, its position and its bracket do not depend on which confirmations were pruned, nor on when.

**Parallel** (mpi4py): the positions of every step are independent. Screening and refining split them round-robin
over the ranks (gathered in position order, so the answer does not depend on the ranks). The FE confirmations of all
the scenes given (``bridgefem assess a.toml b.toml``) are shared out as they go (:func:`_confirm`):

1. The ranks split into groups (``comm.Split``): one group per confirmation while there are ranks enough, else one
   rank each; each FE run is solved on its group's communicator.
2. The confirmations are queued each scene's first (least screen factor) first, then each scene's second, and so
   on: the runs that give the ceilings start first.
3. A group that is free takes the next confirmation of the queue; one rank of each group reads and writes what the
   groups share, an MPI one-sided window on rank 0 (:class:`_Board`: the index of the next confirmation, and per
   scene its ceiling), with atomic operations that need no other rank's part, and broadcasts what it read over its
   group.
4. Before each load step a run reads its scene's ceiling (step 4 above); a bracket found lowers it at once for
   every group.
5. The results are gathered on every rank, each scene's confirmations in queue order.

Which group runs which confirmation, and which end at a ceiling, depend on the timing and the number of ranks; the
adequacy factor, its position and its bracket do not (step 4).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..scene.document import edit
from ..scene.model import Scene
from ..scene.vehicles import DISPERSIONS
from ..status import Status
from .vehicle import Placement, place, positions

STEPS_PER_SPAN = 40  # default screening step: span / this
REFINE_POINTS = 8  # positions per side of a minimum and refinement level
REFINE_LEVELS = 2
CONFIRM = 2  # FE confirmations at most per scene
CONFIRM_MARGIN = 0.10  # a local minimum of the LP within this fraction above the least is confirmed too
LOCKED = "locked"


@dataclass(frozen=True)
class PositionLP:
    """The rigid-block LP at one vehicle position: ``x0`` (m, first axle from the left springing), ``factor`` the
    vehicle's collapse factor (``math.inf`` when the vehicle cannot collapse the bridge there, 0 when the bridge
    does not stand; None on an LP failure or with no axle on the span), ``status``, ``hinges``, ``sliding``,
    ``axles`` on the span and the vehicle ``load`` they carry (N)."""

    x0: float
    factor: float | None
    status: str
    hinges: tuple[int, ...] = ()
    sliding: tuple[int, ...] = ()
    axles: tuple[int, ...] = ()
    load: float = 0.0
    refined: bool = False


@dataclass
class Confirmation:
    """The FE limit analysis at one position: ``x0`` (m), the vehicle ``load`` on the span (N), ``status``,
    ``adequacy`` (lower, upper or None) the FE bracket over that load, ``lp_factor`` the LP's factor there,
    ``summary`` what :func:`assess` was given to describe the analysis with (results.json's entries), ``seconds``,
    ``proposed_by`` the dispersion rule whose LP screen proposed the position when it is not the scene's (None),
    ``ceiling`` its scene's ceiling in force when its search ended, at which a search stops as carried (step 4 of
    the module docstring; None: no ceiling)."""

    x0: float
    load: float
    status: str
    adequacy: tuple[float, float | None] | None
    lp_factor: float | None
    summary: dict
    seconds: float
    proposed_by: str | None = None
    ceiling: float | None = None

    @property
    def pruned(self) -> bool:
        """The run carried its ``ceiling`` (an adequacy factor another position's bracket reached, step 4 of the
        module docstring): not the critical position."""
        return self.ceiling is not None and Status.of(self.status) is Status.LOCKED


@dataclass
class Assessment:
    """The assessment of one scene: ``positions`` the LP screen and refinements (sorted by x0), ``lp_factor`` the
    least LP factor at ``lp_critical_x`` (m), ``confirmations`` the FE runs, ``dispersion_minima`` (with a fill)
    each dispersion rule's least LP position, the scene's own rule's included, ``adequacy`` the least FE bracket
    (None when locked or failed) at ``critical_x``, ``status`` ("adequacy factor found", "locked", "unstable under
    self-weight" or a solver failure), ``seconds`` per phase."""

    scene: Scene
    step: float
    positions: list[PositionLP]
    lp_factor: float | None
    lp_critical_x: float | None
    confirmations: list[Confirmation] = field(default_factory=list)
    dispersion_minima: dict[str, PositionLP] = field(default_factory=dict)
    adequacy: tuple[float, float | None] | None = None
    critical_x: float | None = None
    status: str = ""
    seconds: dict = field(default_factory=dict)

    @property
    def critical(self) -> Confirmation | None:
        """The confirmation at the critical position (None without one)."""
        return next((c for c in self.confirmations if c.x0 == self.critical_x), None)


def lp_at(scene: Scene, x0: float, refined: bool = False) -> PositionLP:
    """Step 1 of the module docstring at one position."""
    from ..limit.collapse import collapse_load  # the LP's public function
    from ..limit.rigid_block import LPFailure
    from .dispersion import dispersed_lp

    pl: Placement = place(scene, x0)
    if pl.scene is None:
        return PositionLP(x0, None, "no axle on the span", refined=refined)
    v, span = scene.vehicle, scene.arch.span
    try:
        if scene.fill is None:
            res = collapse_load(pl.scene)
            scale = 1.0 / max(v.axles)  # the pattern's factors are axle / heaviest axle
        else:
            axles = [(ld.factor * max(v.axles), *ld.x_range(span)) for ld in pl.scene.loads]
            res = dispersed_lp(pl.scene, axles, v.dispersion)
            scale = 1.0
    except LPFailure as err:
        return PositionLP(x0, None, Status.failure(str(err)), axles=pl.on, load=pl.load, refined=refined)
    if res.status == "no collapse (unbounded)":
        factor = math.inf
    elif res.status == "unstable under self-weight":
        factor = 0.0
    else:
        factor = res.level * scale
    mech = res.by_joint  # by the structure's joint ids (a ring interface is several LP pieces)
    return PositionLP(x0, factor, res.status, tuple(mech.hinges), tuple(mech.sliding), pl.on, pl.load, refined)


def _spread(comm, work: list, fn: Callable) -> list:
    """``fn`` of every item of ``work``, the items split round-robin over the ranks of ``comm`` and gathered in
    order on every rank."""
    mine = [fn(*item) for item in work[comm.rank::comm.size]]
    parts = comm.allgather(mine)
    out = [None] * len(work)
    for r, part in enumerate(parts):
        out[r::comm.size] = part
    return out


def _value(p: PositionLP) -> float:
    return math.inf if p.factor is None else p.factor


def local_minima(points: list[PositionLP]) -> list[PositionLP]:
    """The positions (sorted by x0) whose factor is at most their neighbours', least first; a run of equal values
    counts once."""
    vals = [_value(p) for p in points]
    out = []
    for i, v in enumerate(vals):
        if not math.isfinite(v):
            continue
        left = vals[i - 1] if i > 0 else math.inf
        right = vals[i + 1] if i + 1 < len(vals) else math.inf
        if v <= right and v < left:
            out.append(points[i])
    return sorted(out, key=_value)


def _screens(s: Scene) -> list[tuple[str | None, Scene]]:
    """The LP screens of a scene (step 1 of the module docstring): (dispersion rule, the scene with that rule), the
    scene's own first; a bare ring's one screen has no rule."""
    if s.fill is None:
        return [(None, s)]
    own = s.vehicle.dispersion
    return [(own, s)] + [(rule, edit(s, vehicle={"dispersion": rule})) for rule in DISPERSIONS if rule != own]


def assess(scenes: list[Scene], comm=None, step: float | None = None, confirm: int = CONFIRM,
           describe: Callable | None = None, fe: bool = True,
           progress: Callable[[str], None] = lambda line: None) -> list[Assessment]:
    """Assess every scene (each with a ``[vehicle]``): steps 1-3 of the module docstring (collective over ``comm``,
    default COMM_WORLD; every rank gets the same assessments). ``step`` (m): the screening step (default span /
    :data:`STEPS_PER_SPAN`); ``describe(analysis)``: what to keep of each FE analysis, called collectively on its
    group's ranks (default: :func:`brief`); ``fe=False``: the LP screens alone."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    describe = describe or brief
    start = time.perf_counter()
    steps = [step or s.arch.span / STEPS_PER_SPAN for s in scenes]
    screens = [(i, rule, sc) for i, s in enumerate(scenes) for rule, sc in _screens(s)]
    found: list[list[PositionLP]] = [[] for _ in screens]
    work = [(k, float(x)) for k, (i, _, sc) in enumerate(screens) for x in positions(sc, steps[i])]
    for level in range(REFINE_LEVELS + 1):
        done = _spread(comm, [(screens[k][2], x, level > 0) for k, x in work], lp_at)
        for (k, _), p in zip(work, done):
            found[k].append(p)
        if level == REFINE_LEVELS:
            break
        work = []
        for k, (i, _, _) in enumerate(screens):
            h = steps[i] * 2 / REFINE_POINTS ** (level + 1)
            known = {round(p.x0, 12) for p in found[k]}
            for m in local_minima(sorted(found[k], key=lambda p: p.x0))[:confirm + 1]:
                for j in range(-REFINE_POINTS, REFINE_POINTS + 1):
                    x = m.x0 + j * h
                    if round(x, 12) not in known:
                        known.add(round(x, 12))
                        work.append((k, x))
    lp_seconds = time.perf_counter() - start
    out = []
    for i, s in enumerate(scenes):
        mine = [(rule, sorted(found[k], key=lambda p: p.x0)) for k, (j, rule, _) in enumerate(screens) if j == i]
        pts = mine[0][1]
        minima = local_minima(pts)
        least = minima[0] if minima else None
        a = Assessment(s, steps[i], pts, least.factor if least else None, least.x0 if least else None)
        a.dispersion_minima = {rule: local_minima(p)[0] for rule, p in mine if rule is not None and local_minima(p)}
        a.seconds["lp"] = lp_seconds
        if least is None:
            stood = [p for p in pts if p.factor == math.inf]
            a.status = LOCKED if stood else Status.failure("no rigid-block LP answer at any position")
        elif least.factor == 0.0:
            a.status = "unstable under self-weight"
        out.append(a)
    if fe:
        _confirm(out, comm, confirm, describe, progress)
    for a in out:
        a.seconds["total"] = time.perf_counter() - start
    return out


def _finest(step: float) -> float:
    """The spacing (m) of the last refinement's grid (step 2 of the module docstring): positions closer than this
    are one position."""
    return step * 2 / REFINE_POINTS ** REFINE_LEVELS


def _candidates(a: Assessment, confirm: int) -> list[tuple[PositionLP, str | None]]:
    """The positions to confirm with the FE (step 3 of the module docstring), each with the dispersion rule whose
    screen proposed it (None: the scene's own screen); a position another rule proposes carries the scene rule's
    LP factor there. Ordered by the factor the proposing screen gives each, least first: the likeliest critical
    position is confirmed first, and its bracket prunes the others (step 4)."""
    if a.status:
        return []
    minima = local_minima(a.positions)
    out = [(m, None) for m in minima[:confirm] if _value(m) <= (1 + CONFIRM_MARGIN) * _value(minima[0])]
    for rule, m in a.dispersion_minima.items():
        if rule != a.scene.vehicle.dispersion and all(abs(m.x0 - c.x0) > _finest(a.step) for c, _ in out):
            out.append((lp_at(a.scene, m.x0, refined=True), rule))
    return sorted(out, key=lambda c: _value(c[0]) if c[1] is None else _value(a.dispersion_minima[c[1]]))


class _Board:
    """What the groups of ranks share while they confirm (module docstring, *Parallel*, step 3): an MPI one-sided
    window on rank 0 of ``comm`` holding the index of the next confirmation to take and, per assessment, its ceiling
    (the least upper end of its FE brackets so far; inf without one). Created and freed collectively over ``comm``;
    in between one rank takes, reads and lowers without the others' taking part (atomic operations under a shared
    lock)."""

    def __init__(self, comm, assessments: int):
        from mpi4py import MPI

        self.mpi = MPI
        self.win = MPI.Win.Allocate(8 * (1 + assessments) if comm.rank == 0 else 0, 8, comm=comm)
        if comm.rank == 0:
            self.win.Lock(0)
            self.win.Put(np.array([0.0] + [math.inf] * assessments), 0)
            self.win.Unlock(0)
        comm.Barrier()

    def _op(self, slot: int, value: float, op) -> float:
        """The slot's value before ``op`` (with ``value``) changed it."""
        got = np.empty(1)
        self.win.Lock(0, self.mpi.LOCK_SHARED)
        self.win.Fetch_and_op(np.array([value]), got, 0, slot, op)
        self.win.Unlock(0)
        return float(got[0])

    def take(self) -> int:
        """The index of the next confirmation (one past the last when none is left)."""
        return int(self._op(0, 1.0, self.mpi.SUM))

    def ceiling(self, i: int) -> float:
        """Assessment ``i``'s ceiling now."""
        return self._op(1 + i, 0.0, self.mpi.NO_OP)

    def lower(self, i: int, upper: float) -> None:
        """A bracket of assessment ``i`` with this ``upper`` end was found."""
        self._op(1 + i, upper, self.mpi.MIN)

    def free(self) -> None:
        self.win.Free()


def _queue(assessments: list[Assessment], confirm: int) -> list[tuple[int, PositionLP, str | None]]:
    """The confirmations (assessment index, position, proposing rule) in the order they are taken (module docstring,
    *Parallel*, step 2): each assessment's first, then each one's second, and so on."""
    ranked = [(j, i, m, rule) for i, a in enumerate(assessments) for j, (m, rule) in enumerate(_candidates(a, confirm))]
    return [(i, m, rule) for _, i, m, rule in sorted(ranked, key=lambda r: r[:2])]


def _confirm(assessments: list[Assessment], comm, confirm: int, describe: Callable, progress) -> None:
    """Step 3: the FE runs of every assessment, shared out over groups of ranks as they go (module docstring,
    *Parallel*, steps 1-5), each pruned by its assessment's ceiling (step 4). Collective over ``comm``."""
    from ..analysis.runner import run_analysis

    items = _queue(assessments, confirm)
    if not items:
        return
    start = time.perf_counter()
    sub = comm.Split(comm.rank % min(comm.size, len(items)), comm.rank)
    board = _Board(comm, len(assessments))
    mine = []
    try:
        while (k := sub.bcast(board.take() if sub.rank == 0 else None)) < len(items):
            i, m, rule = items[k]
            t0 = time.perf_counter()
            pl = place(assessments[i].scene, m.x0)
            read = [math.inf]  # the ceilings read so far, the last in force

            def enough(i=i, load=pl.load, read=read) -> float:
                read.append(sub.bcast(board.ceiling(i) if sub.rank == 0 else None))
                return read[-1] * load

            an = run_analysis(pl.scene, sub, enough=enough)
            data = describe(an)
            lim = data["limit_load"]
            status = data["status"]
            adequacy = (lim["lower"] / pl.load, None if lim["upper"] is None else lim["upper"] / pl.load) \
                if Status.of(status) is Status.LIMIT else None
            if adequacy is not None and adequacy[1] is not None and sub.rank == 0:
                board.lower(i, adequacy[1])
            c = Confirmation(m.x0, pl.load, status, adequacy, m.factor, data, time.perf_counter() - t0, rule,
                             read[-1] if math.isfinite(read[-1]) else None)
            if sub.rank == 0:
                mine.append((k, c))
                progress(_line(assessments[i].scene, c))
            del an
    finally:
        board.free()
        sub.Free()
    found = dict(kv for part in comm.allgather(mine) for kv in part)
    for k, (i, _, _) in enumerate(items):
        assessments[i].confirmations.append(found[k])
    for a in assessments:
        a.seconds["fe"] = time.perf_counter() - start
        _conclude(a)


def _conclude(a: Assessment) -> None:
    """The adequacy factor and status from the confirmations."""
    if not a.confirmations:
        return
    limits = [c for c in a.confirmations if c.adequacy is not None]
    failed = [c for c in a.confirmations if Status.of(c.status) is Status.FAILURE]
    if limits:
        best = min(limits, key=lambda c: c.adequacy[0])
        a.adequacy, a.critical_x, a.status = best.adequacy, best.x0, "adequacy factor found"
    elif failed:
        a.status, a.critical_x = failed[0].status, failed[0].x0
    elif any(Status.of(c.status) is Status.UNSTABLE for c in a.confirmations):
        a.status = "unstable under self-weight"
    else:
        a.status, a.critical_x = LOCKED, a.confirmations[0].x0


def _line(scene: Scene, c: Confirmation) -> str:
    """One console line for a confirmed position."""
    lp = "none" if c.lp_factor is None else f"{c.lp_factor:.4g}"
    if c.adequacy is not None:
        fe = f"FE adequacy factor in [{c.adequacy[0]:.4f}, {c.adequacy[1]:.4f}]"
    elif c.pruned:
        fe = f"FE carries {c.ceiling:.4f}, the upper end of a bracket found before: not the critical position"
    else:
        fe = f"FE: {c.status}"
    why = f", the position the {c.proposed_by} screen proposed" if c.proposed_by else ""
    return (f"{scene.name}: first axle at x = {c.x0:.3f} m ({c.load / 1e3:.1f} kN on the span{why}): {fe}, LP "
            f"{lp} ({c.seconds:.1f} s)")


def brief(an) -> dict:
    """What an assessment keeps of an FE analysis without the results writer: status, limit load (N), mechanism,
    evidence, warnings, the LP's load and the fill's bounds (collective)."""
    s, total = an.search, an.load_total
    return {"status": s.status,
            "limit_load": {"lower": s.lower * total, "upper": None if s.upper is None else s.upper * total,
                           "unit": "N", "tolerance": s.tolerance},
            "mechanism": {"hinges": [j.id for j in an.joints if j.hinge],
                          "sliding": [j.id for j in an.joints if j.sliding]},
            "evidence": an.verdict.evidence if an.verdict else "", "warnings": an.warnings,
            "lp": {"load": an.lp.load}, "fill_bounds": an.fill_bounds}
