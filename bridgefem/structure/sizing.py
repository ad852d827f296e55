"""The size of a scene's model, estimated from the scene alone before anything is built: cells, unknowns and the
memory of the direct solver, so that a run far beyond the machine is refused with the numbers instead of
swapping for minutes, and a long one is announced.

Cells follow the mesher's rules (:mod:`bridgefem.fe.mesh`): element size h = thickness / elements_through_thickness
in each ring, each voussoir a structured grid of ``elements_through_thickness`` x ceil(length / h) quadrilaterals
cut into two triangles (more along under a thin fill: one per extrados element size); the fill and the abutments
unstructured at their own size, the fill at the extrados element size in a band along the extrados. With a
compressive strength the ring joints are graded for the stress block before meshing
(:mod:`bridgefem.analysis.stress_block`), each voussoir's grid then as many elements through as its joints: the
estimate counts the graded joints when they are given, else the most the grading may give
(:func:`graded_elements`), so that it never falls short of the model it guards. The memory
is a fit ``MEMORY_BASE + MEMORY_PER_DOF x n log2 n`` (bytes, n unknowns) of the peak resident size of serial runs
(MUMPS LU with nested dissection: the factor of a 2D mesh grows as n log n), measured on serial runs of the
bare arch from 1k to 68k unknowns (117 to 127 bytes per n log2 n). The estimate comes within 1 % of the mesher's
cells and unknowns on a bare arch and within 30 % with a fill, whose unstructured mesh it can only approximate:
close enough to refuse a model beyond the machine, not to predict its exact size.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..geometry.shapes import make_shape
from ..scene.keys import SceneError
from ..scene.model import Arch, Scene
from .grading import densest_grading

MEMORY_BASE = 190e6  # bytes: Python, DOLFINx, PETSc and MUMPS loaded, before the model (measured)
MEMORY_PER_DOF = 120.0  # bytes per n log2 n unknowns: matrix, factor and work space (fit, see the docstring)
LARGE_DOFS = 200_000  # unknowns above which a run is announced with its estimate and set-up phases
MAX_DOFS = 1_000_000  # unknowns above which a run is refused (unless asked for): a limit search factorises the
# matrix 50-100 times, which at this size takes hours on a workstation
FILL_DEPTH_SHARE = 1.0  # extrados element size x elements through the ring / fill depth over the crown
EXTRADOS_BAND = 1.0  # width of the band along the extrados kept at that size / the fill's depth over the crown
TRIANGLES_PER_AREA = 4.2  # unstructured triangles per h^2 of fill area (Gmsh, measured on two fills)
GRADED_PAIRS = 3000  # joint pairs that graded ring joints may have in all: a limit search's active-set iterations
# grow faster than the pairs that crush one after another, and beyond a few thousand graded pairs a search takes
# minutes (docs/robustness.md); ring joints of even elements keep theirs whatever their number


def extrados_element_size(thickness: float, per_thickness: int, depth: float | None) -> float:
    """Element size (m) along the extrados: the ring's, ``thickness`` / ``per_thickness``; under a fill ``depth`` (m)
    deep over the crown at most ``FILL_DEPTH_SHARE`` x ``depth`` / ``per_thickness``, so that a thin fill over a
    thick ring has elements through its depth and the size still halves with each doubling of ``per_thickness``."""
    return min(thickness, FILL_DEPTH_SHARE * depth if depth is not None else thickness) / per_thickness


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
    """Cells, nodes and pairs of one span's barrel (arch ``a``; ``through`` elements through each ring joint), and
    its smallest element size h (m): the first part of :func:`estimate_size`."""
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
    if scene.fill is not None:
        f = scene.fill
        hf = f.element_size or 2 * sizes[-1]  # the outer ring's (mesh.py)
        box = (a.span + 2 * a.thickness + 2 * f.extension) * (a.rise + a.thickness + f.depth)
        area = max(box - math.pi / 4 * (a.span + 2 * a.thickness) * (a.rise + a.thickness), 0.2 * box)
        band = min(extrados_length * EXTRADOS_BAND * f.depth, area)  # kept at h_extrados (mesh.py)
        fill_cells = TRIANGLES_PER_AREA * (band / min(h_extrados, hf) ** 2 + (area - band) / hf ** 2)
        cells += fill_cells
        nodes += fill_cells * (0.5 if degree == 1 else 2.0)
        pairs += (extrados_length / min(h_extrados, hf)) * degree
    return cells, nodes, pairs, min(sizes)


def estimate_size(scene: Scene, joint_nodes: tuple[float, ...] | None = None) -> SizeEstimate:
    """The model's size from the scene alone (no mesh is built): per span, per ring (the ring's element size h its
    thickness / elements_through_thickness) its voussoirs' structured grids and its joints' pairs, as many elements
    through as the ring joints have (:func:`graded_elements` of ``joint_nodes``), each ring interface's pairs (one
    per h of the finer ring along it), the fill; then the piers and the abutments (unstructured at 2 h)."""
    degree = scene.mesh.degree
    through = graded_elements(scene, joint_nodes)
    parts = [_barrel_size(a, scene, through) for a in scene.arches]
    cells, nodes, pairs = (sum(part[k] for part in parts) for k in range(3))
    h = min(part[3] for part in parts)
    support_area = sum(p.height * (p.width + p.batter * p.height) for p in scene.piers)
    if scene.abutments.elastic:
        support_area += 2 * scene.abutments.height * scene.abutments.length
    block_cells = TRIANGLES_PER_AREA * support_area / (2 * h) ** 2
    cells += block_cells
    nodes += block_cells * (0.5 if degree == 1 else 2.0)
    pairs += sum((p.blocks + 2) * (degree * p.width / (2 * h) + 1) for p in scene.piers)
    dofs = int(2 * nodes + 2 * pairs)
    memory = MEMORY_BASE + MEMORY_PER_DOF * dofs * math.log2(max(dofs, 2))
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
