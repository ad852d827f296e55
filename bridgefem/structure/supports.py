"""A scene's supports: the joints that bear on the ground and the imposed movement of the ground under the moving
springing(s). (The ring with its elastic abutments is built by :func:`bridgefem.structure.ring.scene_ring`.)

The ground is rigid. Under rigid abutments (the default) the springing joints bear on it directly; under
elastic abutments their base joints do. A support movement displaces the ground under the springing joint, or
under the abutment's base, by ``(-h, v)`` on the left and ``(+h, v)`` on the right (m; h = movement_horizontal,
positive = spreading away from the span; v = movement_vertical, positive = up).
"""
from __future__ import annotations

import numpy as np

from ..geometry.ring import ArchRing
from ..scene.model import Scene


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
