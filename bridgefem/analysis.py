"""The FE limit analysis of a scene: scene -> ring -> mesh -> elastic model -> joint pairs -> solver -> search.

Also reads the collapse mechanism off the last converged state: per joint the resultant normal force N (N,
compression positive), shear V (N), eccentricity e (m, from the joint centre, positive towards the extrados)
and the open part of its length. A *hinge* is a cracked joint (open over at least half its length, or with
its thrust within 1 % of the length from a face: with one element through the thickness a joint has only two
pairs) whose |e| is the largest of its run of consecutive such joints (the thrust line touches the ring there); it sits at the
intrados when e < 0 and at the extrados when e > 0 (for an abutment's base: at its inner and outer edge); a run
only continues through joints that share a block. A *sliding* joint has every closed pair slipping one way.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from mpi4py import MPI

from .abutments import scene_ring, support_motion
from .contact import ARCH_FILL, OPEN, SLIP, JointPairs, build_pairs, ground_offsets
from .fill import PlasticFill
from .geometry import ArchRing, fill_outline
from .mesh import BlockMesh, build_block_mesh
from .model import ElasticModel, build_elastic_model
from .pathfollow import LimitSearch, LoadStep, find_limit_load, monitor_deflection
from .scene import Scene, SceneError
from .solver import ContactSolver, Iterate

HINGE_OPEN_FRACTION = 0.5  # a hinge joint is open over at least this fraction of its length,
HINGE_ECCENTRICITY = 0.49  # or its thrust is this close to a face (fraction of its length from the centre)
FORCE_TOL = 1e-10  # contact-state hysteresis as a fraction of the ring's weight (N/N)


@dataclass
class JointState:
    """Resultants and state of one joint at the last converged step (forces in N, lengths in m)."""

    id: int
    normal_force: float
    shear_force: float
    eccentricity: float
    open_fraction: float
    sliding: int
    hinge: str = ""


@dataclass
class Analysis:
    """Everything a run produced; ``timings`` in seconds per phase."""

    scene: Scene
    ring: ArchRing
    block_mesh: BlockMesh
    model: ElasticModel
    pairs: JointPairs
    solver: ContactSolver
    search: LimitSearch
    joints: list[JointState]
    timings: dict = field(default_factory=dict)

    @property
    def load_total(self) -> float:
        """Total live load (N) per unit load level (1 without live loads)."""
        return sum(ld.factor for ld in self.scene.loads) or 1.0

    @property
    def n_dofs(self) -> int:
        return self.solver.N


def run_analysis(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD, petsc_options: dict | None = None,
                 report: Callable[[LoadStep], None] = lambda s: None) -> Analysis:
    """Compute the limit load of a scene: the ring, with its fill and elastic abutments when the scene has them,
    after the support movement it imposes (collective over ``comm``)."""
    timings = {}
    t = time.perf_counter()

    def lap(name):
        nonlocal t
        now = time.perf_counter()
        timings[name] = comm.allreduce(now - t, op=MPI.MAX)
        t = now

    a = scene.arch
    try:
        ring = scene_ring(scene)
    except ValueError as err:
        raise SceneError(f"[arch] voussoirs = {a.voussoirs}: {err}") from None
    fill = scene.fill
    outline = (fill_outline(ring, fill.depth, fill.extension, scene.load_edges_x()) if fill is not None else None)
    lap("geometry")
    bm = build_block_mesh(ring, scene.mesh.elements_through_thickness, comm, outline,
                          fill.element_size if fill is not None else 0.0)
    lap("mesh")
    model = build_elastic_model(bm, ring, scene)
    lap("assembly")
    pairs = build_pairs(model.V, bm, ring, match_tol=1e-9 * a.span)
    lap("pairing")
    young, friction = pair_properties(scene, ring, pairs)
    c = young * a.width * pairs.length / bm.element_size  # Alart-Curnier constant: the softer side's stiffness
    material = PlasticFill(model.V, bm, scene, model.bcs) if fill and fill.material == "mohr-coulomb" else None
    motion = support_motion(scene, ring)
    solver = ContactSolver(model.K, model.f_dead, model.f_live, pairs, friction, c,
                           FORCE_TOL * model.dead_weight, scene.solver.max_iterations,
                           {**scene.solver.petsc, **(petsc_options or {})}, material, ground_offsets(pairs, motion))
    lap("solver setup")
    s = scene.solver
    search = find_limit_load(solver, monitor_deflection(solver, model.monitor), tolerance=s.tolerance,
                             initial_step=s.initial_step or model.dead_weight / 4,
                             max_load=(s.max_load or 100 * model.dead_weight) if scene.loads else 0.0,
                             max_steps=s.max_steps, guess_scene=scene,
                             stiffness_drop=s.stiffness_drop if fill is not None else 0.0,
                             movement_steps=scene.abutments.movement_steps if motion else 0, report=report)
    lap("limit search")
    joints = joint_states(solver, pairs, ring, search.last) if search.last is not None else []
    return Analysis(scene, ring, bm, model, pairs, solver, search, joints, timings)


def pair_properties(scene: Scene, ring: ArchRing, pairs: JointPairs) -> tuple[np.ndarray, np.ndarray]:
    """Per local pair: the Young's modulus (Pa) of the softer side and the Coulomb coefficient. Ring joints:
    the masonry's and the joints' mu; on elastic abutments the springing and base joints take the softer of
    masonry and abutment, and the bases the abutments' mu; the arch-fill interface: the fill's."""
    young = np.full(len(pairs), scene.masonry.young)
    friction = np.full(len(pairs), scene.joints.friction)
    ab, fill = scene.abutments, scene.fill
    if ab.elastic:
        bases = [j.id for j in ring.bases]
        young[np.isin(pairs.joint, [j.id for j in ring.springings] + bases)] = min(ab.young, scene.masonry.young)
        friction[np.isin(pairs.joint, bases)] = ab.friction
    if fill is not None:
        interface = pairs.joint == ARCH_FILL
        young[interface], friction[interface] = fill.young, fill.interface_friction
    return young, friction


def joint_states(solver: ContactSolver, pairs: JointPairs, ring: ArchRing, it: Iterate) -> list[JointState]:
    """Per-joint resultants, hinges and sliding at a converged iterate (identical on every rank)."""
    _, lam, _ = solver.split(it.x)
    local = np.column_stack([pairs.joint, lam, pairs.position, pairs.length, it.active.state, it.active.sign])
    table = np.vstack(solver.comm.allgather(local))
    states = []
    for jt in (j for j in ring.joints if not j.free):
        rows = table[table[:, 0] == jt.id]
        lam_n, lam_t, pos, length, st, sign = rows[:, 1], rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5], rows[:, 6]
        n_force = lam_n.sum()
        ecc = float((lam_n * (pos - jt.length / 2)).sum() / n_force) if n_force > 0 else 0.0
        closed = st != OPEN
        slip_signs = set(sign[closed & (st == SLIP)])
        sliding = int(slip_signs.pop()) if closed.any() and np.all(st[closed] == SLIP) and len(slip_signs) == 1 else 0
        states.append(JointState(jt.id, float(n_force), float(lam_t.sum()), ecc,
                                 float(length[~closed].sum() / length.sum()), sliding))
    _mark_hinges(states, ring)
    return states


def springing_reactions(joints: list[JointState], ring: ArchRing) -> np.ndarray:
    """Force (N; x, y) of the ground on the structure at each joint on the ground, rows in joint order: the
    springings on rigid abutments, the abutments' bases on elastic ones.

    A joint's resultant (normal force along its normal, shear along its tangent) acts on its right face, so
    the ground pushes the ring with +resultant where the ground is the left block and -resultant otherwise.
    """
    out = []
    for js in joints:
        jt = ring.joints[js.id]
        if jt.left is None or jt.right is None:
            force = js.normal_force * jt.normal + js.shear_force * jt.tangent
            out.append(force if jt.left is None else -force)
    return np.array(out)


def _mark_hinges(states: list[JointState], ring: ArchRing) -> None:
    cracked = [s.open_fraction >= HINGE_OPEN_FRACTION
               or abs(s.eccentricity) >= HINGE_ECCENTRICITY * ring.joints[s.id].length for s in states]

    def adjacent(a: JointState, b: JointState) -> bool:
        blocks = {ring.joints[a.id].left, ring.joints[a.id].right} & {ring.joints[b.id].left, ring.joints[b.id].right}
        return bool(blocks - {None})

    run: list[JointState] = []
    for s, c in zip(states + [None], cracked + [False]):
        if c and run and adjacent(s, run[-1]) and np.sign(s.eccentricity) == np.sign(run[-1].eccentricity):
            run.append(s)
            continue
        if run:
            best = max(run, key=lambda r: abs(r.eccentricity) / ring.joints[r.id].length)
            best.hinge = "extrados" if best.eccentricity > 0 else "intrados"
        run = [s] if c else []
