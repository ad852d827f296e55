"""Arch ring geometry: intrados curve, joints and voussoir polygons — one source for the FE mesh and the LP (pure
numpy; a scene's ring is built by :func:`bridgefem.structure.ring.scene_ring`).

Coordinates are in metres with the origin at the midpoint of the springing line on the intrados,
x to the right and y up. A curve parameter ``p`` in [0, 1] runs along the intrados from the left
springing (p = 0) to the right springing (p = 1).

The ring is the band swept by the joint segments ``intrados(p) -> intrados(p) + t n(p)`` where ``n`` is
the unit normal of the intrados pointing towards the extrados. Offset curves share their normals, so
every joint is perpendicular to the intrados, the centreline (offset t/2) and the extrados (offset t);
for circular shapes the joints are radial. Joints are spaced evenly along the centreline arc length,
except that by default a joint is moved under each concentrated load.

The intrados curves are those of :mod:`bridgefem.geometry.shapes`; on one, :func:`build_ring`

1. measures the centreline's arc length on fine samples of ``p`` (a chord ending at a kink ends on its own arc, so
   the pointed crown's jump between the two arcs' offsets counts no length);
2. places N + 1 joints at equal centreline lengths, the springings at p = 0 and 1;
3. with ``joint_at_loads``, moves an interior joint under each point load and patch edge between the springings
   (a load beyond them, over a pier of a bridge of several spans, gets a vertex only), keeping the joints in
   their order (:func:`_place_joints_at_loads`: a voussoir straddling a concentrated load overstates the limit
   load), and refuses a layout that would leave a voussoir of (almost) no length (:func:`_check_voussoir_lengths`);
4. stacks the rings (``ring_thicknesses``; one ring by default): ring r between the offsets of the rings inside
   it; the outer ring's joints are those of steps 2-3, and with a staggered bond every other ring inwards has its
   joints halfway between them along the centreline (brick bond, half voussoirs at the springings), with an
   aligned bond the same joints;
5. draws each voussoir's intrados and extrados as polylines of ``_EDGE_SAMPLES`` points, with a vertex at every
   kink and load point on it (its polygon, for areas and centroids, and its Gmsh splines); a load within
   ``AT_JOINT_TOL`` x span of a joint's extrados corner acts at the corner and gets no vertex of its own; an
   interface between two rings is sampled once for both, with a vertex at every joint of either ring
   (:func:`_barrel`).

One ring of N voussoirs: joint ``j`` (0..N) separates voussoir ``j-1`` (its *left* block) from voussoir ``j`` (its
*right* block); joints 0 and N are the springings, whose outer side is the ground (block id ``None``). A joint's
unit normal points from its left block into its right block (the centreline tangent); its unit tangent is
the normal rotated +90 degrees, which points from the intrados towards the extrados at the left springing.

Several rings: the voussoirs ring by ring from the intrados (ring 0 first), the joints likewise (each ring's
springings and voussoir joints, from the ring's intrados side to its extrados side), then the ring interfaces
(``kind`` "ring": one joint per piece between two consecutive joints of either ring, its inner ring's voussoir on
the left, its outer ring's on the right, curved: :attr:`Joint.curve`).

On elastic abutments (:func:`add_abutments`) blocks N (left) and N + 1 (right), N the number of voussoirs, stand
below the springings: the springing joints then separate the rings from an abutment, and two more joints (left,
then right) are the abutments' bases on the ground, drawn from the inner base corner (their "intrados", on the
span side) to the outer one (their "extrados").
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .shapes import Shape, make_shape

LOAD_SIDES = ("left", "right", "split")
# a load point within this fraction of the span of a joint's extrados corner is on the joint: it acts at the
# corner and gets no edge point of its own (a sliver of an edge would need a sliver of a mesh)
AT_JOINT_TOL = 1e-4
KINK_NUDGE = 1e-6  # a chord's end at a kink is moved this fraction of it back onto its own arc
ROUND_OFF = 1e-12  # of the span: two coordinates closer than this are one (their difference is round-off)
_FINE = 4001  # samples of p to measure arc lengths and invert x(p): interpolation errors ~ span / 4000^2
# points per voussoir intrados/extrados edge (polygon and Gmsh splines): 16 chords, so that a voussoir's polygon
# holds 1 - theta^2 / 1536 of its curved area (theta: its angle, rad): 7e-4 short at 60 degrees, 1e-5 at 11.25
_EDGE_SAMPLES = 17


JOINT_KINDS = ("voussoir", "springing", "ring", "base", "pier")
"""What a joint is: between two voussoirs of a ring, between a ring and its support (the ground, an abutment or a
pier), between two rings (a ring interface, curved), an abutment's base on the ground, or a bed joint of a pier
(between two of its courses, or its lowest course on the ground)."""


@dataclass(frozen=True)
class Joint:
    """A potential crack between two blocks; ``left``/``right`` are block ids or None for the ground (or, with
    ``free``, for nothing: an unloaded free face). ``kind`` is one of :data:`JOINT_KINDS`. A joint runs from its
    ``intrados`` end to its ``extrados`` end (a ring interface: from its end nearer the right springing to the one
    nearer the left, so that its normal points outwards); a curved joint (a ring interface) has its ``curve``, a
    polyline between those ends (m), straight joints have none."""

    id: int
    intrados: np.ndarray
    extrados: np.ndarray
    left: int | None
    right: int | None
    free: bool = False  # a free face (no ground behind the missing block), e.g. the top of a standing block
    kind: str = "voussoir"
    curve: np.ndarray | None = field(default=None, repr=False)
    span: int | None = 0  # the span whose barrel it belongs to (from 0, left to right); None: a pier's or a base

    @property
    def length(self) -> float:
        """Length (m): of the chord, or of the curve when the joint is curved."""
        if self.curve is not None:
            return float(np.linalg.norm(np.diff(self.curve, axis=0), axis=1).sum())
        return float(np.linalg.norm(self.extrados - self.intrados))

    @property
    def tangent(self) -> np.ndarray:
        """Unit vector along the joint's chord, from its intrados end to its extrados end."""
        return (self.extrados - self.intrados) / np.linalg.norm(self.extrados - self.intrados)

    @property
    def normal(self) -> np.ndarray:
        """Unit normal of the chord from the left block into the right block (the centreline direction)."""
        t = self.tangent
        return np.array([t[1], -t[0]])

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (self.intrados + self.extrados)

    @property
    def chords(self) -> tuple[np.ndarray, np.ndarray]:
        """The joint as straight pieces: start and end points (k, 2), m (one piece for a straight joint, the
        curve's chords for a curved one), in the joint's direction."""
        pts = np.vstack([self.intrados, self.extrados]) if self.curve is None else self.curve
        return pts[:-1], pts[1:]

    def frame_at(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For points on the joint (k, 2): their distance along it from the intrados end (m), and the unit normal
        (left block into right) and tangent there (k, 2): those of the piece of :attr:`chords` nearest each point
        (of the joint itself when it is straight)."""
        if self.curve is None:
            n = len(points)
            return (points - self.intrados) @ self.tangent, np.tile(self.normal, (n, 1)), np.tile(self.tangent, (n, 1))
        a, b = self.chords
        d = b - a
        seg = np.linalg.norm(d, axis=1)
        t = np.clip(((points[:, None, :] - a[None]) * d[None]).sum(axis=2) / seg ** 2, 0.0, 1.0)
        gap = np.linalg.norm(points[:, None, :] - (a[None] + t[..., None] * d[None]), axis=2)
        k = np.argmin(gap, axis=1)
        tangent = d[k] / seg[k, None]
        position = np.concatenate([[0.0], np.cumsum(seg)])[k] + t[np.arange(len(k)), k] * seg[k]
        return position, np.column_stack([tangent[:, 1], -tangent[:, 0]]), tangent


class _Polygonal:
    """Area (m^2) and centroid (m) of a block from its counter-clockwise ``polygon``."""

    polygon: np.ndarray

    @property
    def area(self) -> float:
        return polygon_area_centroid(self.polygon)[0]

    @property
    def centroid(self) -> np.ndarray:
        return polygon_area_centroid(self.polygon)[1]


@dataclass(frozen=True)
class Voussoir(_Polygonal):
    """A block of the ring: intrados and extrados edges as polylines (left to right), m.

    ``*_splits`` are indices of interior polyline points where the edge has a corner (pointed crown) or
    carries a concentrated load, and on the extrados where the crown's cap chord to the apex begins; the mesh places
    a node there, and its edge between two splits is straight (the polygon's chord) when they are neighbours.
    """

    id: int
    intrados: np.ndarray
    extrados: np.ndarray
    intrados_splits: tuple[int, ...] = ()
    extrados_splits: tuple[int, ...] = ()
    ring: int = 0  # 0: the innermost ring (on the intrados)
    span: int = 0  # the span it belongs to (from 0, left to right)

    @property
    def polygon(self) -> np.ndarray:
        """Counter-clockwise boundary: intrados left to right, then extrados right to left."""
        return np.vstack([self.intrados, self.extrados[::-1]])


def polygon_area_centroid(poly: np.ndarray) -> tuple[float, np.ndarray]:
    """Area (m^2) and centroid (m) of a simple counter-clockwise polygon (shoelace formula)."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = 0.5 * cross.sum()
    cx = ((x + xn) * cross).sum() / (6 * area)
    cy = ((y + yn) * cross).sum() / (6 * area)
    return float(area), np.array([cx, cy])


@dataclass(frozen=True)
class Abutment(_Polygonal):
    """An elastic block below a springing: ``polygon`` counter-clockwise (m), ``side`` "left" or "right"."""

    id: int
    polygon: np.ndarray
    side: str


@dataclass(frozen=True)
class PierBlock(_Polygonal):
    """A course of a masonry pier between two spans: ``polygon`` counter-clockwise (m); ``pier`` the pier's index
    (from 0, left to right: pier k carries spans k and k + 1), ``course`` from 0 (the top course, which carries the
    springings) down. Its material: :func:`bridgefem.structure.materials.block_materials`."""

    id: int
    polygon: np.ndarray
    pier: int
    course: int
    top: np.ndarray | None = field(default=None, repr=False)  # the top course: its free top edge (2, 2), left end first


@dataclass(frozen=True)
class ArchRing:
    """The geometry of a bridge's masonry: an arch barrel of one or more rings of voussoirs on two springings, or
    several such spans on piers (:mod:`bridgefem.geometry.bridge`), and its abutments when they are elastic.

    ``params`` are the curve parameters of the outer ring's joints (0 and 1 at the springings); ``joints`` are the
    rings' voussoir joints and springings, ring by ring from the intrados (ring 0: joints 0 .. N0), then the ring
    interfaces, then the abutments' base joints; ``voussoirs`` ring by ring likewise; ``ring_thicknesses`` (m) the
    rings' from the intrados out (empty: one ring of ``thickness``); ``joints_at_x`` the horizontal positions (m) of
    the loads and patch edges that a joint was moved under (``joint_at_loads``), so that a load on a joint it did
    not get can be told from one on its own (:func:`snapped_loads`).

    A bridge of several spans: ``spans`` holds each span's barrel (in the bridge's frame, with the bridge's block and
    joint ids), ``piers`` the piers' courses; ``shape``, ``span``, ``rise``, ``thickness``, ``params`` and
    ``ring_thicknesses`` are then the first span's (the frame's origin is its midspan). One span: ``spans`` is empty
    and :attr:`barrels` is the ring itself.
    """

    shape: str
    span: float
    rise: float
    thickness: float
    params: np.ndarray
    joints: list[Joint] = field(repr=False)
    voussoirs: list[Voussoir] = field(repr=False)
    abutments: list[Abutment] = field(default_factory=list, repr=False)
    joints_at_x: frozenset[float] = frozenset()
    ring_thicknesses: tuple[float, ...] = ()
    piers: list[PierBlock] = field(default_factory=list, repr=False)
    spans: tuple[ArchRing, ...] = field(default=(), repr=False)

    @property
    def barrels(self) -> tuple[ArchRing, ...]:
        """Each span's barrel, left to right (one span: the ring itself)."""
        return self.spans or (self,)

    @property
    def n_rings(self) -> int:
        return max(1, len(self.ring_thicknesses))

    @property
    def n_voussoirs(self) -> int:
        """Voussoirs of all rings and spans: the block ids 0 .. n_voussoirs - 1."""
        return len(self.voussoirs)

    @property
    def blocks(self) -> list:
        """Every block in id order: the voussoirs, the piers' courses, the elastic abutments."""
        return self.voussoirs + self.piers + self.abutments

    @property
    def n_blocks(self) -> int:
        """Voussoirs, pier courses and abutments: the block ids 0 .. n_blocks - 1 (the next id is the fill's)."""
        return len(self.voussoirs) + len(self.piers) + len(self.abutments)

    @property
    def outer_voussoirs(self) -> list[Voussoir]:
        """The voussoirs of each span's outer ring, left to right: their extrados is the barrel's, where loads act."""
        return [v for b in self.barrels for v in b.voussoirs if v.ring == b.n_rings - 1]

    def springings(self, side: str) -> list[Joint]:
        """The springing joints at the bridge's ``side`` end ("left" | "right"), one per ring from the intrados out
        (those on the ground or an abutment: a pier's are not ends)."""
        piers = {b.id for b in self.piers}
        xs = np.concatenate([v.intrados[:, 0] for v in self.voussoirs])
        middle = 0.5 * (xs.min() + xs.max())
        return [j for j in self.joints if j.kind == "springing" and not {j.left, j.right} & piers
                and (j.centre[0] < middle) == (side == "left")]

    @property
    def ring_joints(self) -> list[Joint]:
        """The voussoir joints and springings of every ring (the joints a reader numbers on a drawing)."""
        return [j for j in self.joints if j.kind in ("voussoir", "springing")]

    @property
    def bases(self) -> list[Joint]:
        """The elastic abutments' base joints on the ground (none on rigid springings)."""
        return [j for j in self.joints if j.kind == "base"]

    @property
    def crown_extrados(self) -> float:
        """Height (m) of the highest extrados point."""
        return max(float(v.extrados[:, 1].max()) for v in self.outer_voussoirs)

    @property
    def top_pieces(self) -> list[tuple[int, np.ndarray]]:
        """The bridge's top, left to right, as (block id, polyline (k, 2) in m, left to right): each span's outer
        voussoirs' extrados and each pier's top edge between them, where the live loads act on a bare bridge."""
        pieces = [(v.id, v.extrados) for v in self.outer_voussoirs] + [(b.id, b.top) for b in self.piers
                                                                         if b.top is not None]
        return sorted(pieces, key=lambda piece: float(piece[1][:, 0].mean()))

    def extrados_vertex(self, x: float) -> np.ndarray:
        """The vertex of the top's polylines (:attr:`top_pieces`) nearest to horizontal position x (m): where a point
        load at x acts, since :func:`build_ring` puts a vertex (a mesh node) under every load unless the load is
        within ``AT_JOINT_TOL`` x span of a joint's corner or the pointed crown's apex, where it acts at that corner
        (and :func:`bridgefem.geometry.bridge.build_bridge` one on a pier's top)."""
        ext = np.vstack([line for _, line in self.top_pieces])
        return ext[np.argmin(np.abs(ext[:, 0] - x))]

    def extrados_point(self, x: float) -> np.ndarray:
        """The point of the bridge's top (the extrados, or a pier's top between spans) above horizontal position x
        (m)."""
        ext = np.vstack([line for _, line in self.top_pieces])
        return np.array([x, np.interp(x, ext[:, 0], ext[:, 1])])


@dataclass(frozen=True)
class FillOutline:
    """The backfill region (m): vertical ends at ``x_left``/``x_right``, base at ``y_base`` (the level of the
    springings' extrados corners, fixed: elastic abutments below it are not connected to it), road at
    ``y_road``. The region is bounded below by the base lines and the ring's extrados; ``road_x`` are the road
    points that must be mesh nodes (point loads and patch edges)."""

    x_left: float
    x_right: float
    y_base: float
    y_road: float
    road_x: tuple[float, ...]


def fill_outline(ring: ArchRing, depth: float, extension: float, road_x: list[float] = ()) -> FillOutline:
    """The fill over ``ring`` with the road ``depth`` (m) above the crown's extrados, reaching ``extension`` (m)
    beyond each springing's extrados corner."""
    left, right = (ring.springings(side)[-1].extrados for side in ("left", "right"))
    return FillOutline(float(left[0]) - extension, float(right[0]) + extension, float(left[1]),
                       ring.crown_extrados + depth,
                       tuple(sorted(set(float(x) for x in road_x))))


def _ring_point(shape: Shape, thickness: float, p, offset: float) -> np.ndarray:
    return shape.point(p) + offset * thickness * shape.normal(p)


def _samples(shape: Shape) -> np.ndarray:
    """``_FINE`` equally spaced parameters in [0, 1] and the shape's kinks, sorted: where arc lengths are measured
    and x(p) inverted."""
    return np.unique(np.concatenate([np.linspace(0.0, 1.0, _FINE), shape.kinks]))


def _centreline_length(shape: Shape, thickness: float, p: np.ndarray) -> np.ndarray:
    """The ring's centreline arc length (m) from p[0] at the increasing parameters ``p`` (which hold the shape's
    kinks), summed over chords; a chord that ends at a kink ends on its own arc (``KINK_NUDGE`` of it short of the
    kink), so the centreline's jump there, between the offsets of the two arcs (the pointed crown: t sin(phi / 2) for
    an angle phi between their normals), is no length and joints at equal lengths give voussoirs of equal centreline
    length on both sides of the crown (counted, it would draw every joint that falls on it to the apex: slivers of a
    millimetre between joints a fraction of a degree apart; ``docs/joints-and-lp.md``)."""
    start, end = _ring_point(shape, thickness, p[:-1], 0.5), _ring_point(shape, thickness, p[1:], 0.5)
    for k in np.flatnonzero(np.isin(p, shape.kinks)):
        if k > 0:
            end[k - 1] = _ring_point(shape, thickness, p[k] - KINK_NUDGE * (p[k] - p[k - 1]), 0.5)
        if k < len(p) - 1:
            start[k] = _ring_point(shape, thickness, p[k] + KINK_NUDGE * (p[k + 1] - p[k]), 0.5)
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(end - start, axis=1))])


def _extrados_param(shape: Shape, thickness: float, x: float) -> tuple[float, bool]:
    """The curve parameter whose extrados point is at horizontal position x (m), interpolated in fine samples (about
    span / 4000^2 off: the load's vertex is the extrados vertex nearest to x, :meth:`ArchRing.extrados_vertex`), and
    whether that point exists: at a kink the extrados jumps (the pointed crown's cap between the offsets of its two
    arcs, closed by chords to the apex), and a load on the cap, farther than ``AT_JOINT_TOL`` x the ring's width from
    the interpolated point, gets the kink's parameter and False."""
    p = _samples(shape)
    xs = _ring_point(shape, thickness, p, 1.0)[:, 0]
    q = float(np.interp(x, xs, p))
    if abs(_ring_point(shape, thickness, q, 1.0)[0] - x) <= AT_JOINT_TOL * (xs[-1] - xs[0]):
        return q, True
    return min(shape.kinks, key=lambda v: abs(v - q)), False


def _place_joints_at_loads(params: np.ndarray, s_of_p, load_params: list[float]) -> tuple[np.ndarray, dict[int, float]]:
    """Move an interior joint onto each load parameter, keeping the joints in their order; springing joints never
    move. Returns the parameters and, per moved joint, the load parameter it went to. The caller makes sure there
    are as many interior joints as load parameters.

    Each load, from left to right, takes the nearest joint not yet taken. Where two loads are nearest one joint and
    the second's nearest free joint lies beyond the first's, that would cross two joints (a voussoir of negative
    length): then the joints go under the loads in order with the least total movement along the centreline
    (:func:`_least_movement`). Taking the nearest joint right of the previous load's instead moves a joint more
    than a voussoir's length where half of one does. Wherever the nearest joints keep the order they are kept:
    the least-movement layout serves only loads that compete for one joint."""
    s_joints = s_of_p(params)
    loads = sorted(set(load_params))
    s_loads = s_of_p(np.array(loads))
    chosen: list[int] = []
    for s_load in s_loads:
        order = np.argsort(np.abs(s_joints - s_load))
        chosen.append(int(next(j for j in order if 0 < j < len(params) - 1 and j not in chosen)))
    if np.any(np.diff(chosen) < 0):
        chosen = _least_movement(s_joints, s_loads)
    placed = params.copy()
    placed[chosen] = loads
    return placed, dict(zip(chosen, loads))


def _least_movement(s_joints: np.ndarray, s_loads: np.ndarray) -> list[int]:
    """The interior joints, one per load and in the loads' order (``s_loads`` increasing; centreline positions, m),
    whose total distance from their loads is least. Dynamic programme over the loads: ``best[k]`` is the least
    total distance of the loads so far with the last one on interior joint k (an unmoved joint between two moved ones
    then lies between their loads too, or moving a load onto it would cost less)."""
    inner = s_joints[1:-1]
    index = np.arange(len(inner))
    best = np.abs(inner - s_loads[0])
    came_from = []
    for s_load in s_loads[1:]:
        prefix = np.minimum.accumulate(best)  # the least over joints 0..k, and where it is
        where = np.maximum.accumulate(np.where(best < np.concatenate([[np.inf], prefix[:-1]]), index, 0))
        best = np.concatenate([[np.inf], prefix[:-1] + np.abs(inner[1:] - s_load)])
        came_from.append(np.concatenate([[0], where[:-1]]))
    k = int(np.argmin(best))
    chosen = [k]
    for back in reversed(came_from):
        k = int(back[k])
        chosen.append(k)
    return [k + 1 for k in reversed(chosen)]


def _load_label(labels: dict[float, list[str]], x: float) -> str:
    """The loads at horizontal position x (m) in words, e.g. "[[load]] #2 (point at x = -1.5 m)"."""
    return " and ".join(labels.get(x, [f"the load at x = {x:.9g} m"]))


def _check_voussoir_lengths(s_joints: np.ndarray, length: float, at_loads: dict[int, list[float]],
                            labels: dict[float, list[str]]) -> None:
    """Raise ValueError, naming the loads, when a joint moved under a load is within ``AT_JOINT_TOL`` x the ring's
    centreline ``length`` (m) of the next joint (``s_joints``: the joints' centreline positions, m): the voussoir
    between them would vanish, and the mesh cannot have an edge that short. ``at_loads``: per moved joint the
    horizontal positions (m) of the loads it went under."""
    gaps = np.diff(s_joints)
    tol = AT_JOINT_TOL * length
    short = [k for k in np.flatnonzero(gaps <= tol) if k in at_loads or k + 1 in at_loads]
    if not short:
        return
    k = min(short, key=lambda i: gaps[i])
    last = len(s_joints) - 1

    def what(j):
        if j in at_loads:
            return " and ".join(_load_label(labels, x) for x in at_loads[j])
        return "the left springing" if j == 0 else "the right springing" if j == last else f"joint {j} (not moved)"

    both = k in at_loads and k + 1 in at_loads
    loads, other = (what(k), what(k + 1)) if k in at_loads else (what(k + 1), what(k))
    where = (f"{loads} and {other}: the joints under them would be" if both
             else f"{loads}: the joint under it would be")
    raise ValueError(f"{where} {gaps[k]:.3g} m {'apart' if both else 'from ' + other} along the ring's centreline, "
                     f"closer than {AT_JOINT_TOL:g} x its length = {tol:.3g} m, and voussoir {k} between them "
                     f"would vanish; allowed are joints at least that far apart: put the load"
                     f"{'s further apart or at one position' if both else ' further from it'}, or set "
                     "[arch] joint_at_loads = false")


def _grouped_labels(load_x: list[float], load_labels: list[str] | None) -> dict[float, list[str]]:
    """The loads at each horizontal position (m) in words, for the messages: their ``load_labels``, else their
    position."""
    labels: dict[float, list[str]] = {}
    for x, label in zip(load_x, load_labels or [None] * len(load_x)):
        labels.setdefault(float(x), []).append(label or f"the load at x = {float(x):.9g} m")
    return labels


def _check_load_spacing(xs: np.ndarray, span: float, labels: dict[float, list[str]]) -> None:
    """Raise ValueError, naming the loads, when two of the load positions ``xs`` (m, increasing) are closer than
    ``AT_JOINT_TOL`` x span: the ring cannot have an edge that short."""
    gaps = np.diff(xs)
    if np.any(gaps < AT_JOINT_TOL * span):
        k = int(np.argmin(gaps))
        raise ValueError(f"{_load_label(labels, xs[k])} and {_load_label(labels, xs[k + 1])} are {gaps[k]:.3g} m "
                         f"apart, closer than {AT_JOINT_TOL:g} x span = {AT_JOINT_TOL * span:.3g} m: the ring cannot "
                         "have an edge that short; put them at one position or further apart")


def _joints_at_loads(params: np.ndarray, s_of_p, length: float, xs: np.ndarray, located: list[tuple[float, bool]],
                     labels: dict[float, list[str]]) -> tuple[np.ndarray, frozenset[float]]:
    """The joints' curve parameters ``params`` with an interior joint moved under each load position ``xs`` (m;
    ``located``: each one's curve parameter on the extrados and whether it lies on the curve rather than a kink's
    cap), and the positions on the curve that now have a joint under them. Raises ValueError when there are more
    load positions than interior joints, or a moved joint leaves a voussoir of (almost) no length along the
    centreline (``length``, m; ``s_of_p``: centreline position of a curve parameter)."""
    n_voussoirs = len(params) - 1
    load_params = [q for q, _ in located]  # a load on a kink's cap gets a joint at the kink
    wanted = len(set(load_params))
    if wanted > n_voussoirs - 1:
        raise ValueError(f"[arch] voussoirs = {n_voussoirs}: the loads need a joint under each of their {wanted} "
                         f"positions (point loads and patch edges, [arch] joint_at_loads = true), and "
                         f"{n_voussoirs} voussoirs have {n_voussoirs - 1} joints between the springings; allowed "
                         f"are at least {wanted + 1} voussoirs, or joint_at_loads = false")
    params, moved = _place_joints_at_loads(params, s_of_p, load_params)
    _check_voussoir_lengths(s_of_p(params), length, {j: [x for x, (q, _) in zip(xs, located) if q == pl]
                                                     for j, pl in moved.items()}, labels)
    return params, frozenset(float(x) for x, (q, on_curve) in zip(xs, located) if on_curve)


RING_BONDS = ("staggered", "aligned")


@dataclass(frozen=True)
class _Samples:
    """Where a voussoir's edges are sampled: curve parameters ``q`` (its joints' at both ends), which of them are
    kinks and where the extrados is split (:func:`_voussoir_samples`), and the extrados points that lie on a kink's
    cap chord rather than on the curve (``chord``: parameter -> point, m)."""

    q: np.ndarray
    kink_at: np.ndarray
    split_at: np.ndarray
    chord: dict


def _voussoir_samples(curve: Shape, thickness: float, span: float, pa: float, pb: float, curve_params: list[float],
                      cap_x: list[float]) -> _Samples:
    """The samples of the voussoir between the joints at curve parameters ``pa`` and ``pb``: ``_EDGE_SAMPLES``
    parameters and every kink and load point inside it (``curve_params``: the loads' curve parameters on the
    extrados; ``cap_x``: the positions (m) of loads on a kink's cap, each a vertex on its chord)."""

    def extrados_x(q):
        return _ring_point(curve, thickness, np.asarray(q, float), 1.0)[..., 0]

    kinks = [k for k in curve.kinks if pa + 1e-9 < k < pb - 1e-9]  # a kink at a joint is no split
    inside = np.array([k for k in curve_params if pa < k < pb])  # a load on a joint's corner is at the joint
    corner_gap = np.abs(extrados_x(inside)[:, None] - extrados_x([pa, pb])[None, :]).min(axis=1)
    loads = sorted(set(inside[corner_gap > AT_JOINT_TOL * span].tolist()))
    special = np.array(sorted(kinks + loads))
    regular = np.linspace(pa, pb, _EDGE_SAMPLES)
    if len(special):  # no spline point closer than a quarter of the sample spacing to a corner or load point
        gap = np.abs(regular[1:-1, None] - special[None, :]).min(axis=1)
        regular = np.concatenate([[pa], regular[1:-1][gap > 0.25 * (pb - pa) / (_EDGE_SAMPLES - 1)], [pb]])
    q = np.unique(np.concatenate([regular, special]))
    extra = _ring_point(curve, thickness, q, 1.0)
    kink_at, split_at = np.isin(q, kinks), np.isin(q, special)
    # the apex inside this voussoir or at one of its joints (``kinks`` leaves a joint's out: no split there)
    apex = np.flatnonzero(np.isclose(q[:, None], curve.kinks, rtol=0, atol=1e-9).any(axis=1))
    cap = np.concatenate([apex - 1, apex + 1])  # where the cap's chords to the apex begin: straight edges there
    split_at[cap[(cap > 0) & (cap < len(q) - 1)]] = True
    chord = {}
    for xc in cap_x:  # a load on the cap: a vertex on its chord, the intrados point at the same fraction
        if np.abs(extra[:, 0] - xc).min() <= AT_JOINT_TOL * span or not extra[0, 0] < xc < extra[-1, 0]:
            continue
        k = int(np.searchsorted(extra[:, 0], xc))
        f = (xc - extra[k - 1, 0]) / (extra[k, 0] - extra[k - 1, 0])
        qc = q[k - 1] + f * (q[k] - q[k - 1])
        chord[float(qc)] = extra[k - 1] + f * (extra[k] - extra[k - 1])
        extra = np.insert(extra, k, chord[float(qc)], axis=0)
        q, kink_at, split_at = np.insert(q, k, qc), np.insert(kink_at, k, False), np.insert(split_at, k, True)
    return _Samples(q, kink_at, split_at, chord)


def _level_params(rings: list[list[_Samples]], joints: list[np.ndarray], kinks: np.ndarray) -> np.ndarray:
    """The sample parameters of the interface between two rings, shared by both (``rings``: their voussoirs'
    samples, inner ring first; ``joints``: their joints' parameters): both rings' joints and the kinks, then every
    other sample of either ring not within a quarter of its voussoir's sample spacing of one already taken (a
    spline point that close to another would make a sliver of a mesh element). A kink within 1e-9 of a joint is at
    the joint (as in :func:`_voussoir_samples`): taken too, its point would be a round-off away from the joint's."""
    at_joints = np.unique(np.concatenate(joints))
    inner = kinks[(kinks > 0) & (kinks < 1)]
    inner = inner[np.abs(inner[:, None] - at_joints[None, :]).min(axis=1) > 1e-9]
    taken = np.unique(np.concatenate([at_joints, inner]))
    for samples in (s for ring in rings for s in ring):
        spacing = 0.25 * (samples.q[-1] - samples.q[0]) / (_EDGE_SAMPLES - 1)
        near = np.abs(samples.q[:, None] - taken[None, :]).min(axis=1)
        taken = np.unique(np.concatenate([taken, samples.q[near > spacing]]))
    return taken


def _staggered(params: np.ndarray, p: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Brick bond: the joints of a ring shifted half a voussoir from ``params`` (the curve parameters of the next
    ring's joints), half-voussoirs at the springings: the springings and the midpoints, along the centreline, of
    the voussoirs of ``params`` (``p``, ``s``: fine samples of the curve parameter and the centreline length)."""
    s_joints = np.interp(params, p, s)
    return np.concatenate([[0.0], np.interp(0.5 * (s_joints[:-1] + s_joints[1:]), s, p), [1.0]])


def _between(q: np.ndarray, pa: float, pb: float) -> np.ndarray:
    return q[(q >= pa) & (q <= pb)]


def _splits(q: np.ndarray, cuts: np.ndarray) -> tuple[int, ...]:
    """The interior indices of ``q`` at the parameters ``cuts``."""
    return tuple(int(k) for k in np.flatnonzero(np.isin(q, cuts)) if 0 < k < len(q) - 1)


def _barrel(curve: Shape, thickness: float, levels: np.ndarray, ring_params: list[np.ndarray],
            samples: list[list[_Samples]]) -> tuple[list[Voussoir], list[Joint]]:
    """The voussoirs and joints of rings stacked between the offsets ``levels`` (fractions of ``thickness`` from the
    intrados; ring r between levels r and r + 1), ring r's joints at the curve parameters ``ring_params[r]`` and its
    voussoirs sampled at ``samples[r]`` (:func:`_voussoir_samples`).

    1. Each level's sample parameters: the intrados its ring's samples, the extrados the outer ring's, an interface
       both rings' (:func:`_level_params`); an interface is split at both rings' joints and the kinks.
    2. Voussoirs ring by ring from the intrados (ids in that order), their edges the levels' points between their
       joints; the extrados on a kink's cap on its chord.
    3. Joints ring by ring (springings and voussoir joints, from the ring's intrados to its extrados), then the
       ring interfaces, one joint per piece between consecutive joints of either ring: its curve the level's points
       from the right end to the left, so that its normal points from the inner ring into the outer.
    """
    n = len(ring_params)
    kinks = np.asarray(curve.kinks, float)
    level_q = {r: _level_params(samples[r - 1:r + 1], ring_params[r - 1:r + 1], kinks) for r in range(1, n)}
    first = np.cumsum([0] + [len(p) - 1 for p in ring_params])  # the first voussoir id of each ring

    def point(q, level):
        return _ring_point(curve, thickness, q, levels[level])

    voussoirs = []
    for r, (params, ring_samples) in enumerate(zip(ring_params, samples)):
        for i, own in enumerate(ring_samples):
            pa, pb = params[i], params[i + 1]
            q_in = own.q if r == 0 else _between(level_q[r], pa, pb)
            q_out = own.q if r == n - 1 else _between(level_q[r + 1], pa, pb)
            extra = point(q_out, r + 1)
            if r == n - 1:
                for k, qk in enumerate(q_out):
                    extra[k] = own.chord.get(float(qk), extra[k])
            intra_splits = (tuple(np.flatnonzero(own.kink_at).tolist()) if r == 0
                            else _splits(q_in, np.concatenate([kinks, ring_params[r - 1]])))
            extra_splits = (tuple(np.flatnonzero(own.split_at).tolist()) if r == n - 1
                            else _splits(q_out, np.concatenate([kinks, ring_params[r + 1]])))
            voussoirs.append(Voussoir(int(first[r] + i), point(q_in, r), extra, intra_splits, extra_splits, r))
    joints: list[Joint] = []
    for r, params in enumerate(ring_params):
        last = len(params) - 1
        for j, pj in enumerate(params):
            joints.append(Joint(len(joints), point(pj, r), point(pj, r + 1),
                                int(first[r] + j - 1) if j > 0 else None, int(first[r] + j) if j < last else None,
                                kind="springing" if j in (0, last) else "voussoir"))
    for r in range(1, n):
        cuts = np.unique(np.concatenate(ring_params[r - 1:r + 1]))
        for qa, qb in zip(cuts[:-1], cuts[1:]):
            curve_pts = point(_between(level_q[r], qa, qb)[::-1], r)
            below = int(first[r - 1] + np.searchsorted(ring_params[r - 1], qa, side="right") - 1)
            above = int(first[r] + np.searchsorted(ring_params[r], qa, side="right") - 1)
            joints.append(Joint(len(joints), curve_pts[0], curve_pts[-1], below, above, kind="ring",
                                curve=curve_pts))
    return voussoirs, joints


def build_ring(shape: str, span: float, rise: float, thickness: float, n_voussoirs: int,
               load_x: list[float] = (), joint_at_loads: bool = True, load_labels: list[str] | None = None,
               ring_thicknesses: tuple[float, ...] = (), bond: str = "staggered") -> ArchRing:
    """Build the joints and voussoirs of a barrel of one or more rings (all lengths in m).

    ``load_x`` are the horizontal positions of concentrated loads and patch-load edges on the extrados;
    with ``joint_at_loads`` an interior joint is moved under each between the springings
    (:func:`_place_joints_at_loads`; a block straddling a concentrated load overstates the limit load); a load beyond
    a springing's intrados corner, on the extrados over a pier, gets a vertex only (a joint there would cut a sliver
    off the end voussoir). ``load_labels`` name the loads of ``load_x`` in the
    messages (default: their positions). ``ring_thicknesses`` (m, from the intrados out, summing to ``thickness``;
    empty: one ring) stack rings of ``n_voussoirs`` each: the outer ring's joints are those of a single ring of the
    whole thickness (moved under the loads), and with ``bond`` "staggered" every other ring inwards is shifted
    half a voussoir (:func:`_staggered`: one voussoir more, halves at the springings), with "aligned" its joints
    continue the outer ring's. Raises ValueError, naming the loads and what is allowed, when two load
    positions are closer than the ring can have an edge, when there are more load positions than interior joints
    to put under them, or when a joint moved under a load would leave a voussoir of (almost) no length.
    """
    if bond not in RING_BONDS:
        raise ValueError(f"ring bond {bond!r}: allowed are {', '.join(RING_BONDS)}")
    curve = make_shape(shape, span, rise)
    p = _samples(curve)
    s = _centreline_length(curve, thickness, p)

    def s_of_p(q):
        return np.interp(q, p, s)

    labels = _grouped_labels(load_x, load_labels)
    xs = np.unique(np.asarray(load_x, float))
    _check_load_spacing(xs, span, labels)
    located = [_extrados_param(curve, thickness, x) for x in xs]
    curve_params = [q for q, on_curve in located if on_curve]
    cap_x = [x for x, (_, on_curve) in zip(xs, located) if not on_curve]
    params = np.interp(np.linspace(0.0, s[-1], n_voussoirs + 1), s, p)
    params[0], params[-1] = 0.0, 1.0
    joints_at_x: frozenset[float] = frozenset()
    between = np.abs(xs) <= span / 2 * (1 + AT_JOINT_TOL)  # beyond the springings (over a pier): no joint
    if joint_at_loads and between.any():
        params, joints_at_x = _joints_at_loads(params, s_of_p, s[-1], xs[between],
                                               [pl for pl, keep in zip(located, between) if keep], labels)
    n = max(1, len(ring_thicknesses))
    levels = np.concatenate([[0.0], np.cumsum(ring_thicknesses) / thickness]) if n > 1 else np.array([0.0, 1.0])
    levels[-1] = 1.0
    shifted = _staggered(params, p, s) if bond == "staggered" else params
    ring_params = [shifted if (n - 1 - r) % 2 else params for r in range(n)]
    samples = [[_voussoir_samples(curve, thickness, span, pa, pb, *((curve_params, cap_x) if r == n - 1 else
                                                                     ([], [])))
                for pa, pb in zip(rp[:-1], rp[1:])] for r, rp in enumerate(ring_params)]
    voussoirs, joints = _barrel(curve, thickness, levels, ring_params, samples)
    return ArchRing(shape, span, rise, thickness, params, joints, voussoirs, joints_at_x=joints_at_x,
                    ring_thicknesses=tuple(float(t) for t in ring_thicknesses) if n > 1 else ())


def add_abutments(ring: ArchRing, height: float, length: float) -> ArchRing:
    """The barrel on elastic abutments: below each springing a block from the springing line (y = 0) down to
    y = -height (m), reaching ``length`` (m) outwards from the springing's intrados corner (at least to its
    extrados corner). Its top is the springing joints of every ring, then a free face at the extrados corner's
    level; its base is a new joint to the ground. Block and joint ids as in the module docstring."""
    joints = list(ring.joints)
    abutments = []
    for k, (side, outward) in enumerate(zip(("left", "right"), (-1.0, 1.0))):
        springings = ring.springings(side)
        inner, outer = springings[0].intrados, springings[-1].extrados
        x_out = inner[0] + outward * max(length, abs(outer[0] - inner[0]))
        base = (np.array([inner[0], -height]), np.array([x_out, -height]))
        # a corner above the outer base corner unless it is the springing's extrados corner (up to round-off)
        apart = abs(x_out - outer[0]) > ROUND_OFF * ring.span
        corners = [base[0], inner, *(j.extrados for j in springings)] + ([np.array([x_out, outer[1]])] if apart
                                                                          else [])
        polygon = np.array(corners + [base[1]])
        if polygon_area_centroid(polygon)[0] < 0:
            polygon = polygon[::-1]
        block = ring.n_blocks + k
        abutments.append(Abutment(block, polygon, side))
        for joint in springings:
            joints[joint.id] = dataclasses.replace(joint, left=block if joint.left is None else joint.left,
                                                   right=block if joint.right is None else joint.right)
        base_joint = Joint(len(joints), *base, None, None)
        ground_left = base_joint.normal[1] > 0  # the normal points up: from the ground into the block
        joints.append(dataclasses.replace(base_joint, left=None if ground_left else block,
                                          right=block if ground_left else None, kind="base", span=None))
    return dataclasses.replace(ring, joints=joints, abutments=abutments)


def joint_under(ring: ArchRing, x: float) -> int | None:
    """The interior joint whose extrados corner is at horizontal position x (m), within ``AT_JOINT_TOL`` x span,
    or None (springing corners do not count: a load there is on the end voussoir only)."""
    outer = {v.id for v in ring.outer_voussoirs}
    inner = [j for j in ring.joints if j.kind == "voussoir" and j.right in outer]
    if not inner:
        return None
    j = min(inner, key=lambda jt: abs(jt.extrados[0] - x))
    return j.id if abs(j.extrados[0] - x) <= AT_JOINT_TOL * ring.span else None


def point_load_blocks(ring: ArchRing, x: float, side: str = "split") -> tuple[int, ...]:
    """The voussoir(s) that carry a vertical point load at horizontal position x (m) on the extrados.

    A load off the joints is on the voussoir below it (on a pier's top: its top course). A load on a joint's
    extrados corner (:func:`joint_under`) is on the joint's ``side`` block ("left" | "right"), or half on each
    ("split"): the one choice the FE load vector and the rigid-block LP both take from here. Raises ValueError off
    the extrados or for an unknown side.
    """
    if side not in LOAD_SIDES:
        raise ValueError(f"load side {side!r}: allowed are {', '.join(LOAD_SIDES)}")
    j = joint_under(ring, x)
    if j is not None:
        left, right = ring.joints[j].left, ring.joints[j].right
        return {"left": (left,), "right": (right,), "split": (left, right)}[side]
    on = [b for b, line in ring.top_pieces if line[0, 0] <= x <= line[-1, 0]]
    if not on:
        raise ValueError(f"point load at x = {x:g} m is not above the ring's extrados")
    return (on[0],)
