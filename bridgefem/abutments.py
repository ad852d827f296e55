"""A scene's supports: the ring's geometry with its elastic abutments (when the scene has them) and the imposed
movement of the ground under the moving springing(s).

The ground is rigid. Under rigid abutments (the default) the springing joints bear on it directly; under
elastic abutments their base joints do. A support movement displaces the ground under the springing joint, or
under the abutment's base, by ``(-h, v)`` on the left and ``(+h, v)`` on the right (m; h = movement_horizontal,
positive = spreading away from the span; v = movement_vertical, positive = up).
"""
from __future__ import annotations

import numpy as np

from .geometry import ArchRing, add_abutments, build_ring
from .scene import Scene


def scene_ring(scene: Scene, thickness: float | None = None) -> ArchRing:
    """The joints and blocks of a scene (one source for the FE model and the LP); ``thickness`` (m) overrides the
    ring's. Raises ValueError when the loads are too close together for the number of voussoirs."""
    a, ab = scene.arch, scene.abutments
    ring = build_ring(a.shape, a.span, a.rise, a.thickness if thickness is None else thickness, a.voussoirs,
                      scene.load_edges_x(), a.joint_at_loads)
    return add_abutments(ring, ab.height, ab.length) if ab.elastic else ring


def ground_joints(ring: ArchRing) -> dict[int, str]:
    """The joints that bear on the ground (springings or abutment bases): joint id -> "left" / "right" support."""
    return {j.id: ("left" if j.centre[0] < 0 else "right") for j in ring.joints
            if (j.left is None or j.right is None) and not j.free}


def support_motion(scene: Scene, ring: ArchRing) -> dict[int, np.ndarray]:
    """Ground displacement (m; x, y) under each joint on a moving support, for the full movement (empty: none)."""
    ab = scene.abutments
    if not ab.moves:
        return {}
    moving = ("left", "right") if ab.movement_springing == "both" else (ab.movement_springing,)
    outward = {"left": -1.0, "right": 1.0}
    return {j: np.array([outward[side] * ab.movement_horizontal, ab.movement_vertical])
            for j, side in ground_joints(ring).items() if side in moving}
