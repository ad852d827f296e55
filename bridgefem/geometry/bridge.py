"""A bridge of several spans on masonry piers: the spans' barrels placed side by side in one frame, the piers
between them as stacked courses (pure numpy; a scene's bridge is built by
:func:`bridgefem.structure.ring.scene_ring`).

Frame: as in :mod:`bridgefem.geometry.ring`, metres, x to the right and y up, the origin at the midpoint of the
first span's springing line on the intrados. Every springing is at y = 0; pier k stands between spans k and k + 1,
``width`` (m) apart at springing level (the clear distance between the two spans' intrados corners), and goes down
``height`` (m) to its foundation, its faces leaning outwards by ``batter`` (m horizontally per m down, each face).

:func:`build_bridge`, given each span's barrel in its own frame (:func:`bridgefem.geometry.ring.build_ring`):

1. moves each barrel to its midspan's x in the bridge's frame (given: span k + 1's left springing ``width`` of pier k
   to the right of span k's right one, :func:`bridgefem.scene.model.span_ranges`);
2. numbers the blocks and joints of the bridge: the voussoirs of span 0, then span 1, ... (each span's in its own
   order), then the piers' courses (pier 0 from its top course down, then pier 1, ...); the joints of span 0, then
   span 1, ..., then each pier's bed joints from the top down, its foundation last;
3. builds each pier: ``courses`` blocks between horizontal bed joints evenly spaced from springing level to the
   foundation (kind "pier"; a joint's left block the course above it, its right block the course below, or the
   ground under the foundation, so that its normal points down); the top course's upper outline runs up the right
   span's left springing joints (every ring's, from the intrados out), straight across to the left span's right
   springing joints' extrados corner (through a vertex under each load over the pier), down them to springing
   level: the two spans' springings now bear on it.

A pier too narrow for its spans' springings (their extrados corners meet or cross above it) raises ValueError
naming the pier, its width and the least width allowed.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .ring import ArchRing, Joint, PierBlock, Voussoir, polygon_area_centroid


@dataclass(frozen=True)
class PierShape:
    """A pier's outline: ``width`` (m) between the spans' intrados corners at springing level, ``height`` (m) from
    springing level down to its foundation, ``batter`` (m/m) each face's outward lean per metre down, ``courses``
    the blocks it is built of (bed joints between them, where it can rock or slide)."""

    width: float
    height: float
    batter: float = 0.0
    courses: int = 1

    def face_x(self, left: float, y: float) -> tuple[float, float]:
        """The x (m) of the pier's left and right faces at height y (m, <= 0), its left face at ``left`` at y = 0."""
        return left + self.batter * y, left + self.width - self.batter * y


def _moved(barrel: ArchRing, dx: float, first_block: int, first_joint: int, span: int) -> ArchRing:
    """``barrel`` moved ``dx`` (m) to the right, its blocks numbered from ``first_block`` and its joints from
    ``first_joint``, every voussoir and joint marked as span ``span``."""
    d = np.array([dx, 0.0])

    def block(b: int | None) -> int | None:
        return None if b is None else b + first_block

    voussoirs = [dataclasses.replace(v, id=v.id + first_block, intrados=v.intrados + d, extrados=v.extrados + d,
                                     span=span) for v in barrel.voussoirs]
    joints = [dataclasses.replace(j, id=j.id + first_joint, intrados=j.intrados + d, extrados=j.extrados + d,
                                  left=block(j.left), right=block(j.right), span=span,
                                  curve=None if j.curve is None else j.curve + d) for j in barrel.joints]
    return dataclasses.replace(barrel, joints=joints, voussoirs=voussoirs,
                               joints_at_x=frozenset(x + dx for x in barrel.joints_at_x))


def build_bridge(barrels: list[ArchRing], piers: list[PierShape], centres: list[float],
                 top_x: list[float] = ()) -> ArchRing:
    """The bridge of ``barrels`` (each span's, in its own frame, left to right) on ``piers`` (one fewer): steps 1-3
    of the module docstring, each barrel moved to its midspan's x in ``centres`` (m, bridge frame: the spans side by
    side, each pier's width apart, :func:`bridgefem.scene.model.span_ranges`); ``top_x``: the horizontal positions
    (m, bridge frame) of the loads and patch edges over the piers' tops, each a vertex of its pier's top edge (a mesh
    node). Raises ValueError for a pier its spans' springings do not fit on."""
    if len(piers) != len(barrels) - 1 or len(centres) != len(barrels):
        raise ValueError(f"{len(barrels)} spans need {len(barrels) - 1} piers and {len(barrels)} centres")
    moved, n_blocks, n_joints = [], 0, 0
    for k, (barrel, x) in enumerate(zip(barrels, centres)):
        moved.append(_moved(barrel, x, n_blocks, n_joints, k))
        n_blocks += len(barrel.voussoirs)
        n_joints += len(barrel.joints)
    joints: list[Joint] = [j for b in moved for j in b.joints]
    voussoirs: list[Voussoir] = [v for b in moved for v in b.voussoirs]
    courses: list[PierBlock] = []
    for k, pier in enumerate(piers):
        left_span, right_span = moved[k], moved[k + 1]
        on_left, on_right = left_span.springings("right"), right_span.springings("left")
        xa = float(on_left[0].intrados[0])
        top_left, top_right = on_left[-1].extrados, on_right[-1].extrados
        if top_left[0] >= top_right[0]:
            least = pier.width + top_left[0] - top_right[0]
            raise ValueError(f"[[pier]] #{k + 1} width = {pier.width:g} m: the springings of spans {k + 1} and "
                             f"{k + 2} meet above it; allowed is a width > {least:.6g} m")
        levels = -pier.height * np.arange(pier.courses + 1) / pier.courses
        first = n_blocks + len(courses)
        xs = sorted(x for x in set(top_x) if top_left[0] < x < top_right[0])
        top = np.array([top_left] + [top_left + (x - top_left[0]) / (top_right[0] - top_left[0])
                                     * (top_right - top_left) for x in xs] + [top_right])
        for c in range(pier.courses):
            below, above = levels[c + 1], levels[c]
            lo = pier.face_x(xa, below)
            if c == 0:
                upper = ([on_right[0].intrados] + [j.extrados for j in on_right[:-1]] + list(top[::-1])
                         + [j.extrados for j in on_left[-2::-1]] + [on_left[0].intrados])
            else:
                hi = pier.face_x(xa, above)
                upper = [np.array([hi[1], above]), np.array([hi[0], above])]
            polygon = np.array([[lo[0], below], [lo[1], below], *upper])
            if polygon_area_centroid(polygon)[0] < 0:
                polygon = polygon[::-1]
            courses.append(PierBlock(first + c, polygon, k, c, top if c == 0 else None))
        for j in on_left + on_right:
            joints[j.id] = dataclasses.replace(joints[j.id], left=first if j.left is None else j.left,
                                               right=first if j.right is None else j.right)
        for c in range(1, pier.courses + 1):
            a, b = pier.face_x(xa, levels[c])
            joints.append(Joint(len(joints), np.array([a, levels[c]]), np.array([b, levels[c]]), first + c - 1,
                                first + c if c < pier.courses else None, kind="pier", span=None))
    spans = tuple(dataclasses.replace(b, joints=[joints[j.id] for j in b.joints]) for b in moved)
    first = barrels[0]
    return ArchRing(first.shape, first.span, first.rise, first.thickness, first.params, joints, voussoirs,
                    joints_at_x=frozenset().union(*(b.joints_at_x for b in moved)),
                    ring_thicknesses=first.ring_thicknesses, piers=courses, spans=spans)
