"""How an axle on the road reaches the ring through a fill, for the rigid-block LP (the FE and the conic bounds
carry the load through the fill itself).

Each axle of load P (N) with a tyre contact of length c (m; 0: a line load) centred at x_a on the road, at depth
``h(x) = road - y_extrados(x)`` above the extrados, becomes a vertical pressure on the extrados' horizontal
projection, integrated on cells (:func:`dispersed_forces`) into vertical point forces on the voussoirs below:

* ``"boussinesq"`` (the default): the vertical stress under a uniform strip load on an elastic half-plane (Flamant's
  line load, Flamant 1892, C. R. Acad. Sci. 114:1465; the strip by superposition: Poulos & Davis 1974, Elastic
  Solutions for Soil and Rock Mechanics, table 2.2; Timoshenko & Goodier 1970, Theory of Elasticity, sec. 33-36):
  ``sigma_z = q/pi [alpha + sin(alpha) cos(alpha + 2 delta)]`` with q = P/c, alpha the angle the strip subtends at
  the point and delta the angle to its near edge; for c = 0 the line load ``2 P z^3 / (pi (xi^2 + z^2)^2)``. Taken
  at each point's own depth h(x), so a deep haunch receives less. It spreads without limit and tails off: the
  distribution LimitState:RING offers as its Boussinesq option (LimitState 2016, RING 3.2 manual, "Fill" -- its
  text could not be read here: the closed form above is the cited elasticity solution, not RING's code).
* ``"spread-2:1"``: uniform over ``c + 2 h_a tan(theta)``, tan(theta) = 1/2 (1 horizontal to 2 vertical, the
  UK assessment rule for fill: Highways England CS 454 / formerly BD 21, and the MEXE method; text not read here),
  h_a the depth under the axle.
* ``"spread-30"``: the same with theta = 30 degrees from the vertical (a common trapezoidal dispersion, e.g. RING's
  trapezoidal option; not read here).
* ``"none"``: uniform over the contact length on the extrados directly below (no spreading; a point axle: a
  point force).

Load that spreads beyond the extrados' ends (the springings' extrados corners) bears on the abutment and is lost
to the ring, in every rule. The forces are
for a unit vehicle factor (N), so the LP's load level is the vehicle's load factor. docs/assessment.md shows how
much the rule moves Prestwood's answer.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..geometry.ring import joint_under, point_load_blocks
from ..limit.rigid_block import generalised_loads, solve_blocks  # the LP's public functions
from ..limit.ring_blocks import ring_model
from ..scene.model import Scene
from ..structure.ring import scene_ring

CELLS = 400  # integration cells across the extrados
MERGE = 1e-9  # x the extrados' length: cell edges closer than this are one
SPREAD = {"spread-2:1": 0.5, "spread-30": math.tan(math.radians(30.0)), "none": 0.0}


def strip_stress(q: float, c: float, xi: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Vertical stress (N/m per the scene's width, for q in N/m) at horizontal offsets
    ``xi`` (m) from the centre of a uniform strip load ``q`` x ``c`` (N; c m long) and depths ``z`` (m) > 0."""
    a1 = np.arctan2(xi + c / 2, z)
    a2 = np.arctan2(xi - c / 2, z)
    alpha, delta = a1 - a2, a2
    return q / np.pi * (alpha + np.sin(alpha) * np.cos(alpha + 2 * delta))


def dispersed_forces(scene: Scene, ring, axles: list[tuple[float, float, float]],
                     rule: str) -> tuple[np.ndarray, ...]:
    """(blocks, points, forces): the vertical forces (N) on the outer ring's extrados (and the piers' tops between
    spans) of ``axles`` spread by ``rule`` through the fill (module docstring). Each axle is (load N, lo, hi): its
    tyre patch on the road from ``lo`` to ``hi`` (m from midspan; lo == hi: a point axle).

    1. Cells: the extrados' horizontal extent (from the left springing's extrados corner to the right one's) cut
       into :data:`CELLS` equal cells, cut again at every voussoir's (and pier top's) ends and, for the spread
       rules, at the ends of every axle's spread, so that each cell lies on one block and a spread's pressure is
       constant on it.
    2. Pressure on each cell's midpoint, axle by axle: Boussinesq at the cell's own depth below the road; a spread
       rule uniform over the patch widened by ``h tan(theta)`` on each side, h the depth under the patch's centre.
    3. Each cell's pressure x width is a vertical force at the extrados point above its midpoint, on its voussoir
       (exact resultants and moments for the spread rules: their pressure is constant on a cell).
    4. A spread of zero width (a point axle with ``"none"``, or on no fill depth) is a point force at the extrados
       above it, on the voussoir below it or, on a joint's corner, half on each side
       (:func:`bridgefem.geometry.ring.point_load_blocks`).
    """
    road = ring.crown_extrados + scene.fill.depth
    top = ring.top_pieces  # the barrel's extrados under the fill (and the piers' tops between spans)
    ext = np.vstack([line for _, line in top])
    left, right = ext[0, 0], ext[-1, 0]  # the extrados' ends: beyond them the fill stands on the abutments
    ends = [x for _, line in top for x in (line[0, 0], line[-1, 0])]
    spreads = []
    for load, lo, hi in axles:
        h = road - ring.extrados_point(float(np.clip((lo + hi) / 2, left, right)))[1]
        widen = 0.0 if rule == "boussinesq" else h * SPREAD[rule]
        spreads.append((load, lo - widen, hi + widen))
        ends += [lo - widen, hi + widen]
    edges = np.clip(np.concatenate([np.linspace(left, right, CELLS + 1), ends]), left, right)
    edges = np.sort(edges)
    edges = edges[np.concatenate([[True], np.diff(edges) > MERGE * (right - left)])]
    mid, dx = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    depth = np.maximum(road - np.interp(mid, ext[:, 0], ext[:, 1]), 1e-9)
    pressure = np.zeros_like(mid)
    point_x, point_load = [], []
    for (load, lo, hi), (_, a, b) in zip(axles, spreads):
        if rule == "boussinesq":
            c = hi - lo
            pressure += (strip_stress(load / c, c, mid - (lo + hi) / 2, depth) if c > 0
                         else 2 * load * depth ** 3 / (np.pi * ((mid - lo) ** 2 + depth ** 2) ** 2))
        elif b > a:
            pressure += np.where((mid > a) & (mid < b), load / (b - a), 0.0)
        elif left < a < right:
            point_x.append(a)
            point_load.append(load)
    force = pressure * dx
    keep = force > 0
    x0 = np.array([line[0, 0] for _, line in top])
    ids = np.array([b for b, _ in top])
    blocks = [ids[np.clip(np.searchsorted(x0, mid[keep], side="right") - 1, 0, len(top) - 1)]]
    xs, fy = [mid[keep]], [force[keep]]
    for x, load in zip(point_x, point_load):
        on = point_load_blocks(ring, x, "split")
        j = joint_under(ring, x)
        blocks.append(np.array(on))
        xs.append(np.full(len(on), x if j is None else ring.joints[j].extrados[0]))
        fy.append(np.full(len(on), load / len(on)))
    x, f = np.concatenate(xs), np.concatenate(fy)
    points = np.column_stack([x, np.interp(x, ext[:, 0], ext[:, 1])])
    return np.concatenate(blocks), points, np.column_stack([np.zeros(len(f)), -f])


def dispersed_lp(scene: Scene, axles: list[tuple[float, float, float]], rule: str):
    """The rigid-block LP (the scene's joint law) of ``scene``'s ring with its fill as dead load and ``axles``
    (load N, patch from lo to hi m from midspan, :func:`dispersed_forces`) dispersed by ``rule`` as the live load
    for a unit vehicle factor: its ``level`` is the factor."""
    ring = scene_ring(scene)
    model = ring_model(scene, live=False, ring=ring)
    blocks, points, forces = dispersed_forces(scene, ring, axles, rule)
    live = generalised_loads(model.ref, blocks, points, forces)
    return solve_blocks(dataclasses.replace(model, live=live))
