"""The ring joints' element ends with a compressive strength: fine enough at the joints' edges that the FE's pairs
resolve the rectangular stress block of the hinges at collapse.

A joint's pairs crush one after another from its edge, a polygon around the stress block's parabola
(:mod:`bridgefem.laws.crushing`). Where the compressed zone N / (f_c w) at a hinge is thinner than the element next to
the edge, the edge pair alone carries N at the very edge: the joint's moment, and so the limit load, is that of the
infinitely strong joint. Even elements fine enough for that zone everywhere cost many times the run, so the joints
are graded towards both edges, from the zones the rigid-block LP predicts, before meshing (:func:`joint_nodes`):

1. The rigid-block LP on the stress block (:func:`bridgefem.limit.collapse.collapse_load`, 128 tangents): its level,
   and the thinnest and the deepest compressed zones among its hinges, n / (f_c w t) as fractions of the joint's
   depth t.
2. The LP on the FE's own stations of even elements (``elements_through_thickness``): within ``TARGET`` of step 1's
   level, the joints stay even (the mesh of a run without grading).
3. Otherwise, for each moment tolerance of ``GRADING_TOLERANCES`` in turn, the joints graded to it and those zones
   (:func:`bridgefem.structure.grading.graded_nodes`) and the LP on their stations: the first within ``TARGET`` of step
   1's level is taken; when none is, the last (finest), and the run's check of its stress block warns
   (:func:`bridgefem.analysis.refinement.coarse_stress_block`).
4. A grading with more elements than the size budget allows (:func:`bridgefem.structure.sizing.most_graded_elements`:
   the pairs of all the ring joints within ``GRADED_PAIRS``) is replaced by the finest one within it
   (:func:`bridgefem.structure.grading.graded_within`), and no finer tolerance is tried: many joints get fewer elements
   each, and where those resolve the stress block less well than ``TARGET`` the run's check warns as in step 3.

The LPs are solved on rank 0 and the nodes broadcast; an LP that fails leaves the joints even (the run's own LP check
reports it).
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI

from ..laws.crushing import scene_law
from ..limit.collapse import collapse_load
from ..scene.model import Scene
from ..status import Status
from ..structure.grading import GRADING_TOLERANCES, graded_nodes, graded_within
from ..structure.ring import scene_ring
from ..structure.sizing import most_graded_elements
from .evidence import AGREEMENT

TARGET = AGREEMENT / 2  # the LP on the FE's stations at most this fraction above the LP on the stress block


def joint_nodes(scene: Scene, comm: MPI.Comm) -> tuple[float, ...] | None:
    """The ring joints' element ends (fractions of the depth from the intrados, 0 to 1) for the FE of ``scene``
    (module docstring); None: ``elements_through_thickness`` even elements (always so without a compressive
    strength). Collective."""
    if scene.masonry.compressive_strength is None:
        return None
    return comm.bcast(_graded(scene) if comm.rank == 0 else None, root=0)


def _graded(scene: Scene) -> tuple[float, ...] | None:
    """The module docstring's steps 1-4 on rank 0."""
    def level(nodes: tuple[float, ...] | None) -> float:
        own = collapse_load(scene, law=scene_law(scene, fe=True, nodes=nodes))
        return own.level if own.status == Status.LIMIT and own.level is not None else np.inf

    try:
        block = collapse_load(scene)
        if block.status != Status.LIMIT or block.level is None or not block.hinges:
            return None
        target = (1 + TARGET) * block.level
        if level(None) <= target:
            return None
        ring = scene_ring(scene)
        depth = np.array([ring.joints[j].length for j in block.hinges])
        strength = scene.masonry.compressive_strength * scene.arch.width
        zone = np.maximum(block.joint_forces["n"][block.hinges] / (strength * depth), 0.0)
        ett, most, zones = scene.mesh.elements_through_thickness, most_graded_elements(scene), (zone.min(), zone.max())
        nodes = None
        for tolerance in GRADING_TOLERANCES:
            nodes = graded_nodes(ett, tolerance, zones)
            if len(nodes) - 1 > most:  # step 4
                return graded_within(ett, tolerance, zones, most)
            if level(nodes) <= target:
                break
        return nodes
    except (RuntimeError, ValueError):
        return None
