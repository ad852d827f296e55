"""How an axle on the road reaches the ring through a fill, for the rigid-block LP (the FE and the conic bounds
carry the load through the fill itself).

Each axle of load P (N) with a tyre contact of length c (m; 0: a line load) at x_a on the road, at depth
``h(x) = road - y_extrados(x)`` above the extrados, becomes a vertical pressure on the extrados' horizontal
projection, integrated on :data:`CELLS` cells per span into vertical point forces on the voussoirs below:

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
* ``"none"``: uniform over the contact length on the extrados directly below (no spreading).

Load that spreads beyond a springing bears on the abutment and is lost to the ring, in every rule. The forces are
for a unit vehicle factor (N), so the LP's load level is the vehicle's load factor. docs/assessment.md shows how
much the rule moves Prestwood's answer.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..limit.rigid_block import generalised_loads, solve_blocks  # the LP's public functions
from ..limit.ring_blocks import ring_model
from ..scene.model import Scene
from ..structure.ring import scene_ring

CELLS = 400  # integration cells per span
SPREAD = {"spread-2:1": 0.5, "spread-30": math.tan(math.radians(30.0)), "none": 0.0}


def strip_stress(q: float, c: float, xi: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Vertical stress (N/m per the scene's width, for q in N/m) at horizontal offsets
    ``xi`` (m) from the centre of a uniform strip load ``q`` x ``c`` (N; c m long) and depths ``z`` (m) > 0."""
    a1 = np.arctan2(xi + c / 2, z)
    a2 = np.arctan2(xi - c / 2, z)
    alpha, delta = a1 - a2, a2
    return q / np.pi * (alpha + np.sin(alpha) * np.cos(alpha + 2 * delta))


def dispersed_forces(scene: Scene, ring, axles: list[tuple[float, float]], rule: str) -> tuple[np.ndarray, ...]:
    """(blocks, points, forces): the vertical forces (N) on the outer ring's voussoirs' extrados of ``axles`` (load N, x in the
    scene's coordinates, m from midspan) spread by ``rule`` through the fill (module docstring)."""
    span, c = scene.arch.span, scene.vehicle.contact_length
    road = ring.crown_extrados + scene.fill.depth
    outer = ring.outer_voussoirs  # the barrel's extrados, under the fill
    x0 = np.array([v.extrados[0, 0] for v in outer])
    edges = np.linspace(-span / 2, span / 2, CELLS + 1)
    mid, dx = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    depth = np.array([road - ring.extrados_point(x)[1] for x in mid])
    pressure = np.zeros_like(mid)
    for load, xa in axles:
        if rule == "boussinesq":
            if c > 0:
                pressure += strip_stress(load / c, c, mid - xa, np.maximum(depth, 1e-9))
            else:
                z = np.maximum(depth, 1e-9)
                pressure += 2 * load * z ** 3 / (np.pi * ((mid - xa) ** 2 + z ** 2) ** 2)
        else:
            h = road - ring.extrados_point(float(np.clip(xa, -span / 2, span / 2)))[1]
            half = c / 2 + h * SPREAD[rule]
            lo, hi = xa - half, xa + half
            if hi - lo <= 0:
                continue
            overlap = np.clip(np.minimum(edges[1:], hi) - np.maximum(edges[:-1], lo), 0.0, None)
            pressure += load / (hi - lo) * overlap / dx
    force = pressure * dx
    keep = force > 0
    blocks = np.array([outer[k].id for k in np.clip(np.searchsorted(x0, mid[keep], side="right") - 1, 0,
                                                      len(outer) - 1)], int)
    points = np.array([ring.extrados_point(x) for x in mid[keep]]).reshape(-1, 2)
    forces = np.column_stack([np.zeros(keep.sum()), -force[keep]])
    return blocks, points, forces


def dispersed_lp(scene: Scene, axles: list[tuple[float, float]], rule: str):
    """The rigid-block LP (associative) of ``scene``'s ring with its fill as dead load and ``axles`` (load N, x m
    from midspan) dispersed by ``rule`` as the live load for a unit vehicle factor: its ``level`` is the factor."""
    ring = scene_ring(scene)
    model = ring_model(scene)
    blocks, points, forces = dispersed_forces(scene, ring, axles, rule)
    live = generalised_loads(model.ref, blocks, points, forces)
    return solve_blocks(dataclasses.replace(model, live=live))
