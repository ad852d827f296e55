"""Triangle meshes of a soil region for the collapse bounds (:mod:`bridgefem.limit.bounds`), made with Gmsh.

The region is a simple polygon given counter-clockwise by its corner points; every side has a *kind*:

* ``ROAD``: a traction boundary (free, or carrying a live load: a traction per unit load factor);
* ``ROLLER``: the normal velocity is zero, the shear traction zero (the fill's vertical ends);
* ``FIXED``: velocity zero, any traction (the fill's base);
* ``INTERFACE``: contact with a rigid block (a voussoir or a smooth footing) through a no-tension Coulomb interface;
* ``BONDED``: bonded to a rigid block (a loading beam, a rough footing): no velocity jump, any traction.

Lengths in m. Triangles are counter-clockwise; side ``s`` of a triangle runs from its local vertex ``s`` to
``(s + 1) % 3``, and its outward unit normal is the side's direction turned clockwise by 90 degrees.

:func:`triangulate`:

1. Gmsh (Geuzaine & Remacle 2009, Int. J. Numer. Meth. Eng. 79:1309; its MeshAdapt algorithm) meshes the polygon
   with the sizes given at its corners, and with a fan of ``FAN`` rays embedded around each point where the boundary
   traction jumps (:class:`Outline`);
2. the triangles are renumbered to the vertices they use and turned counter-clockwise;
3. every edge is classified (:func:`_classify`): interior, or the kind, block and traction of the side it lies on.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ROAD, ROLLER, FIXED, INTERFACE, BONDED = 0, 1, 2, 3, 4
ON_BLOCK = (INTERFACE, BONDED)  # sides against a rigid block
INTERIOR = -1
FAN = 32  # triangles around a point where the boundary traction jumps
FAN_GROWTH = 1.5  # ratio of the radii of successive rings of the fan
FAN_REACH = 0.9  # the fan's outer radius, in multiples of the distance to the nearest other side


@dataclass(frozen=True)
class Outline:
    """A counter-clockwise polygon (m): ``points`` (n, 2), mesh ``sizes`` (n,) at the points (m), and per side
    ``i`` (from point i to i + 1, cyclically) its ``kind``, its ``block`` (the rigid block behind an INTERFACE or
    BONDED side, else -1) and its ``traction`` (2,) per unit load factor (Pa; ROAD sides only). ``fans``: points
    (on straight stretches) where the traction jumps: the mesh has a fan of ``FAN`` rays there, out into the region,
    so that the stress can turn through the discontinuities a lower bound needs at such a singular point (Sloan
    1988) and the velocity can shear along the rays of the mechanism's radial zone. The mesh changes neither bound's
    rigour: every mesh gives a statically admissible field and a kinematically admissible mechanism; the fan makes
    them better."""

    points: np.ndarray
    sizes: np.ndarray
    kind: np.ndarray
    block: np.ndarray
    traction: np.ndarray
    fans: tuple[int, ...] = ()


@dataclass(frozen=True)
class SoilMesh:
    """Straight-sided triangles over an :class:`Outline`.

    x (nv, 2) vertices (m); triangles (ne, 3) counter-clockwise; edges (ned, 2) vertex pairs; triangle_edges
    (ne, 3) the edge of each side; edge_triangles (ned, 2) the triangles on each edge (second -1 on the boundary)
    with edge_sides (ned, 2) the local side number in each; edge_kind (ned,) INTERIOR or the boundary kind;
    edge_block (ned,) the block behind an INTERFACE or BONDED edge (else -1); edge_traction (ned, 2) Pa per unit load
    factor on ROAD edges.
    """

    x: np.ndarray
    triangles: np.ndarray
    edges: np.ndarray
    triangle_edges: np.ndarray
    edge_triangles: np.ndarray
    edge_sides: np.ndarray
    edge_kind: np.ndarray
    edge_block: np.ndarray
    edge_traction: np.ndarray

    @property
    def n_triangles(self) -> int:
        return len(self.triangles)

    def areas(self) -> np.ndarray:
        """Triangle areas (m^2)."""
        p = self.x[self.triangles]
        d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        return 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])

    def gradients(self) -> np.ndarray:
        """Gradients (ne, 3, 2) of the barycentric coordinates (1/m), constant on each triangle."""
        p = self.x[self.triangles]
        nxt, prv = p[:, [1, 2, 0]], p[:, [2, 0, 1]]
        edge = prv - nxt  # side opposite each vertex, turned: grad L_k = (y_next - y_prev, x_prev - x_next)/(2A)
        return np.stack([-edge[..., 1], edge[..., 0]], axis=-1) / (2 * self.areas()[:, None, None])

    def edge_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per edge, oriented as side ``edge_sides[:, 0]`` of its first triangle: start and end vertex ids
        (ned, 2), length (m), unit tangent and the outward unit normal of that triangle (ned, 2 each)."""
        tri, side = self.edge_triangles[:, 0], self.edge_sides[:, 0]
        ends = np.column_stack([self.triangles[tri, side], self.triangles[tri, (side + 1) % 3]])
        d = self.x[ends[:, 1]] - self.x[ends[:, 0]]
        length = np.linalg.norm(d, axis=1)
        tangent = d / length[:, None]
        return ends, length, tangent, np.column_stack([tangent[:, 1], -tangent[:, 0]])


def triangulate(outline: Outline) -> SoilMesh:
    """Mesh an outline with Gmsh (sizes interpolated from the points) and classify the edges."""
    import gmsh

    o = outline
    gmsh.initialize([], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("soil")
        geo = gmsh.model.geo
        pts = [geo.addPoint(x, y, 0.0, h) for (x, y), h in zip(o.points, o.sizes)]
        lines = [geo.addLine(a, b) for a, b in zip(pts, pts[1:] + pts[:1])]
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        inner = [geo.addPoint(x, y, 0.0, h) for (x, y), h in _fan_points(o)]
        geo.synchronize()
        if inner:
            gmsh.model.mesh.embed(0, inner, 2, surface)
        gmsh.option.setNumber("Mesh.Algorithm", 1)
        gmsh.model.mesh.generate(2)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        types, _, nodes = gmsh.model.mesh.getElements(2)
        triangles = index[np.asarray(nodes[list(types).index(2)], dtype=np.int64)].reshape(-1, 3)
        segments = [index[np.asarray(gmsh.model.mesh.getElements(1, c)[2][0], dtype=np.int64)].reshape(-1, 2)
                    for c in lines]
    finally:
        gmsh.finalize()
    x = xyz.reshape(-1, 3)[:, :2]
    used, triangles = np.unique(triangles, return_inverse=True)
    renumber = np.full(len(x), -1)
    renumber[used] = np.arange(len(used))
    x, triangles = x[used], triangles.reshape(-1, 3)
    d1, d2 = x[triangles[:, 1]] - x[triangles[:, 0]], x[triangles[:, 2]] - x[triangles[:, 0]]
    signed = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    triangles[signed < 0] = triangles[signed < 0][:, [0, 2, 1]]
    return _classify(x, triangles, [renumber[s] for s in segments], o)


def _fan_points(o: Outline) -> list:
    """Points (and sizes) of the fan around each fan point: ``FAN - 1`` rays evenly spaced in angle over the half
    plane inside the region, with a point on each ray at the radii ``size x FAN_GROWTH^k`` up to ``FAN_REACH``
    times the distance to the nearest side not at the point (the centred fan of stress discontinuities of the
    exact solution, Prandtl's radial shear zone, reaches out to the edge of the plastic zone)."""
    out = []
    n = len(o.points)
    for i in o.fans:
        p = o.points[i]
        along = o.points[(i + 1) % n] - p
        t = along / np.linalg.norm(along)
        inward = np.array([-t[1], t[0]])
        reach = FAN_REACH * min(_distance(p, o.points[j], o.points[(j + 1) % n]) for j in range(n)
                                if j not in (i, (i - 1) % n))
        radii = o.sizes[i] * FAN_GROWTH ** np.arange(max(1, int(np.log(max(reach / o.sizes[i], 1.0))
                                                                 / np.log(FAN_GROWTH)) + 1))
        angle = np.pi * np.arange(1, FAN) / FAN
        ray = np.cos(angle)[:, None] * t + np.sin(angle)[:, None] * inward
        for r in radii:
            h = max(o.sizes[i], r * np.pi / FAN)
            out += [(q, h) for q in p + r * ray]
    return out


def _distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance (m) from the point p to the segment a-b."""
    d = b - a
    s = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
    return float(np.linalg.norm(p - a - s * d))


def _classify(x: np.ndarray, triangles: np.ndarray, segments: list[np.ndarray], o: Outline) -> SoilMesh:
    """Edges, their triangles and sides, and the kind/block/traction of the boundary edges (from the outline
    side each boundary segment lies on)."""
    n = len(x)
    ne = len(triangles)
    a, b = triangles, triangles[:, [1, 2, 0]]
    keys = (np.minimum(a, b) * n + np.maximum(a, b)).ravel()
    unique, edge_of = np.unique(keys, return_inverse=True)
    ned = len(unique)
    edge_of = edge_of.reshape(ne, 3)
    order = np.argsort(edge_of.ravel(), kind="stable")
    count = np.bincount(edge_of.ravel(), minlength=ned)
    first = np.concatenate([[0], np.cumsum(count)[:-1]])
    tri_side = np.column_stack([np.repeat(np.arange(ne), 3), np.tile(np.arange(3), ne)])[order]
    edge_triangles = np.full((ned, 2), -1)
    edge_sides = np.full((ned, 2), -1)
    edge_triangles[:, 0], edge_sides[:, 0] = tri_side[first].T
    two = count == 2
    edge_triangles[two, 1], edge_sides[two, 1] = tri_side[first[two] + 1].T
    kind = np.full(ned, INTERIOR)
    block = np.full(ned, -1)
    traction = np.zeros((ned, 2))
    for side, seg in enumerate(segments):
        e = np.searchsorted(unique, np.minimum(seg[:, 0], seg[:, 1]) * n + np.maximum(seg[:, 0], seg[:, 1]))
        kind[e], block[e], traction[e] = o.kind[side], o.block[side], o.traction[side]
    if np.any(kind[~two] == INTERIOR) or np.any(kind[two] != INTERIOR):
        raise RuntimeError("soil mesh: the boundary edges do not match the outline")
    return SoilMesh(x, triangles, np.column_stack([unique // n, unique % n]), edge_of, edge_triangles, edge_sides,
                    kind, block, traction)
