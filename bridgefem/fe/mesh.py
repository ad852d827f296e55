"""Gmsh mesh of the voussoirs, split into blocks with duplicated nodes on every joint, as a DOLFINx mesh.

Gmsh builds one surface per block sharing the joint curves, so the mesh is conformal; each ring's joints have
``elements_through_thickness`` segments (per ring: a barrel of n rings has n times as many elements through its
thickness as one ring of the same thickness, so that every ring interface and each ring's hinges are resolved). The
mesh is then split: every node gets one copy per block it belongs to, so that a joint becomes a set of coincident
node pairs (one copy per face). Springing joints have a single face, which meets the rigid ground. Lengths in m,
coordinates as in :mod:`bridgefem.geometry.ring`.

:func:`build_block_mesh`, on rank 0 (Gmsh: Geuzaine & Remacle 2009, Int. J. Numer. Meth. Eng. 79:1309):

1. draws the blocks and joints as data (:func:`_gmsh_bridge`, :class:`_Drawing`): one Gmsh point per distinct location
   (the joints' ends first), a line per voussoir joint (with a compressive strength a chain of lines between the graded
   ``joint_nodes``, one element each: :mod:`bridgefem.analysis.stress_block`), each voussoir's intrados and extrados as
   splines split at their splits (kinks, load points, the other ring's joints), a curve shared by two voussoirs (a ring
   interface) drawn once and reused reversed by the other, each voussoir a surface inside its curves; a ring
   interface joint is the curves of its inner voussoir's extrados between its ends; then the elastic abutments
   (their top the springing joints of every ring), the fill over the outer ring's extrados and its loading beams;
2. meshes them with triangles (:func:`_mesh_voussoirs`): the voussoirs structured where their opposite sides have
   equal numbers of segments (always for one ring: the mesh of a single ring is the one it always was), else
   unstructured from their curves' segments; the rest unstructured with the size fields below;
3. splits the nodes per block (:func:`split_blocks`: a loading beam counts as the fill's block, bonded to it) and
   tags the joint faces, the extrados and the fill's boundaries;

then every rank builds the distributed DOLFINx mesh and its tags (:func:`dolfinx.mesh.create_mesh`).

Under a fill the extrados (shared by the outer ring and fill) is divided at
:func:`~bridgefem.structure.sizing.extrados_element_size` (of the outer ring's thickness, each span its own), at most
``sizing.FILL_DEPTH_SHARE`` x the fill's depth over the crown / ``elements_through_thickness`` (the voussoirs get as
many segments along, their joints keep ``elements_through_thickness``), and a Gmsh size field keeps the fill at each
span's size within the fill's depth of its extrados, graded beyond to the far fill's size
(:func:`~bridgefem.structure.sizing.fill_far_size`: twice the coarsest span's outer ring element size), the least of
the spans' fields (:func:`~bridgefem.structure.sizing.fill_element_sizes`, the rule the size estimate integrates).
The road's load points (patch edges, point loads) get ``LOAD_REFINEMENT`` x the extrados size of the span under
them: the bearing zone under a load lies in the fill, whose depth, not the ring's thickness, sets its scale
(docs/fill.md, *Why the fill's scale at the loads*).

Elastic abutments (:func:`bridgefem.geometry.ring.add_abutments`) and the piers' courses of a bridge of several
spans (:func:`bridgefem.geometry.bridge.build_bridge`) are meshed with unstructured triangles, as many across a
block as a ring has through its thickness and at least twice the finest ring element size of the spans each carries
(:func:`~bridgefem.structure.sizing.support_element_size`), graded from the springing joints' nodes; their tops
share the springing joints' curves with the rings, a pier's bed joints are lines shared by its two courses, and a
base or foundation on the ground is a joint with a single face, like a springing on rigid ground. The bridge's top
(every span's outer extrados and the piers' top edges between them) is where loads act and a fill rests.

Tags on the DOLFINx mesh:
- cell tag = block id (voussoir, pier course, abutment), or ``fill_block`` (= the number of blocks) for the fill;
- facet tag ``2 j`` / ``2 j + 1`` = left / right face of joint j (the ground face of a springing is absent);
  ``EXTRADOS_TAG`` = extrados of the ring (where live loads act on a bare arch); with a fill, its side of the
  extrados ``FILL_INTERFACE_TAG`` (the extrados becomes an interface like a joint: its nodes are duplicated),
  the road ``ROAD_TAG``, its vertical ends ``FILL_END_TAG`` and its base ``FILL_BASE_TAG``; the top face of a
  loading beam ``BEAM_TOP_TAG``.

Loading beams (``beams``: the x-ranges of the patch loads, m): a rectangle on the road over each range, of height
``BEAM_HEIGHT`` x its length, meshed with the fill and sharing its nodes on the road (bonded: not split), with a
cell tag of its own (``beam_blocks``, after the fill's); the road under it is not tagged ``ROAD_TAG``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import ufl
from dolfinx import cpp as _cpp
from dolfinx.mesh import GhostMode, Mesh, MeshTagsMetaClass, meshtags, meshtags_from_entities
from mpi4py import MPI

from ..geometry.ring import ROUND_OFF, Abutment, ArchRing, FillOutline, PierBlock
from ..structure.sizing import (
    EXTRADOS_BAND,
    FILL_GRADING,
    TopPiece,
    extrados_sizes,
    fill_far_size,
    ring_element_sizes,
    size_under,
    support_element_size,
    top_pieces,
)

EXTRADOS_TAG = 1_000_000  # the ring's side of the extrados
FILL_INTERFACE_TAG = 1_000_001  # the fill's side of the extrados (arch-fill interface)
ROAD_TAG = 1_000_002
FILL_END_TAG = 1_000_003  # vertical ends of the fill (rollers)
FILL_BASE_TAG = 1_000_004  # base of the fill (fixed)
BEAM_TOP_TAG = 1_000_005  # top face of a loading beam (where its patch load acts)
BEAM_HEIGHT = 0.5  # height of a loading beam / its length
LOAD_REFINEMENT = 0.5  # mesh size at a load's edge on the road / the extrados element size (the fill's own scale)
BOUNDARY_TAGS = (EXTRADOS_TAG, FILL_INTERFACE_TAG, ROAD_TAG, FILL_END_TAG, FILL_BASE_TAG, BEAM_TOP_TAG)


def joint_face_tag(joint: int, side: int) -> int:
    """Facet tag of a joint face: side 0 = the joint's left block, 1 = its right block."""
    return 2 * joint + side


def marked(mesh: Mesh, tags: MeshTagsMetaClass, values) -> MeshTagsMetaClass:
    """The entities of ``tags`` (on ``mesh``) whose tag is one of ``values``, all tagged 1: a form integrating over
    tag 1 is then the same (compiled once) whatever the values, e.g. however many voussoirs there are."""
    entities = tags.indices[np.isin(tags.values, values)]
    return meshtags(mesh, tags.dim, entities, np.ones(len(entities), dtype=np.int32))


@dataclass
class BlockMesh:
    """The distributed mesh with its tags; ``n_cells`` and ``n_nodes`` count the split (duplicated) mesh;
    ``fill_block`` is the cell tag of the fill (None without fill), ``support_blocks`` those of the blocks that carry
    the spans (the elastic abutments, the piers' courses),
    ``beam_blocks`` those of the loading beams."""

    mesh: Mesh
    cell_tags: MeshTagsMetaClass
    facet_tags: MeshTagsMetaClass
    element_size: float
    n_cells: int
    n_nodes: int
    fill_block: int | None = None
    support_blocks: tuple[int, ...] = ()
    beam_blocks: tuple[int, ...] = ()
    joint_nodes: tuple[float, ...] | None = None  # the ring joints' element ends (fractions of the depth), None: even


class _Drawing:
    """The Gmsh entities of the blocks, each drawn once: one point per distinct location (two points closer than
    ``tol`` m are one), one curve per pair of end points, found again in either direction (a curve shared by two
    blocks is drawn by the first and reused, reversed when it runs the other way, by the second)."""

    def __init__(self, geo, tol: float):
        self.geo, self.tol = geo, tol
        self.points: dict[tuple[int, int], int] = {}
        self.curves: dict[tuple[int, int], int] = {}
        self.chains: dict[tuple[int, int], list[int]] = {}

    def find(self, xy) -> int | None:
        """The point at ``xy`` (m), or None."""
        i, j = (int(np.floor(v / self.tol)) for v in xy)
        return next((self.points[i + a, j + b] for a in (0, 1, -1) for b in (0, 1, -1) if (i + a, j + b) in
                     self.points), None)

    def point(self, xy, size: float = 0.0) -> int:
        """The point at ``xy`` (m), drawn with the mesh ``size`` (m; 0: from its curves) if it is new."""
        tag = self.find(xy)
        if tag is None:
            tag = self.geo.addPoint(float(xy[0]), float(xy[1]), 0.0, size)
            self.points[tuple(int(np.floor(v / self.tol)) for v in xy)] = tag
        return tag

    def curve(self, a: int, b: int) -> int | None:
        """The curve from point ``a`` to point ``b`` (negative: drawn from b to a), or None."""
        if (a, b) in self.curves:
            return self.curves[a, b]
        return -self.curves[b, a] if (b, a) in self.curves else None

    def line(self, a: int, b: int) -> int:
        """The straight curve from point ``a`` to ``b``, drawn if it is new."""
        found = self.curve(a, b)
        if found is None:
            found = self.curves[a, b] = self.geo.addLine(a, b)
        return found

    def chain(self, points: np.ndarray) -> list[int]:
        """Straight lines through ``points`` (m) in turn, drawn if new, kept as one path between its ends."""
        tags = [self.point(p) for p in points]
        lines = [self.line(a, b) for a, b in zip(tags[:-1], tags[1:])]
        self.chains[tags[0], tags[-1]] = lines
        return lines

    def path(self, a: int, b: int) -> list[int]:
        """The curves from point ``a`` to point ``b``: a :meth:`chain` between them (in either direction), else the
        straight line."""
        if (a, b) in self.chains:
            return self.chains[a, b]
        if (b, a) in self.chains:
            return [-c for c in self.chains[b, a][::-1]]
        return [self.line(a, b)]

    def side(self, points: np.ndarray, splits: tuple[int, ...]) -> list[tuple[int, int, int]]:
        """The curves of a block's side through ``points`` (m), splines broken at the indices ``splits``, as
        (first point, last point, curve) in the side's direction: the pieces already drawn (by a neighbouring block,
        the same points) are reused; the new pieces' inner points are drawn in the side's order, then their
        splines."""
        cuts = [0, *splits, len(points) - 1]
        ends = {k: self.point(points[k]) if k in (0, len(points) - 1) else self.find(points[k]) for k in cuts}
        new = [(a, b) for a, b in zip(cuts[:-1], cuts[1:])
               if ends[a] is None or ends[b] is None or self.curve(ends[a], ends[b]) is None]
        tags = dict(ends)
        for k in range(1, len(points) - 1):
            if k in ends:
                tags[k] = ends[k] if ends[k] is not None else self.point(points[k])
            elif any(a < k < b for a, b in new):
                tags[k] = self.geo.addPoint(float(points[k, 0]), float(points[k, 1]), 0.0)
        for a, b in new:
            self.curves[tags[a], tags[b]] = self.geo.addSpline([tags[k] for k in range(a, b + 1)])
        return [(tags[a], tags[b], self.curve(tags[a], tags[b])) for a, b in zip(cuts[:-1], cuts[1:])]


def _segment_counts(lengths: list[float], total: int) -> list[int]:
    """Split ``total`` (at least one per curve) segments over curves in proportion to length, at least one each.

    Rounding and the minimum of one can exceed ``total``; the curve with the most segments then gives up the
    excess, and when it would keep none (a long chord beside short curves, e.g. a patch's edges on a pointed
    crown's cap) the curves with the most segments give it theirs back one at a time: Gmsh aborts on a
    transfinite curve without a segment."""
    raw = np.maximum(1, np.round(np.asarray(lengths) / sum(lengths) * total)).astype(int)
    top = int(np.argmax(raw))
    raw[top] += total - raw.sum()
    others = np.arange(len(raw)) != top
    while raw[top] < 1:
        donor = int(np.argmax(np.where(others, raw, 0)))
        raw[donor] -= 1
        raw[top] += 1
    return [int(v) for v in raw]


@dataclass
class _RawMesh:
    """The conformal Gmsh mesh before splitting: node coordinates, triangles and their block ids, and boundary
    segments (pairs of node ids): per joint, on the extrados, and per fill boundary tag."""

    x: np.ndarray
    cells: np.ndarray
    blocks: np.ndarray
    joints: dict
    extrados: np.ndarray
    fill: dict
    h: float


def voussoir_element_sizes(ring: ArchRing, per_thickness: int) -> dict[int, float]:
    """The element size (m) of each voussoir (by id): its own ring's, in its own span (:func:`ring_element_sizes`)."""
    return {v.id: ring_element_sizes(b, per_thickness)[v.ring] for b in ring.barrels for v in b.voussoirs}


def _top_curves(draw: _Drawing, ring: ArchRing, sides: dict, pieces: list[TopPiece]
                ) -> list[tuple[list[int], float]]:
    """The bridge's top, left to right, as (curves, element size m): the curves of each of ``pieces``
    (:func:`~bridgefem.structure.sizing.top_pieces`: each span's outer extrados, where the loads act on a bare bridge
    and the fill rests, and the free top edge of each pier between two spans) with its size."""
    out = []
    for piece in pieces:
        curves = []
        for block in (ring.blocks[i] for i in piece.blocks):
            if isinstance(block, PierBlock):
                top = block.top
                curves += [c for a, b in zip(top[:-1], top[1:]) for c in draw.path(draw.point(a), draw.point(b))]
            else:
                curves += [c for *_, c in sides[block.id][1]]
        out.append((curves, piece.size))
    return out


def _gmsh_bridge(ring: ArchRing, per_thickness: int, outline: FillOutline | None, h_fill: float,
                 beams: tuple[tuple[float, float], ...] = (), joint_nodes: tuple[float, ...] | None = None
                 ) -> _RawMesh:
    """Mesh the barrel, and the fill over it when ``outline`` is given (with a loading beam over each x-range of
    ``beams``), with Gmsh (rank 0 only); the steps of the module docstring. ``h`` of the result: the smallest ring's
    element size. ``joint_nodes``: the element ends of every ring's voussoir joints and springings, fractions of each
    joint's depth from its intrados end (None: ``per_thickness`` even elements)."""
    import gmsh

    gmsh.initialize([], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("bridge")
        geo = gmsh.model.geo
        sizes = voussoir_element_sizes(ring, per_thickness)
        h = min(sizes.values())
        depth = outline.y_road - ring.crown_extrados if outline is not None else None
        span_extrados = extrados_sizes(ring, per_thickness, depth)
        top_sizes = top_pieces(ring, span_extrados)
        draw = _Drawing(geo, ROUND_OFF * ring.span)
        ring_joints = ring.ring_joints
        for end in ("intrados", "extrados"):
            for j in ring_joints:
                draw.point(getattr(j, end))
        fractions = np.asarray(joint_nodes if joint_nodes is not None else (0.0, 1.0))
        joint_curves = {j.id: draw.chain(j.intrados + fractions[:, None] * (j.extrados - j.intrados))
                        for j in ring_joints}
        sides, surfaces = {}, []
        for v in ring.voussoirs:
            intra, extra = draw.side(v.intrados, v.intrados_splits), draw.side(v.extrados, v.extrados_splits)
            left, right = (draw.path(draw.point(v.intrados[k]), draw.point(v.extrados[k])) for k in (0, -1))
            loop = geo.addCurveLoop([c for *_, c in intra] + right + [-c for *_, c in extra[::-1]]
                                    + [-c for c in left[::-1]])
            surfaces.append(geo.addPlaneSurface([loop]))
            sides[v.id] = (intra, extra)
        for j in ring.joints:
            if j.kind == "ring":  # the inner block's extrados pieces from the joint's left end to its right end
                pieces = sides[j.left][1]
                first = next(k for k, (a, _, _) in enumerate(pieces) if a == draw.point(j.extrados))
                last = next(k for k, (_, b, _) in enumerate(pieces) if b == draw.point(j.intrados))
                joint_curves[j.id] = [c for *_, c in pieces[first:last + 1]]
        support_sizes = [support_element_size(ring, block, per_thickness) for block in ring.piers + ring.abutments]
        support_surfaces = [(_add_support(draw, block, ring, joint_curves, size), block.id)
                            for block, size in zip(ring.piers + ring.abutments, support_sizes)]
        top = _top_curves(draw, ring, sides, top_sizes)
        extrados_curves = [c for curves, _ in top for c in curves]
        fill_curves = {}
        if outline is not None:  # the fill's base begins at the outer ring's springings' extrados corners
            corners = [draw.point(ring.springings(side)[-1].extrados) for side in ("left", "right")]
            fill_curves = _add_fill(geo, outline, corners, extrados_curves, h_fill,
                                    lambda x: LOAD_REFINEMENT * size_under(top_sizes, x), beams)
        geo.synchronize()
        if outline is not None or ring.abutments or ring.piers:
            gmsh.option.setNumber("Mesh.MeshSizeMax", max(h_fill if outline is not None else 0.0, 2 * h,
                                                          *support_sizes))
        mesh = gmsh.model.mesh
        if outline is not None:
            boundary = [c for tag in (FILL_BASE_TAG, FILL_END_TAG, ROAD_TAG) for c in fill_curves[tag]]
            _grade_fill_from_extrados(fill_curves["surface"], boundary, top, h_fill, depth)
        for c in (c for j in ring_joints for c in joint_curves[j.id]):
            mesh.setTransfiniteCurve(abs(c), per_thickness + 1 if joint_nodes is None else 2)
        _mesh_voussoirs(ring, sides, surfaces, sizes, span_extrados if outline is not None else None)
        mesh.generate(2)
        tags, xyz, _ = mesh.getNodes()
        order = np.zeros(int(tags.max()) + 1, dtype=np.int64)
        order[tags.astype(np.int64)] = np.arange(len(tags))

        def elements(dim, entity, nodes_per):
            return order[np.asarray(mesh.getElements(dim, abs(entity))[2][0], dtype=np.int64)].reshape(-1, nodes_per)

        block_surfaces = [(s, v.id) for s, v in zip(surfaces, ring.voussoirs)] + support_surfaces
        if outline is not None:
            block_surfaces.append((fill_curves.pop("surface"), ring.n_blocks))
            block_surfaces += [(b, ring.n_blocks + 1 + k) for k, b in enumerate(fill_curves.pop("beams"))]
        cells = [elements(2, s, 3) for s, _ in block_surfaces]
        blocks = [np.full(len(c), i, dtype=np.int32) for c, (_, i) in zip(cells, block_surfaces)]
        return _RawMesh(xyz.reshape(-1, 3)[:, :2], np.vstack(cells), np.concatenate(blocks),
                        {j: np.vstack([elements(1, c, 2) for c in curves]) for j, curves in joint_curves.items()},
                        np.vstack([elements(1, c, 2) for c in extrados_curves]),
                        {tag: np.vstack([elements(1, c, 2) for c in curves]) for tag, curves in fill_curves.items()},
                        h)
    finally:
        gmsh.finalize()


def _mesh_voussoirs(ring: ArchRing, sides: dict, surfaces: list[int], sizes: dict[int, float],
                    h_extrados: list[float] | None) -> None:
    """The segments of the voussoirs' intrados and extrados curves (``sides``: per voussoir its two sides' (first
    point, last point, curve) pieces; ``surfaces``: the voussoirs' surfaces in id order), and which voussoirs are
    structured. ``sizes``: each voussoir's element size (m, by id: its ring's); ``h_extrados``: each span's element
    size along the extrados under a fill (m; None: no fill).

    1. A curve shared by two voussoirs (between two rings) gets one segment per element size of the finer ring,
       ceil(length / h).
    2. A voussoir with no shared side (a single ring) gets n_along segments along both sides: about one per element
       size h of its centreline, one per ``h_extrados`` along a fill's extrados when that is finer, at least one per
       curve; each side's curves share them in proportion to their lengths (:func:`_segment_counts`).
    3. A voussoir with one shared side gives its other side as many segments as the shared one, in proportion to
       its curves' lengths, if that is at least the other side's own least (its curves, a fill's extrados size);
       else the other side's curves get ceil(length / h) each (h: the ring's, or ``h_extrados`` on a fill's
       extrados).
    4. A voussoir whose opposite sides have equal counts is meshed structured (transfinite, ``Alternate``
       triangles) between its four corners, any other unstructured from its boundary's segments.
    """
    import gmsh

    mesh = gmsh.model.mesh
    counts: dict[int, int] = {}
    users: dict[int, list[int]] = {}
    for v in ring.voussoirs:
        for side in sides[v.id]:
            for *_, c in side:
                users.setdefault(abs(c), []).append(v.id)
    for c, blocks in users.items():
        if len(blocks) > 1:
            counts[c] = max(1, int(np.ceil(_curve_length(c) / min(sizes[b] for b in blocks) - 1e-9)))
            mesh.setTransfiniteCurve(c, counts[c] + 1)
    outer = {v.id for v in ring.outer_voussoirs}
    for s, v in zip(surfaces, ring.voussoirs):
        h = sizes[v.id]
        intra, extra = ([abs(c) for *_, c in side] for side in sides[v.id])
        on_fill = h_extrados[v.span] if v.id in outer and h_extrados is not None else None
        fill_size = on_fill if on_fill is not None and on_fill < h else None
        # segments along the extrados that a fill's size asks for (its nodes are the fill's)
        n_fill = sum(int(np.ceil(_curve_length(c) / fill_size - 1e-9)) for c in extra) if fill_size else 0
        known = [all(c in counts for c in side) for side in (intra, extra)]
        if not any(known):
            centre = 0.5 * (v.intrados + v.extrados)
            length = np.linalg.norm(np.diff(centre, axis=0), axis=1).sum()
            # 1e-9: a length of exactly k h gives k
            n_along = max(int(np.ceil(length / h - 1e-9)), n_fill, len(intra), len(extra))
            plan = [(side, _shares(side, n_along)) for side in (intra, extra)]
        elif all(known):
            plan = []
        else:
            shared, other = (intra, extra) if known[0] else (extra, intra)
            total = sum(counts[c] for c in shared)
            plan = [(other, _shares(other, total) if total >= max(len(other), n_fill) else
                     [int(np.ceil(_curve_length(c) / (fill_size or h) - 1e-9)) for c in other])]
        for side, along in plan:
            for c, m in zip(side, along):
                counts[c] = m
                mesh.setTransfiniteCurve(c, m + 1)
        if sum(counts[c] for c in intra) == sum(counts[c] for c in extra):
            below, above = sides[v.id]
            mesh.setTransfiniteSurface(s, "Alternate", [below[0][0], below[-1][1], above[-1][1], above[0][0]])


def _shares(curves: list[int], total: int) -> list[int]:
    """``total`` segments over ``curves`` in proportion to their lengths (:func:`_segment_counts`)."""
    return _segment_counts([_curve_length(c) for c in curves] if len(curves) > 1 else [1.0], total)


def _grade_fill_from_extrados(surface: int, boundary: list[int], top: list[tuple[list[int], float]], far_size: float,
                              depth: float) -> None:
    """Gmsh size field of the fill (its ``surface`` and its ``boundary`` curves only): along each piece of the
    bridge's ``top`` (curves, size m) its size within ``EXTRADOS_BAND`` x ``depth`` (the fill's depth over the crown,
    m) of it, growing by ``FILL_GRADING`` per metre beyond that band up to ``far_size`` (at least the piece's); the
    least of the pieces' fields. Gmsh takes the smaller of this and the sizes at the fill's points (load edges,
    corners)."""
    import gmsh

    field = gmsh.model.mesh.field
    thresholds = []
    for curves, size in top:
        distance = field.add("Distance")
        field.setNumbers(distance, "CurvesList", curves)
        field.setNumber(distance, "NumPointsPerCurve", 20)
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "SizeMin", size)
        field.setNumber(threshold, "SizeMax", max(far_size, size))
        field.setNumber(threshold, "DistMin", EXTRADOS_BAND * depth)
        field.setNumber(threshold, "DistMax", EXTRADOS_BAND * depth + (max(far_size, size) - size) / FILL_GRADING)
        thresholds.append(threshold)
    least = field.add("Min")
    field.setNumbers(least, "FieldsList", thresholds)
    restricted = field.add("Restrict")
    field.setNumber(restricted, "InField", least)
    field.setNumbers(restricted, "FacesList", [surface])
    field.setNumbers(restricted, "EdgesList", boundary)
    field.setAsBackgroundMesh(restricted)


def _add_fill(geo, outline: FillOutline, corners: list[int], extrados_curves: list[int], h_fill: float,
              h_load: Callable[[float], float], beams: tuple[tuple[float, float], ...] = ()) -> dict:
    """The fill surface over the extrados and the loading beams on its road (one per x-range of ``beams``, whose
    ends are road points of ``outline``): the Gmsh surfaces ("surface", "beams") and the boundary curves per facet
    tag. Mesh sizes (m): ``h_fill`` at the fill's corners, ``h_load(x)`` at the road's load point at x (patch edges,
    point loads), where the bearing stress is singular, the beam's height at its top corners; the extrados's
    (:func:`~bridgefem.structure.sizing.extrados_element_size`) along it and within the fill's depth of it
    (:func:`_grade_fill_from_extrados`); Gmsh grades in between."""
    o = outline
    base_left, base_right = geo.addPoint(o.x_left, o.y_base, 0.0, h_fill), geo.addPoint(o.x_right, o.y_base, 0.0,
                                                                                         h_fill)
    road_x = [o.x_right, *sorted((x for x in o.road_x if o.x_left < x < o.x_right), reverse=True), o.x_left]
    road = [geo.addPoint(x, o.y_road, 0.0, h_fill if i in (0, len(road_x) - 1) else h_load(x))
            for i, x in enumerate(road_x)]
    bases = [geo.addLine(base_left, corners[0]), geo.addLine(corners[1], base_right)]
    ends = [geo.addLine(base_right, road[0]), geo.addLine(road[-1], base_left)]
    road_lines = [geo.addLine(a, b) for a, b in zip(road[:-1], road[1:])]
    loop = geo.addCurveLoop([bases[0], *extrados_curves, bases[1], ends[0], *road_lines, ends[1]])
    under, surfaces, tops = set(), [], []
    for a, b in beams:
        first, last = road_x.index(b), road_x.index(a)  # road_x descends: the lines first .. last - 1 lie under
        height = BEAM_HEIGHT * (b - a)
        top_b, top_a = (geo.addPoint(x, o.y_road + height, 0.0, height) for x in (b, a))
        sides = [geo.addLine(road[first], top_b), geo.addLine(top_b, top_a), geo.addLine(top_a, road[last])]
        bottom = [-road_lines[k] for k in range(last - 1, first - 1, -1)]  # from a to b
        surfaces.append(geo.addPlaneSurface([geo.addCurveLoop([*bottom, *sides])]))
        tops.append(sides[1])
        under.update(range(first, last))
    return {"surface": geo.addPlaneSurface([loop]), "beams": surfaces, FILL_BASE_TAG: bases, FILL_END_TAG: ends,
            ROAD_TAG: [c for k, c in enumerate(road_lines) if k not in under], FILL_INTERFACE_TAG: extrados_curves,
            **({BEAM_TOP_TAG: tops} if beams else {})}


def _add_support(draw: _Drawing, block: Abutment | PierBlock, ring: ArchRing, joint_curves: dict, size: float) -> int:
    """The Gmsh surface of a block that carries the rings (an abutment, a pier's course): its polygon's corners as
    points (the springing joints' corners are the rings'; ``size`` (m) the mesh size at the others), its sides the
    springing joints' curves where they are one, each of its straight joints (an abutment's base, a pier's bed
    joints) a line set in ``joint_curves`` at the joint's id (drawn once, by the first of its two blocks), and lines
    elsewhere."""
    points = [draw.point(p, size) for p in block.polygon]
    for j in ring.joints:
        if j.kind in ("base", "pier") and block.id in (j.left, j.right):
            joint_curves[j.id] = [draw.line(draw.point(j.intrados), draw.point(j.extrados))]
    loop = [c for a, b in zip(points, points[1:] + points[:1]) for c in draw.path(a, b)]
    return draw.geo.addPlaneSurface([draw.geo.addCurveLoop(loop)])


def _curve_length(curve: int) -> float:
    import gmsh

    lo, hi = gmsh.model.getParametrizationBounds(1, curve)
    pts = np.asarray(gmsh.model.getValue(1, curve, np.linspace(lo, hi, 9).ravel())).reshape(-1, 3)
    return float(np.linalg.norm(np.diff(pts[:, :2], axis=0), axis=1).sum())


def split_blocks(x: np.ndarray, cells: np.ndarray, blocks: np.ndarray):
    """Give every node one copy per block: returns new coordinates, cells and ``copy(block, old_node)``."""
    n_old = len(x)
    keys = blocks.astype(np.int64)[:, None] * n_old + cells
    unique, inverse = np.unique(keys.ravel(), return_inverse=True)

    def copy(block, old):
        k = np.asarray(block, dtype=np.int64) * n_old + np.asarray(old, dtype=np.int64)
        idx = np.searchsorted(unique, k)
        assert np.all(unique[np.minimum(idx, len(unique) - 1)] == k), "node not in block"
        return idx

    return x[unique % n_old], inverse.reshape(cells.shape), copy


def build_block_mesh(ring: ArchRing, per_thickness: int, comm: MPI.Comm = MPI.COMM_WORLD,
                     fill: FillOutline | None = None, fill_element_size: float = 0.0,
                     beams: tuple[tuple[float, float], ...] = (),
                     joint_nodes: tuple[float, ...] | None = None) -> BlockMesh:
    """Mesh the ring (and the fill over it) on rank 0, split it at the joints and the extrados, distribute it.

    ``fill_element_size`` (m) is the fill's mesh size away from the rings (0: twice the coarsest span's outer ring
    element size, :func:`~bridgefem.structure.sizing.fill_far_size`);
    ``beams``: x-ranges (m) of loading beams on the fill's road (each end one of ``fill.road_x``; not overlapping);
    ``joint_nodes``: the ring joints' element ends, fractions of the depth from the intrados, 0 to 1 (None:
    ``per_thickness`` even elements, whose size is the ring's element size either way).
    """
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.triangle, 1))
    fill_block = ring.n_blocks if fill is not None else None
    beams = beams if fill is not None else ()
    beam_blocks = tuple(range(ring.n_blocks + 1, ring.n_blocks + 1 + len(beams)))
    if comm.rank == 0:
        h_fill = fill_far_size(ring, per_thickness, fill_element_size)
        raw = _gmsh_bridge(ring, per_thickness, fill, h_fill, beams, joint_nodes)
        # a beam is bonded to the road: its nodes are the fill's (split as one block)
        xs, cs, copy = split_blocks(raw.x, raw.cells, np.minimum(raw.blocks, ring.n_blocks))
        facets, values = [], []
        for j, seg in raw.joints.items():
            if ring.joints[j].free:
                continue
            for side, block in enumerate((ring.joints[j].left, ring.joints[j].right)):
                if block is not None:
                    facets.append(copy(np.full(seg.shape, block), seg))
                    values.append(np.full(len(seg), joint_face_tag(j, side), dtype=np.int32))
        ring_cells = np.flatnonzero(raw.blocks < ring.n_blocks)  # the fill's cells share the extrados edges
        ext_block = raw.blocks[ring_cells[_owning_cell(raw.cells[ring_cells], raw.extrados)]]
        facets.append(copy(np.stack([ext_block, ext_block], axis=1), raw.extrados))
        values.append(np.full(len(raw.extrados), EXTRADOS_TAG, dtype=np.int32))
        for tag, seg in raw.fill.items():
            facets.append(copy(np.full(seg.shape, fill_block), seg))
            values.append(np.full(len(seg), tag, dtype=np.int32))
        facets, values = np.vstack(facets).astype(np.int64), np.concatenate(values)
        cell_values = raw.blocks
        info = comm.bcast((raw.h, len(cs), len(xs)), root=0)
    else:
        xs, cs = np.zeros((0, 2)), np.zeros((0, 3), dtype=np.int64)
        facets, values = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int32)
        cell_values = np.zeros(0, dtype=np.int32)
        info = comm.bcast(None, root=0)
    mesh = _create_mesh(comm, cs, xs, domain)
    tdim = mesh.topology.dim
    ct = _tags(mesh, tdim, cs, cell_values)
    mesh.topology.create_connectivity(tdim - 1, tdim)
    ft = _tags(mesh, tdim - 1, facets, values)
    return BlockMesh(mesh, ct, ft, info[0], info[1], info[2], fill_block, tuple(b.id for b in ring.piers + ring.abutments),
                     beam_blocks, joint_nodes)


def _create_mesh(comm: MPI.Comm, cells: np.ndarray, x: np.ndarray, domain: ufl.Mesh) -> Mesh:
    """:func:`dolfinx.mesh.create_mesh` with the cells passed as an adjacency list: given a numpy array, DOLFINx
    0.5 first calls the C++ function with it, which raises a TypeError whose message formats both arrays."""
    cmap = _cpp.fem.CoordinateElement(_cpp.mesh.CellType.triangle, 1)
    adjacency = _cpp.graph.AdjacencyList_int64(np.ascontiguousarray(cells, dtype=np.int64))
    return Mesh(_cpp.mesh.create_mesh(comm, adjacency, cmap, np.ascontiguousarray(x), GhostMode.shared_facet,
                                      _cpp.mesh.create_cell_partitioner()), domain)


def _owning_cell(cells: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """For each boundary segment (two node ids), the index of a cell containing both nodes."""
    n = cells.max() + 1
    edge_keys = np.concatenate([np.sort(cells[:, [a, b]], axis=1) @ np.array([n, 1]) for a, b in
                                ((0, 1), (1, 2), (2, 0))])
    edge_cell = np.tile(np.arange(len(cells)), 3)
    order = np.argsort(edge_keys)
    seg_keys = np.sort(segments, axis=1) @ np.array([n, 1])
    pos = np.searchsorted(edge_keys[order], seg_keys)
    return edge_cell[order][pos]


def _tags(mesh: Mesh, dim: int, entities: np.ndarray, values: np.ndarray) -> MeshTagsMetaClass:
    local, local_values = _cpp.io.distribute_entity_data(mesh._mesh, dim, entities, values)
    mesh.topology.create_connectivity(dim, 0)
    return meshtags_from_entities(mesh, dim, _cpp.graph.AdjacencyList_int32(local),
                                  np.asarray(local_values, dtype=np.int32))
