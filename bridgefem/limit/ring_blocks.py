"""The scene's ring as rigid blocks: the :class:`~bridgefem.limit.rigid_block.BlockModel` that the rigid-block LP,
the collapse loads, the least thickness and the conic bounds solve.

The blocks are the voussoirs of :func:`bridgefem.structure.ring.scene_ring` (then the two elastic abutments, when
the scene has them), and the joints are the ring's joints: the same layout as the FE mesh, so that the LP checks
the FE on the same joints (Gilbert & Melbourne 1994, *Rigid-block analysis of masonry structures*, The Structural
Engineer 72(21):356, the RING model of a ring of voussoirs). Units: m, N and N·m for the scene's whole width;
x to the right, y up, moments counter-clockwise; loads act downwards (-y).

:func:`ring_model` builds the model in five steps:

1. the ring: :func:`~bridgefem.structure.ring.scene_ring` (a ``thickness`` may override the scene's);
2. the blocks: each voussoir (pier course, abutment) polygon, its centroid the block's reference point, its weight
   ``unit weight x area x width`` (N; :func:`bridgefem.structure.materials.block_materials`) acting there;
3. a fill, if any, as dead load only (:func:`_overburden`): on each voussoir the weight of the fill column above
   its extrados, through the column's centroid; the fill's strength, stiffness and load spreading are ignored;
4. the live loads for a unit load factor (:func:`live_loads`): ``factor`` N per load, a point load at the extrados
   point above it, a patch uniform per horizontal metre over its x-range and shared by the voussoirs under it; a
   point load exactly above a joint acts at the joint's extrados corner, on the voussoir its side names;
5. the joints from intrados (``joint_a``) to extrados (``joint_b``), their normal from the left block into the right
   one; the ring's joints take the scene's friction, the abutments' bases the abutments' friction; a ring
   interface (curved) is its chords (``BlockModel.joint_ids`` maps them back), each an *interface* piece that never
   crushes, with the ring friction and the shear capacity ``ring_cohesion x chord length x width`` (N) at no
   normal force (``BlockModel.cohesion``).

Two variants load the same blocks with the FE's own forces, for the FE's checks: :func:`ring_under_forces` (the
forces a fill transmits across the arch-fill interface) and :func:`ring_with_loads` (the FE's assembled block
loads).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..geometry.ring import ArchRing, joint_under, point_load_blocks, polygon_area_centroid
from ..laws.base import JointLaw
from ..laws.crushing import scene_law
from ..scene.model import Scene
from ..structure.materials import block_materials
from ..structure.ring import scene_ring
from .rigid_block import BlockModel, generalised_loads


def ring_model(scene: Scene, thickness: float | None = None, load_at_joint: str | tuple[str, ...] = "split",
               live: bool = True, law: type[JointLaw] | JointLaw | None = None, ring: ArchRing | None = None
               ) -> BlockModel:
    """The voussoirs of a scene's ring as a :class:`~bridgefem.limit.rigid_block.BlockModel` (the FE model's joint
    layout).

    Self-weight ``density g area width`` (N) acts at each voussoir centroid (the reference point). Live loads are
    vertical, downward, ``factor`` N per unit load factor: a point load at the extrados point above its x, a patch
    uniform per horizontal metre over its x-range. A point load exactly above a joint acts at the joint's extrados
    corner and is carried as :func:`bridgefem.geometry.ring.point_load_blocks` says for its side: ``load_at_joint`` is
    one side ("left" | "right" | "split") for every load, or one per scene load (patches ignore theirs).
    ``thickness`` overrides the scene's; ``live=False`` drops the live loads. A scene's fill enters as dead load
    only (:func:`_overburden`). Elastic abutments are two more rigid blocks (``unit_weight area width`` at their
    centroids) with their base joints on the ground (the abutments' friction); a support movement is not modelled
    (it does not change the collapse load of rigid blocks). ``law``: the joints' law (default the scene's,
    :func:`bridgefem.laws.crushing.scene_law`). ``ring``: the scene's ring when the caller has built it already
    (:func:`bridgefem.structure.ring.scene_ring` of ``scene``, not given with ``thickness``); None: built here.
    """
    a = scene.arch
    sides = (load_at_joint,) * len(scene.loads) if isinstance(load_at_joint, str) else tuple(load_at_joint)
    if len(sides) != len(scene.loads):
        raise ValueError(f"load_at_joint: {len(sides)} sides for {len(scene.loads)} loads")
    if ring is not None and thickness is not None:
        raise ValueError("ring_model: give the ring or a thickness to build it with, not both")
    ring = ring or scene_ring(scene, thickness)
    ref = np.array([polygon_area_centroid(b.polygon)[1] for b in ring.blocks])
    nb = len(ref)
    dead = generalised_loads(ref, np.arange(nb), ref, np.column_stack([np.zeros(nb), -block_weights(scene, ring)]))
    if scene.fill is not None:
        dead = dead + _overburden(ring, scene, ref)
    live_pattern = live_loads(scene, ring, ref, sides) if live else np.zeros((nb, 3))
    friction = {"base": scene.abutments.friction, "ring": scene.joints.ring_interface_friction}
    pieces = [(j, a, b) for j in ring.joints for a, b in zip(*j.chords)]  # a ring interface: its curve's chords
    joint_a, joint_b = np.array([a for _, a, _ in pieces]), np.array([b for _, _, b in pieces])
    interface = np.array([j.kind == "ring" for j, _, _ in pieces])
    return BlockModel(
        ref=ref, dead=dead, live=live_pattern, joint_a=joint_a, joint_b=joint_b,
        joint_left=np.array([-1 if j.left is None else j.left for j, _, _ in pieces]),
        joint_right=np.array([-1 if j.right is None else j.right for j, _, _ in pieces]),
        friction=np.array([friction.get(j.kind, scene.joints.friction) for j, _, _ in pieces]),
        law=scene_law(scene) if law is None else law,
        **({} if not interface.any() else dict(
            joint_ids=np.array([j.id for j, _, _ in pieces]), interface=interface,
            cohesion=np.where(interface, scene.joints.ring_cohesion * a.width
                              * np.linalg.norm(joint_b - joint_a, axis=1), 0.0))))


def block_weights(scene: Scene, ring) -> np.ndarray:
    """(nb,) the weight (N) of each block of ``ring``, voussoirs, pier courses then abutments (step 2 of the module
    docstring): its unit weight (:func:`bridgefem.structure.materials.block_materials`) x polygon area x the arch's
    width."""
    area = np.array([polygon_area_centroid(b.polygon)[0] for b in ring.blocks])
    return block_materials(scene, ring).unit_weight * scene.arch.width * area


def live_loads(scene: Scene, ring, ref: np.ndarray, sides: tuple[str, ...]) -> np.ndarray:
    """(nb, 3) generalised live loads (Fx, Fy in N; M in N·m about ``ref``) of a scene's loads for a unit load
    factor on the voussoirs of ``ring`` (step 4 of the module docstring); ``sides``: one per scene load, the side
    ("left" | "right" | "split") that carries it when it is a point load on a joint."""
    parts = load_forces(scene, ring, sides)
    if not parts:
        return np.zeros((len(ref), 3))
    blocks, points, forces = (np.concatenate(x) for x in zip(*parts))
    return generalised_loads(ref, blocks, points, forces)


def load_forces(scene: Scene, ring, sides: tuple[str, ...]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per scene load, the vertical forces it puts on the outer ring's voussoirs (and a pier's top course, for a load
    over a pier) for a unit load factor (step 4 of the module docstring): (blocks (k,), points (k, 2) on the extrados
    in m, forces (k, 2) in N); ``sides`` as in :func:`live_loads`."""
    top = ring.top_pieces  # the outer voussoirs' extrados, and the piers' tops between spans
    ext = np.vstack([line for _, line in top])
    ids = np.array([b for b, _ in top])
    x0 = np.array([line[0, 0] for _, line in top])  # block ids[k] spans x0[k]..x1[k] on the extrados
    x1 = np.array([line[-1, 0] for _, line in top])
    out = []
    for ld, side in zip(scene.loads, sides):
        lo, hi = ld.x_range(scene.arch.span)
        if ld.kind == "point":
            on = np.array(point_load_blocks(ring, lo, side))
            j = joint_under(ring, lo)
            x = np.full(len(on), lo if j is None else ring.joints[j].extrados[0])
            fy = np.full(len(on), -ld.factor / len(on))
        else:
            left, right = np.maximum(x0, lo), np.minimum(x1, hi)
            k = np.nonzero(right > left)[0]
            on, x = ids[k], 0.5 * (left[k] + right[k])
            fy = -ld.factor * (right[k] - left[k]) / (hi - lo)
        out.append((on, np.column_stack([x, np.interp(x, ext[:, 0], ext[:, 1])]),
                    np.column_stack([np.zeros(len(fy)), fy])))
    return out


def ring_under_forces(scene: Scene, blocks, points, dead_forces, live_forces) -> BlockModel:
    """The scene's ring (the joints and blocks of :func:`ring_model`, its self-weight; without the fill's overburden
    and without the scene's live loads) loaded by given nodal forces instead of a fill.

    ``blocks`` (k,): the voussoir each force acts on; ``points`` (k, 2): where (m); ``dead_forces`` (k, 2): forces
    (N, x and y, whole width) added to the dead load; ``live_forces`` (k, 2): the live load for a unit load factor
    (N per unit factor). With the forces a fill transmits across the arch-fill interface at two states of an FE
    analysis (:func:`bridgefem.analysis.interface.transmitted_load_check`) this is the ring as the FE sees it: the fill
    then needs no model of its own, whatever its stiffness or strength.
    """
    model = ring_model(dataclasses.replace(scene, fill=None), live=False)
    blocks = np.asarray(blocks, int)
    return dataclasses.replace(model, dead=model.dead + generalised_loads(model.ref, blocks, points, dead_forces),
                               live=generalised_loads(model.ref, blocks, points, live_forces))


def ring_with_loads(model: BlockModel, dead: np.ndarray, live: np.ndarray) -> BlockModel:
    """The blocks and joints of ``model`` (e.g. :func:`ring_model`) under given block loads instead of its own:
    ``dead``, ``live`` (nb, 3) Fx, Fy (N) and M (N·m, counter-clockwise) about ``model.ref``, ``live`` for a unit
    load level, e.g. the FE's assembled self-weight and live load
    (:func:`bridgefem.analysis.static_bound.block_loads`): the rigid blocks loaded as the FE's meshed voussoirs are."""
    return dataclasses.replace(model, dead=np.asarray(dead, float), live=np.asarray(live, float))


def _overburden(ring, scene: Scene, ref: np.ndarray) -> np.ndarray:
    """The fill as dead load only: on each voussoir (and each pier's top course) the weight (N) of the fill column
    between its extrados (its top) and the road, vertical, through the column's centroid on the extrados. The
    fill's strength, stiffness and load spreading are ignored (live loads still act on the extrados below them)."""
    road = ring.crown_extrados + scene.fill.depth
    w = scene.fill.unit_weight * scene.arch.width
    points, forces = [], []
    top = ring.top_pieces  # the outer voussoirs' extrados, and the piers' tops between spans
    for _, line in top:
        x, h = line[:, 0], road - line[:, 1]
        area = np.trapz(h, x)
        xc = np.trapz(x * h, x) / area
        points.append(ring.extrados_point(xc))
        forces.append((0.0, -w * area))
    return generalised_loads(ref, np.array([b for b, _ in top]), np.array(points), np.array(forces))
