"""The size of a scene's model, estimated from the scene alone before anything is built: cells, unknowns and the
memory of the direct solver, so that a run far beyond the machine is refused with the numbers instead of
swapping for minutes, and a long one is announced.

Cells follow the mesher's rules (:mod:`bridgefem.fe.mesh`): element size h = thickness / elements_through_thickness
in each ring, each voussoir a structured grid of ``elements_through_thickness`` x ceil(length / h) quadrilaterals
cut into two triangles (more along under a thin fill: one per extrados element size); the piers' courses and the
abutments unstructured with as many elements across as a ring has through its thickness, at least twice the finest
element size of the spans each carries (:func:`block_element_size`); the fill over the whole bridge (its road
at the highest crown's extrados plus its depth, over the piers too) integrated with the mesher's size field
(:func:`fill_element_sizes`: each span's extrados size in a band along it, graded to the bridge's far size). With a
compressive strength the ring joints are graded for the stress block before meshing
(:mod:`bridgefem.analysis.stress_block`), each voussoir's grid then as many elements through as its joints: the
estimate counts the graded joints when they are given, else the most the grading may give
(:func:`graded_elements`), so that it never falls short of the model it guards. The memory
is a fit ``MEMORY_BASE + MEMORY_PER_DOF x n log2 n`` (bytes, n unknowns) of the peak resident size of serial runs
(MUMPS LU with nested dissection: the factor of a 2D mesh grows as n log n), measured on serial runs of the
bare arch from 1k to 68k unknowns (117 to 127 bytes per n log2 n). With a fill the base is ``FILL_MEMORY_BASE``
(its quadrature fields, the conic bounds' programmes), and quadratic elements take 255 bytes per n log2 n (a row
couples about twice the unknowns): measured on Prestwood at 2, 4 and 8 elements through the ring (12k, 41k, 146k
unknowns: 0.30, 0.41, 0.94 GB) and a three-span bridge (216k: 1.25 GB), each within 35 MB of the fit, and on an
elastic fill over five spans on linear elements (35k: 0.35 GB, the fit 0.33 GB) (docs/robustness.md, *Several
spans*). The estimate comes within 1 % of the mesher's
cells and unknowns on a bare arch; with a fill, whose unstructured mesh Gmsh also grades from the sizes along its
boundaries (which the field alone does not model), from 0.65 to 1.6 x the mesher's cells on the scenes measured
(docs/robustness.md, *Several spans*): close enough to refuse a model beyond the machine, not to predict its exact
size.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..geometry.ring import Abutment, ArchRing, FillOutline, PierBlock, fill_outline
from ..geometry.shapes import make_shape
from ..scene.keys import SceneError
from ..scene.model import Arch, Scene
from .grading import densest_grading

MEMORY_BASE = 190e6  # bytes: Python, DOLFINx, PETSc and MUMPS loaded, before the model (measured)
FILL_MEMORY_BASE = 270e6  # bytes: the same with a fill (its quadrature fields, the conic bounds' programmes; fit)
MEMORY_PER_DOF = {1: 120.0, 2: 255.0}  # bytes per n log2 n unknowns by element degree: matrix, factor and work
# space (fits, see the docstring)
LARGE_DOFS = 200_000  # unknowns above which a run is announced with its estimate and set-up phases
MAX_DOFS = 1_000_000  # unknowns above which a run is refused (unless asked for): a limit search factorises the
# matrix 50-100 times, which at this size takes hours on a workstation
FILL_DEPTH_SHARE = 1.0  # extrados element size x elements through the ring / fill depth over the crown
EXTRADOS_BAND = 1.0  # width of the band along the extrados kept at that size / the fill's depth over the crown
FILL_GRADING = 0.5  # growth of the fill's element size per unit distance beyond that band (m/m)
TRIANGLES_PER_AREA = 4.2  # unstructured triangles per h^2 of fill area (Gmsh, measured on two fills)
GRADED_PAIRS = 3000  # joint pairs that graded ring joints may have in all: a limit search's active-set iterations
# grow faster than the pairs that crush one after another, and beyond a few thousand graded pairs a search takes
# minutes (docs/robustness.md); ring joints of even elements keep theirs whatever their number


def extrados_element_size(thickness: float, per_thickness: int, depth: float | None) -> float:
    """Element size (m) along the extrados: the ring's, ``thickness`` / ``per_thickness``; under a fill ``depth`` (m)
    deep over the crown at most ``FILL_DEPTH_SHARE`` x ``depth`` / ``per_thickness``, so that a thin fill over a
    thick ring has elements through its depth and the size still halves with each doubling of ``per_thickness``."""
    return min(thickness, FILL_DEPTH_SHARE * depth if depth is not None else thickness) / per_thickness


def ring_element_sizes(ring: ArchRing, per_thickness: int) -> tuple[float, ...]:
    """The element size (m) of each ring of a barrel (one span's), from the intrados out: its thickness /
    ``per_thickness``."""
    return tuple(t / per_thickness for t in (ring.ring_thicknesses or (ring.thickness,)))


def extrados_sizes(ring: ArchRing, per_thickness: int, depth: float | None) -> list[float]:
    """The element size (m) along each span's extrados (:func:`extrados_element_size` of its outer ring's thickness
    and the fill's ``depth`` over the crown, m; None: no fill)."""
    return [extrados_element_size((b.ring_thicknesses or (b.thickness,))[-1], per_thickness, depth)
            for b in ring.barrels]


def block_element_size(finest: float, extent: float, per_thickness: int) -> float:
    """The element size (m) of a block that carries spans (an elastic abutment, a pier's course): as many elements
    across its lesser ``extent`` (m, the lesser side of its bounding box) as a ring has through its thickness
    (``per_thickness``), so that its bed joints and base are resolved as a ring's joints are and its interior is no
    finer than that; at least twice ``finest`` (m), the finest ring element size of the spans it carries, so that a
    small block is not meshed finer than those rings. Gmsh grades it from the springing joints' finer nodes."""
    return max(2 * finest, extent / per_thickness)


def support_element_size(ring: ArchRing, block: Abutment | PierBlock, per_thickness: int) -> float:
    """The element size (m) of a block that carries spans (:func:`block_element_size`): a pier k carries spans k and
    k + 1, an abutment the end span on its side, so that a pier between thick rings is not meshed at a thin ring's
    size elsewhere on the bridge."""
    barrels = ring.barrels
    if isinstance(block, PierBlock):
        carried = barrels[block.pier:block.pier + 2]
    else:
        carried = barrels[:1] if block.side == "left" else barrels[-1:]
    finest = min(min(ring_element_sizes(b, per_thickness)) for b in carried)
    return block_element_size(finest, float(np.ptp(block.polygon, axis=0).min()), per_thickness)


def fill_far_size(ring: ArchRing, per_thickness: int, element_size: float = 0.0) -> float:
    """The fill's element size (m) away from the rings: ``element_size`` (``[fill] element_size``) when given, else
    twice the coarsest span's outer ring element size (its thickness / ``per_thickness``). Each span's extrados size
    grows towards it (:func:`fill_element_sizes`), so that a fill over a thin span and a thick one is fine along the
    thin ring and coarse where it is far from both; one span: twice its outer ring's element size."""
    return element_size or 2 * max(ring_element_sizes(b, per_thickness)[-1] for b in ring.barrels)


@dataclass(frozen=True)
class TopPiece:
    """A piece of the bridge's top where a fill rests: the ``blocks`` (ids) whose top it is, its ``line`` (k, 2) m,
    left to right, and the fill's element ``size`` along it (m)."""

    blocks: tuple[int, ...]
    line: np.ndarray
    size: float


def top_pieces(ring: ArchRing, span_sizes: list[float]) -> list[TopPiece]:
    """The bridge's top, left to right: each span's outer extrados at its size of ``span_sizes`` (m,
    :func:`extrados_sizes`), and the top edge of each pier between two spans at the finer of theirs."""
    out = []
    for k, size in enumerate(span_sizes):
        voussoirs = [v for v in ring.outer_voussoirs if v.span == k]
        out.append(TopPiece(tuple(v.id for v in voussoirs), np.vstack([v.extrados for v in voussoirs]), size))
        for b in (b for b in ring.piers if b.pier == k and b.top is not None):
            out.append(TopPiece((b.id,), np.asarray(b.top, dtype=float), min(size, span_sizes[k + 1])))
    return out


def size_under(pieces: list[TopPiece], x: float) -> float:
    """The element size (m) of the top piece under horizontal position ``x`` (m; beyond the bridge's ends, the end
    piece's; on the boundary of two pieces, the finer)."""
    gaps = [max(p.line[:, 0].min() - x, x - p.line[:, 0].max(), 0.0) for p in pieces]
    least = min(gaps)
    return min(p.size for p, g in zip(pieces, gaps) if g <= least + 1e-12)


def fill_element_sizes(distances: np.ndarray, sizes: np.ndarray, far: float, depth: float) -> np.ndarray:
    """The fill's element size (m) at points, the size field the mesher gives Gmsh (:mod:`bridgefem.fe.mesh`):

    1. from each top piece (``sizes`` (m) along each; ``distances`` (pieces, points) m to each): its size within
       ``EXTRADOS_BAND`` x ``depth`` (the fill's depth over the crown, m) of it;
    2. beyond that band growing by ``FILL_GRADING`` per metre, up to ``far`` (:func:`fill_far_size`; at least the
       piece's own size);
    3. the least over the pieces."""
    s = np.asarray(sizes, dtype=float)[:, None]
    grown = s + FILL_GRADING * np.maximum(np.asarray(distances) - EXTRADOS_BAND * depth, 0.0)
    return np.minimum(grown, np.maximum(far, s)).min(axis=0)


FILL_SAMPLES = 40_000  # sample points of the fill's area for its cell count (:func:`fill_cell_count`)


def fill_cell_count(ring: ArchRing, outline: FillOutline, pieces: list[TopPiece], far: float, depth: float) -> float:
    """The fill's triangles (estimate): ``TRIANGLES_PER_AREA`` x the integral over the fill of 1 / size^2, the size
    of :func:`fill_element_sizes` (the mesher's field).

    1. The fill: x from ``outline.x_left`` to ``x_right``, y from the bridge's top (the ``pieces``' lines; beyond
       them the fill's base ``y_base``) to the road ``y_road`` (m).
    2. A grid of about ``FILL_SAMPLES`` cells over its bounding box, no coarser than a quarter of the extrados band
       (``EXTRADOS_BAND`` x ``depth``) while that keeps within 5 x ``FILL_SAMPLES``; each cell inside the fill counts
       its area / size^2 at its centre.
    3. Distances to each piece from its line sampled at a quarter of the grid step (Gmsh's distance field samples
       its curves too), one k-d tree per distinct size (pieces of equal size act as one)."""
    from scipy.spatial import cKDTree

    o = outline
    width, height = o.x_right - o.x_left, o.y_road - o.y_base
    step = math.sqrt(width * height / FILL_SAMPLES)
    step = max(min(step, EXTRADOS_BAND * depth / 4), math.sqrt(width * height / (5 * FILL_SAMPLES)))
    xs = np.arange(o.x_left + step / 2, o.x_right, step)
    ys = np.arange(o.y_base + step / 2, o.y_road, step)
    top = np.vstack([p.line for p in pieces])
    order = np.argsort(top[:, 0], kind="stable")
    floor = np.interp(xs, top[order, 0], top[order, 1], left=o.y_base, right=o.y_base)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    inside = gy > floor[:, None]
    points = np.column_stack([gx[inside], gy[inside]])
    if not len(points):
        return 0.0
    sizes = sorted({p.size for p in pieces})
    trees = [cKDTree(np.vstack([_densify(p.line, step / 4) for p in pieces if p.size == size])) for size in sizes]

    def field(at: np.ndarray) -> np.ndarray:
        return fill_element_sizes(np.array([tree.query(at)[0] for tree in trees]), np.array(sizes), far, depth)

    return TRIANGLES_PER_AREA * float(np.sum(step * step / field(points) ** 2))


def _densify(line: np.ndarray, spacing: float) -> np.ndarray:
    """Points along the polyline ``line`` (k, 2) m at most ``spacing`` (m) apart, its vertices included: each
    segment cut into n = ceil(length / spacing) equal parts (at least one), its points after its start in order."""
    line = np.asarray(line, float)
    seg = np.diff(line, axis=0)
    n = np.maximum(1, np.ceil(np.linalg.norm(seg, axis=1) / spacing)).astype(np.int64)
    of = np.repeat(np.arange(len(seg)), n)  # the segment of each new point
    k = np.arange(1, int(n.sum()) + 1) - np.repeat(np.cumsum(n) - n, n)  # its index within the segment, 1..n
    return np.vstack([line[:1], line[of] + (k / n[of])[:, None] * seg[of]])


@dataclass(frozen=True)
class SizeEstimate:
    """Cells, unknowns (displacements and joint forces) and peak memory (bytes) of a scene's model."""

    cells: int
    dofs: int
    memory: float

    def describe(self) -> str:
        return (f"about {self.cells:,} cells, {self.dofs:,} unknowns and {self.memory / 1e9:.1f} GB of memory "
                "(estimate)")


def ring_voussoirs(a: Arch) -> list[int]:
    """The voussoirs of each ring of arch ``a`` (one span's), inner first: the arch's, one more in every other ring of
    a staggered bond."""
    layers = a.ring_layers or (a.thickness,)
    return [a.voussoirs + (1 if len(layers) > 1 and a.ring_bond == "staggered" and (len(layers) - 1 - r) % 2 else 0)
            for r in range(len(layers))]


def most_graded_elements(scene: Scene) -> int:
    """The most elements through each ring joint that the grading for the stress block may use: as many as keep the
    pairs of all the rings' joints (n + 1 per ring of n voussoirs, every span's, ``degree`` x elements + 1 each) within
    ``GRADED_PAIRS``, and never fewer than ``elements_through_thickness`` (the even joints)."""
    joints = sum(n + 1 for a in scene.arches for n in ring_voussoirs(a))
    ett, degree = scene.mesh.elements_through_thickness, scene.mesh.degree
    return max(ett, int((GRADED_PAIRS / joints - 1) // degree))


def graded_elements(scene: Scene, joint_nodes: tuple[float, ...] | None = None) -> int:
    """The elements through each ring joint: those of ``joint_nodes`` (the graded element ends) when given; without
    them ``elements_through_thickness`` without a compressive strength, else the most the grading may give, its
    densest grading (:func:`bridgefem.structure.grading.densest_grading`) within :func:`most_graded_elements`."""
    ett = scene.mesh.elements_through_thickness
    if joint_nodes is not None:
        return len(joint_nodes) - 1
    if scene.masonry.compressive_strength is None:
        return ett
    return min(densest_grading(ett), most_graded_elements(scene))


def _barrel_size(a: Arch, scene: Scene, through: int) -> tuple[float, float, float, float]:
    """Cells, nodes and pairs of one span's barrel (arch ``a``; ``through`` elements through each ring joint) with
    the pairs of its extrados under a fill, and its smallest element size h (m): the first part of
    :func:`estimate_size`."""
    ett, degree = scene.mesh.elements_through_thickness, scene.mesh.degree
    shape = make_shape(a.shape, a.span, a.rise)
    p = np.linspace(0.0, 1.0, 257)

    def offset_length(offset: float) -> float:
        curve = shape.point(p) + offset * shape.normal(p)
        return float(np.linalg.norm(np.diff(curve, axis=0), axis=1).sum())

    layers = a.ring_layers or (a.thickness,)
    levels = np.concatenate([[0.0], np.cumsum(layers)])
    sizes = [t / ett for t in layers]
    extrados_length = offset_length(a.thickness)
    h_extrados = extrados_element_size(layers[-1], ett, scene.fill.depth if scene.fill is not None else None)
    cells = nodes = pairs = 0.0
    for r, (t, h_r, n) in enumerate(zip(layers, sizes, ring_voussoirs(a))):
        fill_along = (math.ceil(extrados_length / n / h_extrados) if h_extrados < h_r and r == len(layers) - 1
                      else 0)
        along = max(1, math.ceil(offset_length(levels[r] + t / 2) / n / h_r), fill_along)
        cells += 2 * n * through * along
        nodes += n * (degree * through + 1) * (degree * along + 1)
        pairs += (n + 1) * (degree * through + 1)
    for r in range(1, len(layers)):  # the ring interfaces
        pairs += degree * offset_length(levels[r]) / min(sizes[r - 1], sizes[r])
    if scene.fill is not None:  # the arch-fill interface: one pair per extrados element
        pairs += (extrados_length / h_extrados) * degree
    return cells, nodes, pairs, min(sizes)


def _fill_cells(scene: Scene, ring: ArchRing) -> float:
    """The fill's triangles (:func:`fill_cell_count`) on the scene's ``ring`` and fill outline, with the mesher's
    sizes."""
    f, ett = scene.fill, scene.mesh.elements_through_thickness
    outline = fill_outline(ring, f.depth, f.extension, scene.load_edges_x())
    pieces = top_pieces(ring, extrados_sizes(ring, ett, f.depth))
    return fill_cell_count(ring, outline, pieces, fill_far_size(ring, ett, f.element_size), f.depth)


def estimate_size(scene: Scene, joint_nodes: tuple[float, ...] | None = None,
                  ring: ArchRing | None = None) -> SizeEstimate:
    """The model's size from the scene alone (no mesh is built): per span, per ring (the ring's element size h its
    thickness / elements_through_thickness) its voussoirs' structured grids and its joints' pairs, as many elements
    through as the ring joints have (:func:`graded_elements` of ``joint_nodes``), each ring interface's pairs (one
    per h of the finer ring along it); the fill's triangles over the whole bridge with the mesher's size field
    (:func:`fill_cell_count`, on ``ring`` when given: the scene's, else built from the scene,
    :func:`bridgefem.structure.ring.scene_ring`); then the piers' courses and the abutments, each its area at the
    mesher's size (:func:`support_element_size`)."""
    degree = scene.mesh.degree
    through = graded_elements(scene, joint_nodes)
    parts = [_barrel_size(a, scene, through) for a in scene.arches]
    cells, nodes, pairs = (sum(part[k] for part in parts) for k in range(3))
    if ring is None and (scene.fill is not None or scene.piers or scene.abutments.elastic):
        from .ring import scene_ring

        ring = scene_ring(scene)
    if scene.fill is not None:
        fill_cells = _fill_cells(scene, ring)
        cells += fill_cells
        nodes += fill_cells * (0.5 if degree == 1 else 2.0)
    # the blocks that carry spans, with the mesher's sizes
    supports = [(block, support_element_size(ring, block, scene.mesh.elements_through_thickness))
                for block in (ring.piers + ring.abutments if ring is not None else [])]
    block_cells = sum(TRIANGLES_PER_AREA * block.area / size ** 2 for block, size in supports)
    for k, p in enumerate(scene.piers):  # its bed joints, base and top at its finest course's size
        pairs += (p.blocks + 2) * (degree * p.width / min(size for b, size in supports
                                                           if isinstance(b, PierBlock) and b.pier == k) + 1)
    cells += block_cells
    nodes += block_cells * (0.5 if degree == 1 else 2.0)
    dofs = int(2 * nodes + 2 * pairs)
    base = FILL_MEMORY_BASE if scene.fill is not None else MEMORY_BASE
    memory = base + MEMORY_PER_DOF[degree] * dofs * math.log2(max(dofs, 2))
    return SizeEstimate(int(cells), dofs, memory)


def machine_memory() -> float:
    """Physical memory of this machine (bytes)."""
    return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def check_size(scene: Scene, memory: float | None = None, max_dofs: float = MAX_DOFS) -> SizeEstimate:
    """The scene's size estimate; SceneError, naming the numbers and the keys that set them, when its memory
    exceeds 80 % of ``memory`` (default: this machine's) or its unknowns ``max_dofs``."""
    size = estimate_size(scene)
    memory = machine_memory() if memory is None else memory
    keys, advice = _size_keys(scene)
    if size.memory > 0.8 * memory:
        raise SceneError(f"{keys}: {size.describe()}, more than the allowed 80 % of this "
                         f"machine's {memory / 1e9:.1f} GB; use {advice}")
    if size.dofs > max_dofs:
        raise SceneError(f"{keys}: {size.describe()}, more than the {max_dofs:,.0f} unknowns allowed "
                         f"(hours per limit search); use {advice}, or --no-size-limit")
    return size


def _size_keys(scene: Scene) -> tuple[str, str]:
    """The keys that set the model's size, with their values, and what to change: the ring's mesh, and the fill's
    or the abutments' when the scene has them (a fine fill mesh can outgrow the ring's)."""
    a, m, f, ab = scene.arch, scene.mesh, scene.fill, scene.abutments
    keys = [f"[arch] voussoirs = {a.voussoirs}, [mesh] elements_through_thickness = {m.elements_through_thickness}, "
            f"degree = {m.degree}"]
    advice = "fewer voussoirs or elements"
    if f is not None:
        keys.append(f"[fill] element_size = {f.element_size:g}, depth = {f.depth:g}, extension = {f.extension:g}")
        advice += ", a coarser fill mesh or a smaller fill"
    if ab.elastic:
        keys.append(f"[abutments] height = {ab.height:g}, length = {ab.length:g}")
        advice += ", smaller abutments"
    return "; ".join(keys), advice
