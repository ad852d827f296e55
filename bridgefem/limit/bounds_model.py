"""The rigid-plastic model shared by the lower and upper collapse bounds (:mod:`bridgefem.limit.bounds`).

A :class:`LimitProblem` is a set of rigid blocks (voussoirs, abutment blocks, a footing) with no-tension
Coulomb joints between them and to the ground (the rigid-block model of :mod:`bridgefem.limit.rigid_block`), plus
an optional plane-strain Mohr-Coulomb soil (the fill) meshed in triangles, in contact with the blocks through
no-tension Coulomb interfaces. Forces in N for the whole width ``width`` (m), stresses in Pa, tension positive.

Plane-strain Mohr-Coulomb as a second-order cone (cohesion c, friction angle phi)::

    sqrt((sx - sy)^2 + (2 txy)^2) <= 2 c cos(phi) - (sx + sy) sin(phi)

and, when ``tension_cutoff`` is given, the in-plane mean stress ``(sx + sy)/2 <= tension_cutoff``.
This module also builds the problems: a scene's bridge (:func:`bridge_problem`) and a strip footing on a soil
layer (:func:`strip_footing_problem`, the bearing-capacity checks).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..geometry.ring import ArchRing, Voussoir, fill_outline
from ..scene.keys import SceneError
from ..scene.model import Scene
from ..structure.ring import scene_ring
from .bounds_mesh import BONDED, FIXED, INTERFACE, ROAD, ROLLER, Outline, SoilMesh, triangulate
from .collapse import collapse_load, sided_ring
from .conic import NONNEG, SOC, ConicProgramme
from .rigid_block import BlockModel, _Programme
from .ring_blocks import ring_model

FAR_SIZE = 4.0  # element size away from the ring and the loads, in multiples of the size near them
LOAD_SIZE = 0.5  # element size at the edges of a loaded patch, in multiples of the size near the ring
MAX_TRIANGLES = 6000  # triangles of the fill at refine 1 (x refine^2), above which the size grows to fit
# (bridge_problem: the mesh cap)


@dataclass(frozen=True)
class Soil:
    """Mohr-Coulomb soil: cohesion (Pa), friction_angle (degrees), unit_weight (N/m^3), tension_cutoff (Pa,
    limit of the in-plane mean stress; None: none)."""

    cohesion: float
    friction_angle: float
    unit_weight: float
    tension_cutoff: float | None = None


@dataclass(frozen=True)
class LimitProblem:
    """Rigid blocks (dead and live loads, N, for the whole width; live for a unit load factor), and optionally
    a soil mesh with its material and the blocks' interface friction. ``live_total``: N of live load per unit
    load factor; ``size``: the mesh size near the ring and the loads (m; None without soil)."""

    blocks: BlockModel
    width: float
    live_total: float
    soil: Soil | None = None
    mesh: SoilMesh | None = None
    interface_friction: float = 0.0
    size: float | None = None

    @property
    def force_scale(self) -> float:
        """A typical force (N): the dead load, or the soil's strength over the mesh, whichever is larger."""
        dead = float(np.abs(self.blocks.dead[:, :2]).sum())
        if self.mesh is not None:
            dead += self.soil.unit_weight * self.width * float(self.mesh.areas().sum())
            dead = max(dead, self.stress_scale * self.width * float(np.ptp(self.mesh.x, axis=0).max()))
        return dead or 1.0

    @property
    def stress_scale(self) -> float:
        """A typical stress (Pa): cohesion or the soil's weight over the mesh height."""
        s = self.soil
        return max(s.cohesion, s.unit_weight * float(np.ptp(self.mesh.x[:, 1])), 1e-300)


def block_rows(blocks: BlockModel, block, point, fx_cols, fx_vals, fy_cols, fy_vals, row0: int = 0):
    """Triplets (rows, cols, vals) of the generalised forces (Fx, Fy, moment about the block's reference point)
    on ``block`` (p,) of forces at ``point`` (p, 2) whose components are linear in the unknowns:
    ``Fx = sum fx_vals[i] x[fx_cols[i]]`` (arrays (p, m)), likewise Fy. Rows ``row0 + 3 block + (0, 1, 2)``."""
    block = np.asarray(block)
    arm = point - blocks.ref[block]
    base = row0 + 3 * block[:, None]
    m = fx_cols.shape[1]
    rows = np.hstack([np.repeat(base, m, 1), np.repeat(base + 1, m, 1), np.repeat(base + 2, 2 * m, 1)])
    cols = np.hstack([fx_cols, fy_cols, fy_cols, fx_cols])
    vals = np.hstack([fx_vals, fy_vals, arm[:, :1] * fy_vals, -arm[:, 1:] * fx_vals])
    return rows.ravel(), cols.ravel(), vals.ravel()


def joint_rows(prog: ConicProgramme, blocks: BlockModel) -> np.ndarray:
    """The joints' yield conditions on the forces ``q = (n, s, m)`` at columns 0 .. 3 nj - 1 (the rigid-block LP's,
    the rows of their law for the conic bounds, :meth:`bridgefem.laws.base.JointLaw.conic`: its
    :meth:`~bridgefem.laws.base.JointLaw.block_yield`, for Coulomb ``|m| <= n t/2``, ``|s| <= mu n``, ``n >= 0``,
    and its :meth:`~bridgefem.laws.base.JointLaw.block_cones`, a crushing joint's parabola); returns the equilibrium
    matrix of the blocks (3 nb, 3 nj): the generalised forces the joints exert on the blocks."""
    law = blocks.law.conic()
    lp = _Programme(dataclasses.replace(blocks, law=law))
    nj = blocks.n_joints
    if nj:
        mu = np.asarray(blocks.friction, float)
        rules = lp.joint_yield(mu)
        g = lp.yield_rows(mu, np.zeros(rules.per_joint * nj)).tocoo()
        keep = g.col < 3 * nj
        prog.add(NONNEG, g.row[keep], g.col[keep], g.data[keep], rules.rhs.ravel())
        prog.add(NONNEG, np.arange(nj), 3 * np.arange(nj), -np.ones(nj), 0.0 - rules.n_min)
        cones = law.block_cones(lp.t)
        if cones is not None:
            rows, cols, vals, rhs = cones
            j = np.arange(nj)[:, None]
            prog.add(SOC, rows + rhs.shape[1] * j, cols + 3 * j, vals, rhs)
    return lp.A


def with_loading_beams(blocks: BlockModel, spans, loads, road: float) -> BlockModel:
    """``blocks`` with a rigid, weightless loading beam appended per patch: ``spans`` (k, 2) its x-range on the
    road at height ``road`` (m), ``loads`` (k,) its vertical live load (N per unit load factor) acting downwards
    at the patch centre, its reference point. The beam is bonded to the road under it (BONDED sides of the soil
    outline) and free to translate and rotate: its equilibrium makes the road tractions under it add up to the
    load, with no horizontal resultant and no moment about the centre."""
    spans, loads = np.asarray(spans, float).reshape(-1, 2), np.asarray(loads, float)
    k = len(loads)
    centre = np.column_stack([spans.mean(axis=1), np.full(k, road)])
    return dataclasses.replace(blocks, ref=np.vstack([blocks.ref, centre]), dead=np.vstack([blocks.dead,
                                                                                           np.zeros((k, 3))]),
                               live=np.vstack([blocks.live, np.column_stack([np.zeros(k), -loads, np.zeros(k)])]))


def soil_rows(prog: ConicProgramme, soil: Soil, col0: int, n_points: int) -> None:
    """Mohr-Coulomb cones (and the tension cut-off) on stress triples ``(sx, sy, txy)`` at columns
    ``col0 + 3 i + (0, 1, 2)``, i < n_points."""
    phi = math.radians(soil.friction_angle)
    cols = col0 + 3 * np.arange(n_points)[:, None] + np.array([0, 1, 0, 1, 2])
    rows = 3 * np.arange(n_points)[:, None] + np.array([0, 0, 1, 1, 2])
    vals = np.tile([math.sin(phi), math.sin(phi), -1.0, 1.0, -2.0], (n_points, 1))
    rhs = np.zeros((n_points, 3))
    rhs[:, 0] = 2 * soil.cohesion * math.cos(phi)
    prog.add(SOC, rows, cols, vals, rhs)
    if soil.tension_cutoff is not None:
        i = np.arange(n_points)
        prog.add(NONNEG, np.repeat(i, 2), col0 + 3 * i[:, None] + np.array([0, 1]), np.full((n_points, 2), 0.5),
                 np.full(n_points, soil.tension_cutoff))


def bridge_problem(scene: Scene, refine: float = 1.0) -> LimitProblem:
    """The scene's bridge: its ring (and abutment blocks) as in the rigid-block LP and, with a fill, the fill
    as Mohr-Coulomb soil meshed with element size ``min(ring thickness / 2, fill depth over the crown) / refine``
    near the extrados (half that at the load patches' edges, ``FAR_SIZE`` times it far from them; the depth keeps
    a thin fill over a thick ring from being one triangle deep, on which no mechanism forms and the upper bound
    is unbounded). The mesh cap: a mesh of more than ``MAX_TRIANGLES`` x refine^2 triangles is made again with the
    size grown by the square root of the excess, since a thin ring under a deep, long fill would otherwise give tens
    of thousands of triangles and conic programmes that take minutes; a coarser mesh still gives bounds, only
    wider. Without a fill this is the LP's model (point loads on a Mohr-Coulomb fill are refused by the scene)."""
    width = scene.arch.width
    live_total = float(sum(ld.factor for ld in scene.loads))
    if scene.fill is None:  # a point load on a joint goes on the block the LP finds least favourable
        return LimitProblem(sided_ring(scene, collapse_load(scene).load_sides), width, live_total)
    f = scene.fill
    if f.material != "mohr-coulomb":
        raise SceneError('[fill] material = "elastic": the collapse bounds need a mohr-coulomb fill')
    if not scene.loads:
        raise SceneError("no [[load]]: the collapse bounds need a live load")
    ring = scene_ring(scene)
    size = min(min(a.thickness for a in scene.arches) / 2, f.depth) / refine
    blocks = ring_model(dataclasses.replace(scene, fill=None), live=False)
    outline = _bridge_outline(scene, ring, size, blocks.n_blocks)
    mesh, cap = triangulate(outline), MAX_TRIANGLES * refine ** 2
    if mesh.n_triangles > cap:
        size *= math.sqrt(mesh.n_triangles / cap)
        outline = _bridge_outline(scene, ring, size, blocks.n_blocks)
        mesh = triangulate(outline)
    if f.loading_beam:
        blocks = with_loading_beams(blocks, [ld.x_range(scene.arch.span) for ld in scene.loads],
                                    [ld.factor for ld in scene.loads], outline.points[-1, 1])
    soil = Soil(f.cohesion, f.friction_angle, f.unit_weight, f.tension_cutoff)
    return LimitProblem(blocks, width, live_total, soil, mesh, f.interface_friction, size)


def _bridge_outline(scene: Scene, ring: ArchRing, size: float, n_blocks: int) -> Outline:
    """The fill region of :func:`bridgefem.geometry.ring.fill_outline` as a counter-clockwise :class:`Outline`: base
    (fixed) from the left end to the left springing's extrados corner, the extrados (interface, on the voussoirs'
    own extrados points), base to the right end, right end (roller), road leftwards, left end. The road under
    patch ``k`` is bonded to loading beam ``n_blocks + k`` (``[fill] loading_beam``) or carries its pressure."""
    f, span = scene.fill, scene.arch.span
    ranges = [ld.x_range(span) for ld in scene.loads]
    o = fill_outline(ring, f.depth, f.extension, [x for r in ranges for x in r])
    ext, owner = _extrados_points(ring, size)
    n_ext = len(ext)
    road_x = np.array([o.x_right, *sorted((x for x in o.road_x if o.x_left < x < o.x_right), reverse=True),
                       o.x_left])
    points = np.vstack([[[o.x_left, o.y_base]], ext, [[o.x_right, o.y_base]],
                        np.column_stack([road_x, np.full(len(road_x), o.y_road)])])
    kind = np.concatenate([[FIXED], np.full(n_ext - 1, INTERFACE), [FIXED, ROLLER],
                           np.full(len(road_x) - 1, ROAD), [ROLLER]])
    block = np.concatenate([[-1], owner, [-1, -1], np.full(len(road_x), -1)])
    mid = 0.5 * (road_x[:-1] + road_x[1:])
    under = np.array([(lo < mid) & (mid < hi) for lo, hi in ranges]).reshape(-1, len(mid))  # (patches, sides)
    road = slice(n_ext + 2, n_ext + 1 + len(road_x))
    traction = np.zeros((len(points), 2))
    if f.loading_beam:
        beam = under.any(axis=0)
        kind[road][beam] = BONDED
        block[road][beam] = n_blocks + np.argmax(under, axis=0)[beam]
    else:
        traction[road, 1] = -sum(ld.factor / (ld.length * scene.arch.width) * u for ld, u in zip(scene.loads, under))
    loaded = np.isin(road_x, o.road_x)
    sizes = np.concatenate([[FAR_SIZE * size], np.full(n_ext, size), [FAR_SIZE * size],
                            np.where(loaded, LOAD_SIZE * size, FAR_SIZE * size)])
    fans = tuple(int(i) for i in n_ext + 2 + np.nonzero(loaded[1:-1])[0] + 1)
    return Outline(points, sizes, kind, block, traction, fans)


def _extrados_points(ring: ArchRing, size: float) -> tuple[np.ndarray, np.ndarray]:
    """Points of the bridge's top under the fill (:attr:`~bridgefem.geometry.ring.ArchRing.top_pieces`: each span's
    outer voussoirs' extrados, each pier's top), left to right, about ``size`` apart (m), and the block of each
    segment between consecutive points (kinks and load points kept)."""
    top = ring.top_pieces
    pts, owner = [top[0][1][:1]], []
    for b, e in top:
        block = ring.blocks[b]
        splits = block.extrados_splits if isinstance(block, Voussoir) else range(1, len(e) - 1)
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(e, axis=0), axis=1))])
        k = max(1, int(math.ceil(s[-1] / size - 1e-9)))
        pick = np.unique(np.concatenate([np.searchsorted(s, np.linspace(0, s[-1], k + 1)[1:-1]),
                                         list(splits), [len(e) - 1]]).astype(int))
        pick = pick[pick > 0]
        pts.append(e[pick])
        owner.append(np.full(len(pick), b))
    return np.vstack(pts), np.concatenate(owner)


def strip_footing_problem(soil: Soil, breadth: float, half_width: float, depth: float, size: float,
                          rough: bool | None = None) -> LimitProblem:
    """A strip footing of ``breadth`` (m) at the surface of a soil layer ``2 half_width`` wide and ``depth``
    deep (fixed base, roller ends), unit width, mesh size ``size`` (m) at the footing's edges; load factor = the
    footing's force (N per m).

    ``rough`` None: a uniform pressure (a flexible smooth footing); True: a rigid rough footing, the bridge's
    loading beam (:func:`with_loading_beams`: weightless, bonded to the soil, loaded at its centre, free to
    translate and rotate); False: the same rigid footing on a smooth no-tension interface."""
    b2, w, d = breadth / 2, half_width, depth
    points = np.array([[-w, -d], [w, -d], [w, 0.0], [b2, 0.0], [-b2, 0.0], [-w, 0.0]])
    under = {None: ROAD, True: BONDED, False: INTERFACE}[rough]
    kind = np.array([FIXED, ROLLER, ROAD, under, ROAD, ROLLER])
    block = np.array([-1, -1, -1, -1 if rough is None else 0, -1, -1])
    traction = np.zeros((6, 2))
    blocks = _no_blocks()
    if rough is None:
        traction[3, 1] = -1.0 / breadth
    else:
        blocks = with_loading_beams(blocks, [[-b2, b2]], [1.0], 0.0)
    sizes = np.array([FAR_SIZE * 2, FAR_SIZE * 2, FAR_SIZE, 1.0, 1.0, FAR_SIZE]) * size
    mesh = triangulate(Outline(points, sizes, kind, block, traction, (3, 4)))
    return LimitProblem(blocks, 1.0, 1.0, soil, mesh, 0.0, size)


def _no_blocks() -> BlockModel:
    empty = np.zeros((0, 2))
    return BlockModel(np.zeros((0, 2)), np.zeros((0, 3)), np.zeros((0, 3)), empty, empty, np.zeros(0, int),
                      np.zeros(0, int), np.zeros(0))
