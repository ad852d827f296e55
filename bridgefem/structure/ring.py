"""TODO docstring"""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..scene.schema import Scene
from ..geometry.ring import ArchRing, add_abutments, build_ring


def scene_ring(scene: Scene, thickness: float | None = None) -> ArchRing:
    """The joints and blocks of a scene (one source for the FE model and the LP); ``thickness`` (m) overrides the
    ring's. Raises SceneError when the loads are too close together (for each other or the number of voussoirs)."""
    from ..scene.schema import SceneError

    a, ab = scene.arch, scene.abutments
    try:
        ring = build_ring(a.shape, a.span, a.rise, a.thickness if thickness is None else thickness, a.voussoirs,
                          scene.load_edges_x(), a.joint_at_loads)
    except ValueError as err:
        raise SceneError(f"[[load]] positions: {err}") from None
    return add_abutments(ring, ab.height, ab.length) if ab.elastic else ring
