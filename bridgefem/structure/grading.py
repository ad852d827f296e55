"""The element ends through a joint, graded towards its edges where a compressed zone of finite depth must be
resolved: masonry that crushes carries a hinge's thrust on a stress block whose depth the FE's pairs across the joint
resolve only as finely as they are spaced (:mod:`bridgefem.laws.crushing`, the polygon of its pairs). Positions are
fractions of the joint's depth from the intrados (0 to 1); the number of elements is what the mesh puts through the
joint (:mod:`bridgefem.fe.mesh` draws them as a chain), what the size estimate counts
(:mod:`bridgefem.structure.sizing`) and what the stress-block LP chooses from
(:mod:`bridgefem.analysis.stress_block`). Pure numpy.
"""
from __future__ import annotations

import math

import numpy as np

GROWTH = 1.5  # the largest ratio of neighbouring elements' sizes where a graded joint coarsens towards its middle
GRADING_TOLERANCES = (1e-2, 2.5e-3, 6.25e-4)  # the graded joints' moment tolerances tried in turn (each halves the
# spacing; :mod:`bridgefem.analysis.stress_block`)


def graded_nodes(elements: int, tolerance: float, zones: tuple[float, float]) -> tuple[float, ...]:
    """The element ends (fractions of a joint's depth t from the intrados, 0 to 1) of a joint whose pairs resolve
    the stress block to ``tolerance`` at every compressed zone from ``zones[0]`` to twice ``zones[1]`` deep (fractions
    of t, the hinges' thinnest and deepest zones), with at most the even spacing 1/``elements`` elsewhere.

    Pairs at spacing s (a fraction of t) around a compressed zone of depth x overstate the joint's moment by about f_c w
    (s t)^2 / 8 (the polygon's vertex above the parabola, :mod:`bridgefem.laws.crushing`), a fraction s^2 / (4 x) of the
    hinge moment n t / 2 (n = f_c w x t); a zone shallower than the first spacing sits on the edge pair, overstating the
    moment by its whole stress block, a fraction x / 2 or less (so a zone shallower than ``tolerance`` needs no
    resolving, and the thinnest zone is taken at least that deep). So:

    1. the spacing allowed at depth x is s(x) = 2 sqrt(``tolerance`` max(x, zones[0])) up to 2 zones[1] (the FE's
       hinges may carry more than the LP's), beyond it ``GROWTH`` times the spacing before; at most 1/``elements``;
    2. from each edge the nodes are marched x_{k+1} = x_k + s while s < 1/``elements`` and x_{k+1} is short of the
       joint's middle;
    3. the rest, between the two graded ends, is divided evenly: into pieces of at most 1/``elements`` where the
       march reached that spacing, else into pieces as near s as a whole number gives (a rest shorter than half of
       s joins the last graded piece on each side).

    Where no grading is needed (2 sqrt(tolerance zones[0]) >= 1/elements) these are ``elements`` even elements."""
    even, thinnest, cover = 1.0 / elements, max(zones[0], tolerance), 2.0 * zones[1]
    ends, step = [0.0], 0.0
    while True:
        x = ends[-1]
        step = min(even, 2.0 * math.sqrt(tolerance * max(x, thinnest)) if x <= cover else GROWTH * step)
        if step >= even or x + step >= 0.5:
            break
        ends.append(x + step)
    if step < even and 1.0 - 2.0 * ends[-1] < step / 2 and len(ends) > 1:
        ends.pop()
    edge = np.array(ends)
    width = 1.0 - 2.0 * edge[-1]
    pieces = math.ceil(width / even - 1e-9) if step >= even else max(1, round(width / step))
    middle = np.linspace(edge[-1], 1.0 - edge[-1], pieces + 1)
    return tuple(np.concatenate([edge[:-1], middle, 1.0 - edge[-2::-1]]).tolist())


def graded_within(elements: int, tolerance: float, zones: tuple[float, float], most: int) -> tuple[float, ...]:
    """:func:`graded_nodes` at ``tolerance`` when they are at most ``most`` elements, else the finest grading of the
    same ``zones`` within ``most`` elements (``most`` >= ``elements``): the least tolerance t >= ``tolerance`` whose
    grading has at most ``most`` elements, to a factor ``1 + 1e-3`` of t, by bisection on log t between ``tolerance``
    and 1 (at t = 1 every spacing 2 sqrt(t max(x, t)) >= 2 exceeds the even one: ``elements`` even elements, always
    within ``most``)."""
    nodes = graded_nodes(elements, tolerance, zones)
    if len(nodes) - 1 <= most:
        return nodes
    low, high = math.log(tolerance), 0.0
    fitting = graded_nodes(elements, 1.0, zones)
    while high - low > 1e-3:
        middle = (low + high) / 2
        trial = graded_nodes(elements, math.exp(middle), zones)
        if len(trial) - 1 <= most:
            high, fitting = middle, trial
        else:
            low = middle
    return fitting


def densest_grading(elements: int) -> int:
    """The most elements :func:`graded_nodes` gives a joint of ``elements`` even elements at the finest of
    ``GRADING_TOLERANCES``: hinge zones from none to the joint's middle, each spacing the least its depth allows."""
    return len(graded_nodes(elements, GRADING_TOLERANCES[-1], (0.0, 0.5))) - 1
