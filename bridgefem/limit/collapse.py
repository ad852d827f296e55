"""The rigid-block collapse load of a scene's ring, with each point load on a joint where it is least favourable.

A point load that lies exactly on a joint (``[arch] joint_at_loads``, the default) can be carried by the voussoir to
its left, by the one to its right, or shared; which one changes the collapse load where the joint can slide (the
load on one face pushes that voussoir down along the joint). :func:`collapse_load` takes the allocation with the
least collapse load, the one a safe assessment must assume, and reports it (``LPResult.load_sides``) so that the FE
puts the load on the same voussoir (:func:`bridgefem.fe.model.least_favourable_sides`). Loads in N for the scene's
width.

The search (:func:`_least_favourable`), for ``k`` point loads on joints:

1. solve the LP with every such load shared by its two voussoirs (the split allocation);
2. with ``k <= _EXHAUSTIVE``, solve every corner allocation (each load wholly on one voussoir, ``2^k`` LPs) and
   keep the least; with more, start from all loads on the left voussoirs and move one load at a time to its other
   voussoir while that lowers the collapse load (a local search, not a proof);
3. keep the split allocation unless that corner is lower by more than ``_TIE`` (relative), so that a load whose
   allocation does not matter (no joint slides) stays shared, as the FE applies it.

Why corners suffice for associative friction: the live-load patterns the blocks can carry form a convex set, whose
gauge is convex along the affine family of allocations, so the least collapse load over the box of allocations is
at a corner.

:func:`collapse_state_from` is the non-associative collapse state reached from given joint normal forces (an FE
state's), the Tresca fixed point of :func:`bridgefem.limit.rigid_block.solve_blocks` on the same allocation.
"""
from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from ..geometry.ring import ArchRing, joint_under
from ..laws.base import JointLaw
from ..scene.model import Scene
from ..structure.ring import scene_ring
from .rigid_block import BlockModel, LPResult, dead_load_deficit, solve_blocks
from .ring_blocks import live_loads, ring_model

LEAST_FAVOURABLE = "least-favourable"
_EXHAUSTIVE = 8  # point loads on joints up to which every allocation is tried (2^8 = 256 LPs)
_TIE = 1e-7  # relative: a load on one block must lower the collapse load by more than this to replace the split


def collapse_load(scene: Scene, friction_model: str = "associative", load_at_joint: str = LEAST_FAVOURABLE,
                  law: type[JointLaw] | JointLaw | None = None, ring: ArchRing | None = None, **options) -> LPResult:
    """Rigid-block collapse load of a scene's ring; ``law`` the joints' (default the scene's,
    :func:`~bridgefem.limit.ring_blocks.ring_model`); ``friction_model`` and ``options`` go to
    :func:`~bridgefem.limit.rigid_block.solve_blocks`.

    ``load_at_joint``: the block that carries a point load lying on a joint ("left" | "right" | "split",
    :func:`~bridgefem.limit.ring_blocks.ring_model`), or "least-favourable" (the default): the allocation with the
    least collapse load (:func:`_least_favourable`). The result's ``load_sides`` says which was taken. The blocks
    must first carry their own weight (the deficit programme, once for every allocation: a live load follows the
    self-weight, :mod:`bridgefem.limit.rigid_block`); else the result is "unstable under self-weight". ``ring``: the
    scene's ring when the caller has built it already (:func:`bridgefem.structure.ring.scene_ring` of ``scene``);
    None: built here.
    """
    ring = scene_ring(scene) if ring is None else ring
    span = scene.arch.span
    on_joint = [i for i, ld in enumerate(scene.loads)
                if ld.kind == "point" and joint_under(ring, ld.x_range(span)[0]) is not None]
    model = ring_model(scene, load_at_joint="split", law=law, ring=ring)
    if np.any(model.live):  # the self-weight once for every allocation (the same blocks and dead load)
        _, dead = dead_load_deficit(model)
        if dead.status == "unstable under self-weight":
            dead.friction_model, dead.load_sides = friction_model, [None] * len(scene.loads)
            return dead

    def solve(choice: dict[int, str]) -> LPResult:
        sides = tuple(choice.get(i, "split") for i in range(len(scene.loads)))
        res = solve_blocks(dataclasses.replace(model, live=live_loads(scene, ring, model.ref, sides)),
                           friction_model, self_weight=False, **options)
        res.load_sides = [choice.get(i) for i in range(len(scene.loads))]
        return res

    if load_at_joint != LEAST_FAVOURABLE:
        return solve({i: load_at_joint for i in on_joint})
    return _least_favourable(solve, on_joint)


def collapse_state_from(scene: Scene, normal_forces: np.ndarray, load_sides: list[str | None] | None = None,
                        **options) -> LPResult:
    """The non-associative rigid-block collapse state of a scene's ring reached from given joint normal forces.

    ``normal_forces`` (N, one per joint of :func:`~bridgefem.limit.ring_blocks.ring_model`, e.g. an FE state's joint
    resultants) seed the Tresca fixed point (:func:`~bridgefem.limit.rigid_block.solve_blocks`,
    ``friction_model="non-associative"``); ``load_sides``: the block carrying each point load on a joint
    (:func:`collapse_load`'s ``load_sides``; None entries and None: shared). The result's ``converged`` says whether
    a fixed point was reached; ``options`` go to :func:`~bridgefem.limit.rigid_block.solve_blocks`.
    """
    res = solve_blocks(sided_ring(scene, load_sides), "non-associative", seed=normal_forces, **options)
    res.load_sides = list(load_sides or [None] * len(scene.loads))
    return res


def sided_ring(scene: Scene, load_sides: list[str | None] | None, ring: ArchRing | None = None) -> BlockModel:
    """The scene's ring as rigid blocks (:func:`~bridgefem.limit.ring_blocks.ring_model`) with each point load on a
    joint carried by the block ``load_sides`` names (:func:`collapse_load`'s ``load_sides``; None entries and None:
    shared by both); ``ring``: the scene's ring when the caller has built it (None: built here)."""
    sides = tuple(side or "split" for side in (load_sides or [None] * len(scene.loads)))
    return ring_model(scene, load_at_joint=sides, ring=ring)


def _level(res: LPResult) -> float:
    """The collapse load factor as a number to compare (an unbounded load is +inf)."""
    return np.inf if res.level is None and res.status == "no collapse (unbounded)" else (res.level or 0.0)


def _least_favourable(solve, on_joint: list[int]) -> LPResult:
    """The least collapse load over the allocations of the point loads on joints (load index -> side).

    With associative friction the load factors ``(lambda_1, ..., lambda_k)`` the blocks can carry form a convex
    set, so its gauge is convex along the (affine) allocation and its maximum over the box of allocations (the
    least load factor) sits at a corner: every load wholly on one block. Up to ``_EXHAUSTIVE`` such loads every
    corner is tried (2^k LPs); beyond, one load at a time is moved to its other block while that lowers the load
    (a local search, not a proof). The split allocation is kept unless a corner is lower by more than ``_TIE``
    (relative): where the allocation does not matter (no joint slides) the load stays shared by both faces.
    """
    split = solve({})
    if not on_joint:
        return split
    if len(on_joint) <= _EXHAUSTIVE:
        results = [solve(dict(zip(on_joint, c))) for c in itertools.product(("left", "right"), repeat=len(on_joint))]
        best = min(results, key=_level)
    else:
        choice = dict.fromkeys(on_joint, "left")
        best = solve(choice)
        improved = True
        while improved:
            improved = False
            for i in on_joint:
                trial = {**choice, i: "right" if choice[i] == "left" else "left"}
                res = solve(trial)
                if _level(res) < _level(best):
                    best, choice, improved = res, trial, True
    if _level(best) < _level(split) * (1 - _TIE):
        return best
    split.load_sides = ["split" if i in on_joint else None for i in range(len(split.load_sides))]
    return split
