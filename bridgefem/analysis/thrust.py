"""The line of thrust of a converged state: where the resultant of each joint's contact forces crosses the joint.

Method (for every joint of the ring that carries a force, springings and abutment joints included):

1. the joint's resultant is its normal force ``N`` (N, compression positive) and shear ``V`` (N) from the contact
   forces of its node pairs; its point of application lies on the joint at the eccentricity ``e`` (m) from the
   joint's centre, ``e = sum(lambda_n,i (s_i - t/2)) / N`` (s_i: a pair's distance from the intrados, t: the joint's
   length), positive towards the extrados (:func:`bridgefem.analysis.runner.joint_states`);
2. the crossing point is ``c + e T`` (c: the joint's centre, T: its unit tangent from the intrados to the extrados);
3. ``e / (t/2)`` is the thrust's place in the joint (-1 on the intrados, +1 on the extrados); the line *touches* a
   face where ``|e| >= TOUCH x t/2`` (the joint's hinge, the contact force at its edge);
4. the line of thrust is the polyline through the crossing points in joint order (the classical drawing:
   Heyman 1982, The Masonry Arch, ch. 3; between two joints the true line bends under each voussoir's weight and
   loads, which the polyline does not show). A joint without compression (``N <= 0``, fully open) has no crossing.

Lengths in m, forces in N, for the scene's width.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

TOUCH = 0.98  # |e| / (t/2) from which the thrust touches a face: the FE's hinge reading (HINGE_ECCENTRICITY 0.49 t)


@dataclass(frozen=True)
class ThrustPoint:
    """Where the thrust crosses joint ``joint``: ``x``, ``y`` (m), ``eccentricity`` (m, from the centre, positive
    towards the extrados), ``relative`` = e / (t/2) (-1 intrados, +1 extrados), ``touches`` ("intrados",
    "extrados" or ""), ``normal_force`` and ``shear_force`` (N)."""

    joint: int
    x: float
    y: float
    eccentricity: float
    relative: float
    touches: str
    normal_force: float
    shear_force: float


def line_of_thrust(joints, ring) -> list[ThrustPoint]:
    """The crossing points of the thrust at every joint of ``joints`` (JointState rows of one converged state:
    ``id``, ``normal_force``, ``shear_force``, ``eccentricity``) on ``ring`` (its geometry), in joint order; joints
    without compression are left out."""
    out = []
    for js in sorted(joints or [], key=lambda j: j.id):
        if not js.normal_force > 0:
            continue
        jt = ring.joints[js.id]
        half = jt.length / 2
        point = 0.5 * (jt.intrados + jt.extrados) + js.eccentricity * jt.tangent
        rel = js.eccentricity / half
        touches = "" if abs(rel) < TOUCH else ("extrados" if rel > 0 else "intrados")
        out.append(ThrustPoint(int(js.id), float(point[0]), float(point[1]), float(js.eccentricity), float(rel),
                               touches, float(js.normal_force), float(js.shear_force)))
    return out


def thrust_summary(points: list[ThrustPoint]) -> dict:
    """The ``line_of_thrust`` entry of results.json: the points and the joints where the line touches each face."""
    return {"points": [asdict(p) for p in points],
            "touches_intrados": [p.joint for p in points if p.touches == "intrados"],
            "touches_extrados": [p.joint for p in points if p.touches == "extrados"],
            "touch": TOUCH,
            "method": "the resultant of each joint's contact forces at the last converged state, crossing the joint "
                      "at its eccentricity; touches a face where |e| >= touch x t/2"}
