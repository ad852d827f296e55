"""A scene's ring: the blocks and joints its keys describe, built in one place for every model, and the loads'
names and moves for messages and results.

:func:`scene_ring` reads ``[arch]`` (shape, span, rise, thickness, voussoirs, joint_at_loads), or the ``[[span]]``
and ``[[pier]]`` tables of a bridge of several spans, the horizontal positions of the point loads and patch edges
(:meth:`bridgefem.scene.model.Scene.load_edges_x`) and ``[abutments]``, and

1. builds each span's barrel of voussoirs and joints (:func:`bridgefem.geometry.ring.build_ring`), with a joint
   moved under each load on its extrados when ``joint_at_loads`` asks for it;
2. with several spans, places them on their piers in one frame (:func:`bridgefem.geometry.bridge.build_bridge`),
   a vertex on a pier's top under each load over it;
3. with elastic abutments, adds the two abutment blocks and their base joints on the ground
   (:func:`bridgefem.geometry.ring.add_abutments`).

The FE model (:mod:`bridgefem.fe.mesh` meshes this ring), the rigid-block LP (:mod:`bridgefem.limit.ring_blocks`)
and the conic bounds (:mod:`bridgefem.limit.bounds_model`) all take their ring from here, so that the LP checks the
FE on the same joints. Lengths in m; coordinates, numbering and the joints' left/right blocks as in
:mod:`bridgefem.geometry.ring` and :mod:`bridgefem.geometry.bridge`: one ring of N voussoirs has voussoirs 0 .. N - 1
and joints 0 (left springing) .. N (right springing); the abutments are the last two blocks (left, then right) with
the last two joints their bases. A load layout the geometry cannot honour raises
:class:`~bridgefem.scene.keys.SceneError` naming the loads in words (:func:`load_labels`), as any other bad value of a
scene. A point load that acts at the corner of a joint it was not given (within ``AT_JOINT_TOL`` x span of it) is
reported, never silent (:func:`snapped_loads`).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..geometry.bridge import PierShape, build_bridge
from ..geometry.ring import AT_JOINT_TOL, ArchRing, add_abutments, build_ring, joint_under
from ..geometry.shapes import make_shape
from ..scene.keys import SceneError
from ..scene.model import Scene


def load_labels(scene: Scene) -> list[str]:
    """The loads of :meth:`Scene.load_edges_x` in words, in the same order, e.g. "[[load]] #2 (point at x = -1.5 m)"
    and "the left edge of [[load]] #1 (patch over x = -2..-1 m)": what a message about their positions names."""
    out = []
    for i, ld in enumerate(scene.loads):
        a, b = ld.x_range(scene.arch.span)
        if ld.kind == "point":
            out.append(f"[[load]] #{i + 1} (point at x = {a:.9g} m)")
        else:
            out += [f"the {edge} edge of [[load]] #{i + 1} (patch over x = {a:.9g}..{b:.9g} m)"
                    for edge in ("left", "right")]
    return out


def scene_ring(scene: Scene, thickness: float | None = None) -> ArchRing:
    """The joints and blocks of a scene (one source for the FE model and the LP); ``thickness`` (m) overrides the
    ring's (every span's, scaled alike). Raises SceneError when the loads cannot have the joints and edges they need
    (:func:`build_ring`) or a pier is too narrow for its spans' springings
    (:func:`bridgefem.geometry.bridge.build_bridge`)."""
    ab = scene.abutments
    edges, labels = scene.load_edges_x(), load_labels(scene)
    barrels, on_spans, centres = [], set(), []
    try:
        for a, (left, right) in zip(scene.arches, scene.span_ranges()):
            centre = 0.5 * (left + right)
            centres.append(centre)
            t = a.thickness if thickness is None else thickness * (a.thickness / scene.arch.thickness)
            reach = abs(t * make_shape(a.shape, a.span, a.rise).normal(0.0)[0])  # to the extrados corner
            mine = [k for k, x in enumerate(edges) if left - reach <= x <= right + reach]
            on_spans.update(mine)
            barrels.append(build_ring(a.shape, a.span, a.rise, t, a.voussoirs, [edges[k] - centre for k in mine],
                                      a.joint_at_loads, [labels[k] for k in mine],
                                      tuple(r * t / a.thickness for r in a.ring_layers), a.ring_bond))
        ring = barrels[0] if len(barrels) == 1 else build_bridge(barrels, [
            PierShape(p.width, p.height, p.batter, p.blocks) for p in scene.piers], centres,
            [x for k, x in enumerate(edges) if k not in on_spans])
    except ValueError as err:
        raise SceneError(str(err)) from None
    return add_abutments(ring, ab.height, ab.length) if ab.elastic else ring


@dataclass(frozen=True)
class SnappedLoad:
    """A point load that acts at the extrados corner of a joint it did not get (within ``AT_JOINT_TOL`` x span of
    it, :func:`joint_under`): scene load ``index`` (from 0) given at horizontal position ``x`` (m), moved to the
    corner of joint ``joint`` at ``corner`` (m)."""

    index: int
    x: float
    joint: int
    corner: float

    @property
    def moved_by(self) -> float:
        """How far (m) the load was moved."""
        return abs(self.corner - self.x)

    def notice(self, span: float) -> str:
        """One line for the console: the load, its given position, the joint, the distance moved (m), what to
        change to keep the load where it was given."""
        return (f"[[load]] #{self.index + 1} (point at x = {self.x:.9g} m) is {self.moved_by:.3g} m from joint "
                f"{self.joint}'s extrados corner (x = {self.corner:.9g} m), within {AT_JOINT_TOL:g} x span = "
                f"{AT_JOINT_TOL * span:.3g} m: it is moved onto the joint, on the side where it is least favourable "
                "(results.json: loads); farther from the corner it stays on its own voussoir")


def snapped_loads(scene: Scene, ring: ArchRing) -> list[SnappedLoad]:
    """The scene's point loads that act at a joint's corner they were moved onto: within ``AT_JOINT_TOL`` x span of
    the corner of a joint that was not moved under them (``joint_at_loads = false``, or a load on the pointed crown's
    cap next to the apex), a load gets no mesh node of its own (its edge would be a sliver) and acts at the corner,
    carried by the voussoir where it is least favourable. That can move the limit load by several per cent, so it is
    reported, never silent. Over a fill the loads act on the road and none is moved."""
    if scene.fill is not None:
        return []
    out = []
    for i, ld in enumerate(scene.loads):
        x = ld.x_range(scene.arch.span)[0]
        j = joint_under(ring, x) if ld.kind == "point" and x not in ring.joints_at_x else None
        if j is not None:
            out.append(SnappedLoad(i, x, j, float(ring.joints[j].extrados[0])))
    return out
