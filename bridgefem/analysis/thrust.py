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

A barrel of several rings has one line of thrust through its whole depth (:func:`_section_point`): at each joint of
the outer ring, the resultant of the forces that everything left of a section through the barrel exerts on
everything right of it, where it crosses that joint's line extended to the intrados:

5. the section (in one span's barrel): the outer-ring joint and, in each inner ring, that ring's joint whose centre is
   nearest to the outer joint's; left of it lie those rings' voussoirs left of their section joints and, for a
   joint on the barrel's support (the ground, an abutment or a pier) left of the span's midspan, the support;
6. the joints that cross it (one block left of the section, the other right: the section's joints and the ring
   interfaces between them) add their resultants ``N n + V t`` (n, t: their chord's normal and tangent), each at
   ``c + e T``, into the force ``S`` and moment ``M`` (about the origin) of the left side on the right;
7. the crossing point is where the line of action of ``S`` meets the outer joint's line ``E - s u`` (E its extrados
   end, u its unit tangent, s from 0 to the barrel's thickness t): ``e = s - t/2`` is its eccentricity in the
   barrel's depth, ``S . n`` and ``S . u`` its normal and shear force.

The abutments' bases and the piers' bed joints keep steps 1-4. A bridge of several spans has a line per span and one
per pier (down its bed joints). Lengths in m, forces in N, for the scene's width.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

TOUCH = 0.98  # |e| / (t/2) from which the thrust touches a face: the FE's hinge reading (HINGE_ECCENTRICITY 0.49 t)


@dataclass(frozen=True)
class ThrustPoint:
    """Where the thrust crosses joint ``joint``: ``x``, ``y`` (m), ``eccentricity`` (m, from the centre, positive
    towards the extrados), ``relative`` = e / (t/2) (-1 intrados, +1 extrados), ``touches`` ("intrados",
    "extrados" or ""), ``normal_force`` and ``shear_force`` (N), ``line`` the polyline it is drawn on (a span's, or a
    pier's: :func:`_line`)."""

    joint: int
    x: float
    y: float
    eccentricity: float
    relative: float
    touches: str
    normal_force: float
    shear_force: float
    line: int = 0


def line_of_thrust(joints, ring) -> list[ThrustPoint]:
    """The crossing points of the thrust on ``ring`` (its geometry) for ``joints`` (JointState rows of one converged
    state: ``id``, ``normal_force``, ``shear_force``, ``eccentricity``), in joint order: for each span, at every joint
    of a single ring (steps 1-4) or at every outer-ring joint's section of a barrel of several rings (steps 5-7); at
    every abutment base and pier bed joint (steps 1-4); crossings without compression are left out. Each point's
    ``line`` says which polyline it is drawn on (:func:`_line`)."""
    by_id = {js.id: js for js in joints or []}
    out = []
    for barrel in ring.barrels:
        if barrel.n_rings == 1:
            out += [_crossing(jt, by_id[jt.id], ring) for jt in barrel.ring_joints if jt.id in by_id]
        else:
            outer = {v.id for v in barrel.voussoirs if v.ring == barrel.n_rings - 1}
            out += [_section_point(barrel, jt, by_id, _line(jt, ring)) for jt in barrel.ring_joints
                    if {jt.left, jt.right} & outer]
    out += [_crossing(jt, by_id[jt.id], ring) for jt in ring.joints if jt.kind in ("base", "pier") and jt.id in by_id]
    return sorted((p for p in out if p.normal_force > 0), key=lambda p: p.joint)


def _line(joint, ring) -> int:
    """The polyline a crossing at ``joint`` is drawn on: span k's (k; an abutment's base on its end span's), or pier
    k's (the number of spans + k: its bed joints, from the top down)."""
    if joint.kind == "pier":
        return len(ring.barrels) + next(b.pier for b in ring.piers if b.id == joint.left)
    if joint.span is not None:
        return joint.span
    return 0 if joint.id == ring.bases[0].id else len(ring.barrels) - 1


def _crossing(jt, js, ring) -> ThrustPoint:
    """Steps 1-4 at joint ``jt`` (geometry) with state ``js``."""
    return _point(jt.id, jt.centre, jt.tangent, jt.length, js.eccentricity, js.normal_force, js.shear_force,
                  _line(jt, ring))


def _point(joint: int, centre: np.ndarray, tangent: np.ndarray, depth: float, e: float, normal: float,
           shear: float, line: int) -> ThrustPoint:
    """The crossing at eccentricity ``e`` (m) from ``centre`` along ``tangent`` of a section ``depth`` (m) deep."""
    point = centre + e * tangent
    rel = e / (depth / 2)
    touches = "" if abs(rel) < TOUCH else ("extrados" if rel > 0 else "intrados")
    return ThrustPoint(int(joint), float(point[0]), float(point[1]), float(e), float(rel), touches, float(normal),
                       float(shear), line)


def _section_point(barrel, outer_joint, by_id: dict, line: int) -> ThrustPoint:
    """The thrust of one span's ``barrel`` at the section through ``outer_joint`` (steps 5-7 of the module
    docstring); a section whose force has no compression across the joint gets normal force <= 0 (left out by the
    caller)."""
    own = {v.id for v in barrel.voussoirs}
    xs = np.concatenate([v.intrados[:, 0] for v in barrel.voussoirs])
    middle = 0.5 * (xs.min() + xs.max())
    body = set()
    for r in range(barrel.n_rings):
        ids = {v.id for v in barrel.voussoirs if v.ring == r}
        joints = [j for j in barrel.ring_joints if {j.left, j.right} & ids]
        cut = min(joints, key=lambda j: float(np.linalg.norm(j.centre - outer_joint.centre)))
        body |= {v for v in ids if v < cut.right} if cut.right in ids else ids

    def left_of(block, jt) -> bool:
        """A voussoir of the barrel: left of the section when in ``body``; its support (the ground, an abutment, a
        pier) is left where the joint is left of midspan."""
        return block in body if block in own else bool(jt.centre[0] < middle)

    force, moment = np.zeros(2), 0.0
    for jt in barrel.joints:
        js = by_id.get(jt.id)
        if js is None or left_of(jt.left, jt) == left_of(jt.right, jt):
            continue
        sign = 1.0 if left_of(jt.left, jt) else -1.0
        f = sign * (js.normal_force * jt.normal + js.shear_force * jt.tangent)
        p = jt.centre + js.eccentricity * jt.tangent
        force += f
        moment += p[0] * f[1] - p[1] * f[0]
    u, t = outer_joint.tangent, barrel.thickness
    start = outer_joint.extrados - t * u  # the section's intrados end
    across = u[0] * force[1] - u[1] * force[0]
    s = (moment - (start[0] * force[1] - start[1] * force[0])) / across if across else t / 2
    normal = np.array([u[1], -u[0]])
    return _point(outer_joint.id, start + 0.5 * t * u, u, t, s - t / 2, float(force @ normal), float(force @ u), line)


def thrust_summary(points: list[ThrustPoint]) -> dict:
    """The ``line_of_thrust`` entry of results.json: the points and the joints where the line touches each face."""
    return {"points": [asdict(p) for p in points],
            "touches_intrados": [p.joint for p in points if p.touches == "intrados"],
            "touches_extrados": [p.joint for p in points if p.touches == "extrados"],
            "touch": TOUCH,
            "method": "the resultant of each joint's contact forces at the last converged state, crossing the joint "
                      "at its eccentricity; touches a face where |e| >= touch x t/2; a barrel of several rings: at each "
                      "outer-ring joint the resultant across a section through every ring (that joint, each inner "
                      "ring's nearest joint and the ring interfaces between them), where it crosses the joint's line "
                      "through the barrel's depth t"}
