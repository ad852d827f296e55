"""The FE model of a scene, built for a limit analysis: scene -> ring -> mesh -> rigid-block LP -> elastic model ->
joint pairs -> contact solver (:func:`bridgefem.analysis.runner.run_analysis`).

Units: N, m, Pa; the Alart-Curnier constants in N/m per pair. Each phase is announced (``phase(name)``) and timed,
as the slowest rank's wall time (:class:`Clock`).

1. *Geometry*: the ring's voussoirs, joints and abutments (:func:`bridgefem.structure.ring.scene_ring`), and with a
   fill its outline (:func:`bridgefem.geometry.ring.fill_outline`).
2. *Mesh*: one mesh per block, with coincident nodes on both faces of every joint
   (:func:`bridgefem.fe.mesh.build_block_mesh`), and the loading beams of patch loads on a fill
   (:func:`loading_beams`).
3. *Rigid-block LP* on the same joints (:func:`bridgefem.analysis.checks.rigid_block_check`): built here because it
   decides on which side of a joint a load on that joint sits, before the loads are assembled.
4. *Assembly*: the elastic stiffness, the dead loads and the live loads per unit level
   (:func:`bridgefem.fe.model.build_elastic_model`).
5. *Pairing*: the joints' node pairs (:func:`bridgefem.fe.pairs.build_pairs`, coincident up to 1e-9 of the span),
   each with the Young's modulus of its softer block (:func:`bridgefem.structure.materials.block_materials`) and its
   Coulomb coefficient (:func:`pair_properties`), and the
   Alart-Curnier constant c = E w l / h (w the width, l the pair's tributary length, h the element size).
6. *Solver*: the contact solver (:class:`bridgefem.solver.newton.ContactSolver`) with the plastic fill
   (:class:`bridgefem.fe.fill.PlasticFill`) and the ground's offsets of a support movement
   (:func:`bridgefem.structure.supports.support_motion`); its first factorisation.

Safeguards:

- *Ring joints' constant* ``RING_JOINT_SCALE``: the Alart-Curnier constant only weighs forces against displacements
  when the active set is classified, never what counts as converged; the smaller weight at the ring's joints failed
  less often and cost fewer solves (docs/robustness.md).
- *State hysteresis* ``FORCE_TOL``: the joint law classifies with a hysteresis of that fraction of the ring's
  weight, so that pairs carrying no force do not chatter between states
  (:meth:`bridgefem.laws.coulomb.CoulombJoints.classify`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from mpi4py import MPI

from ..fe.fill import PlasticFill
from ..fe.mesh import BlockMesh, build_block_mesh
from ..fe.model import ElasticModel, build_elastic_model
from ..fe.pairs import ARCH_FILL, JointPairs, build_pairs, ground_offsets
from ..geometry.ring import ArchRing, fill_outline
from ..laws.base import JointLaw
from ..laws.coulomb import CoulombJoints
from ..laws.crushing import scene_law_factory
from ..limit.rigid_block import LPResult
from ..scene.model import Scene
from ..solver.newton import ContactSolver
from ..structure.materials import BlockMaterials, block_materials
from ..structure.ring import scene_ring
from ..structure.supports import support_motion
from .checks import rigid_block_check
from .stress_block import joint_nodes

FORCE_TOL = 1e-10  # contact-state hysteresis as a fraction of the ring's weight (N/N)
RING_JOINT_SCALE = 0.1  # Alart-Curnier constant of the ring's joints, of E w L / h (module docstring)


JointLawFactory = Callable[[JointPairs, np.ndarray, np.ndarray, float], JointLaw]
"""Builds the joint law of a run from its pairs, their Coulomb coefficients, Alart-Curnier constants (N/m) and the
hysteresis (N) (:class:`bridgefem.laws.base.JointLaw`)."""
DEFAULT_JOINT_LAW = CoulombJoints  # the joints' law of a scene without a compressive strength (its ``for_pairs``
# builds it); with one, :class:`bridgefem.laws.crushing.CrushingJoints` (:func:`scene_law_factory`)


@dataclass
class Clock:
    """The wall time (s) of each phase of a run, the slowest rank's, from the clock's creation on. Collective."""

    comm: MPI.Comm
    timings: dict = field(default_factory=dict)
    start: float = field(default_factory=time.perf_counter)

    def lap(self, name: str) -> None:
        """Time the phase ``name``, which ends now (collective)."""
        now = time.perf_counter()
        self.timings[name] = self.comm.allreduce(now - self.start, op=MPI.MAX)
        self.start = now


@dataclass
class BridgeModel:
    """The FE model of a scene (module docstring): its ``ring``, ``block_mesh``, elastic ``model``, joint ``pairs``
    and contact ``solver``, and the rigid-block ``lp`` on the same joints."""

    ring: ArchRing
    block_mesh: BlockMesh
    lp: LPResult
    model: ElasticModel
    pairs: JointPairs
    solver: ContactSolver


def build_model(scene: Scene, comm: MPI.Comm, petsc_options: dict | None, phase: Callable[[str], None],
                clock: Clock, joint_law: JointLawFactory | None = None) -> BridgeModel:
    """The FE model of ``scene`` (module docstring, steps 1-6) on ``comm``, with the ``petsc_options`` over the
    scene's and the joints' law that ``joint_law`` builds (the scene's when None: :func:`scene_law_factory`); ``phase(name)``
    announces each phase, ``clock`` times it. Raises SceneError for voussoirs the ring
    cannot have. Collective."""
    a = scene.arch
    ring = scene_ring(scene)  # SceneError naming the loads when they cannot have their joints
    fill = scene.fill
    outline = (fill_outline(ring, fill.depth, fill.extension, scene.load_edges_x()) if fill is not None else None)
    clock.lap("geometry")
    phase("meshing")
    nodes = joint_nodes(scene, comm)  # with crushing: the joints graded for the stress block
    bm = build_block_mesh(ring, scene.mesh.elements_through_thickness, comm, outline,
                          fill.element_size if fill is not None else 0.0, loading_beams(scene), nodes)
    clock.lap("mesh")
    lp = rigid_block_check(scene, comm, nodes, ring)  # the search's guess, the verdict's evidence, a load's side on a joint
    clock.lap("rigid-block LP")
    phase("assembling")
    model = build_elastic_model(bm, ring, scene, lp.load_sides if fill is None and lp.load_sides else None)
    clock.lap("assembly")
    phase("pairing the joints")
    pairs = build_pairs(model.V, bm, ring, match_tol=1e-9 * a.span)  # coincident joint nodes, up to round-off
    clock.lap("pairing")
    materials = block_materials(scene, ring)
    young, friction = pair_properties(scene, pairs, ring, materials)
    c = young * a.width * pairs.length / bm.element_size  # Alart-Curnier constant: the softer side's stiffness,
    c[pairs.joint != ARCH_FILL] *= RING_JOINT_SCALE  # scaled down at the ring's joints (see the constant)
    material = (PlasticFill(model.V, bm, scene, model.bcs, materials) if fill and fill.material == "mohr-coulomb"
                else None)
    motion = support_motion(scene, ring)
    phase("setting up the solver (first factorisation)")
    law = (joint_law or scene_law_factory(scene))(pairs, friction, c, FORCE_TOL * model.dead_weight)
    solver = ContactSolver(model.K, model.f_dead, model.f_live, pairs, law, scene.solver.max_iterations,
                           {**scene.solver.petsc, **(petsc_options or {})}, material, ground_offsets(pairs, motion))
    clock.lap("solver setup")
    return BridgeModel(ring, bm, lp, model, pairs, solver)


def loading_beams(scene: Scene) -> tuple[tuple[float, float], ...]:
    """The x-ranges (m) of the loading beams: one per patch load on a fill with ``[fill] loading_beam`` (the scene
    keeps them apart), none otherwise."""
    if scene.fill is None or not scene.fill.loading_beam:
        return ()
    return tuple(sorted(ld.x_range(scene.arch.span) for ld in scene.loads if ld.kind == "patch"))



def pair_properties(scene: Scene, pairs: JointPairs, ring: ArchRing, materials: BlockMaterials
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Per local pair: the Young's modulus (Pa) of the softer of its joint's two blocks (``materials``; a joint on
    the ground: its block's) and the Coulomb coefficient: the joints' mu, the ring friction on ring interfaces
    (``[joints] ring_friction``), the abutments' on their bases; on the arch-fill interface the fill's modulus and
    interface friction."""
    friction = np.where(pairs.kind == "ring", scene.joints.ring_interface_friction, scene.joints.friction)
    ab, fill = scene.abutments, scene.fill
    if ab.elastic:
        friction[pairs.kind == "base"] = ab.friction
    softer = np.array([min(materials.young[b] for b in (j.left, j.right) if b is not None) for j in ring.joints])
    interface = pairs.joint == ARCH_FILL
    young = np.where(interface, fill.young if fill is not None else 0.0, softer[np.where(interface, 0, pairs.joint)])
    if fill is not None:
        friction[interface] = fill.interface_friction
    return young, friction
