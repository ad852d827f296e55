"""A scene's ring: the blocks and joints its keys describe, built in one place for every model.

:func:`scene_ring` reads ``[arch]`` (shape, span, rise, thickness, voussoirs, joint_at_loads), the horizontal
positions of the point loads and patch edges (:meth:`bridgefem.scene.schema.Scene.load_edges_x`) and
``[abutments]``, and

1. builds the ring of voussoirs and joints (:func:`bridgefem.geometry.ring.build_ring`), with a joint moved under
   each load when ``joint_at_loads`` asks for it;
2. with elastic abutments, adds the two abutment blocks and their base joints on the ground
   (:func:`bridgefem.geometry.ring.add_abutments`).

The FE model (:mod:`bridgefem.fe.mesh` meshes this ring), the rigid-block LP (:mod:`bridgefem.limit.ring_blocks`)
and the conic bounds (:mod:`bridgefem.limit.bounds_model`) all take their ring from here, so that the LP checks the
FE on the same joints. Lengths in m; coordinates, numbering and the joints' left/right blocks as in
:mod:`bridgefem.geometry.ring`: voussoirs 0 .. N - 1 and joints 0 (left springing) .. N (right springing); the
abutments are blocks N (left) and N + 1 (right) with base joints N + 1 and N + 2. A load layout the geometry cannot
honour (loads too close together for the number of voussoirs) raises :class:`~bridgefem.scene.schema.SceneError`
naming ``[[load]]``, as any other bad value of a scene.
"""
from __future__ import annotations

from ..geometry.ring import ArchRing, add_abutments, build_ring
from ..scene.schema import Scene, SceneError


def scene_ring(scene: Scene, thickness: float | None = None) -> ArchRing:
    """The joints and blocks of a scene (one source for the FE model and the LP); ``thickness`` (m) overrides the
    ring's. Raises SceneError when the loads are too close together (for each other or the number of voussoirs)."""
    a, ab = scene.arch, scene.abutments
    try:
        ring = build_ring(a.shape, a.span, a.rise, a.thickness if thickness is None else thickness, a.voussoirs,
                          scene.load_edges_x(), a.joint_at_loads)
    except ValueError as err:
        raise SceneError(f"[[load]] positions: {err}") from None
    return add_abutments(ring, ab.height, ab.length) if ab.elastic else ring
