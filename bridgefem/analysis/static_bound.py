"""The static (lower-bound) theorem on a bare ring's FE (evidence 4 of :mod:`bridgefem.analysis.evidence`): the FE's
loads and pair forces read as the rigid-block LP's block loads and joint forces on the same joints (Livesley 1978).
Forces in N, moments in N·m (counter-clockwise), lengths in m; levels in N per unit load factor.

1. *Block loads* (:func:`block_loads`, :func:`fe_blocks`): the FE's assembled self-weight and unit live load summed
   per block, as resultants about each block's reference point: the LP's ring loaded as the FE loads its voussoirs.
2. *The bound* (:func:`static_cap`): that LP's collapse level, an upper bound on every FE equilibrium, and under
   self-weight its blocks' deficit of joint tension and cohesion against the largest one a converged FE state's
   tolerances can hide (``StaticBound.margin``); solved on rank 0.
3. *The check* (:func:`static_cap`'s ``admissible``): a converged state's joint resultants (:func:`joint_resultants`)
   against the LP's rows within the FE's own tolerances (:func:`bridgefem.analysis.evidence.admissible`), run by the
   search before it ends on the bound.

Safeguard: *waived pairs refused* (step 3): a state with frozen or bonded pairs bends the joint law there and is no
premise of the theorem, so the check refuses it and the search goes on without the bound.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..fe.mesh import BlockMesh
from ..fe.model import ElasticModel, node_blocks
from ..fe.pairs import JointPairs
from ..geometry.ring import ArchRing
from ..laws.crushing import scene_law
from ..limit.rigid_block import BlockModel, LPResult, generalised_loads, solve_blocks, standing_deficit, statics
from ..limit.ring_blocks import ring_model, ring_with_loads
from ..scene.model import Scene
from ..search.records import LoadStep, StaticCap
from ..solver.convergence import BOND_RTOL, EQUILIBRIUM_RTOL
from ..solver.newton import ContactSolver, Iterate
from ..status import Status
from .evidence import StaticBound, admissible


def static_cap(blocks: BlockModel, model: ElasticModel, bm: BlockMesh, pairs: JointPairs, solver: ContactSolver
               ) -> tuple[StaticBound, StaticCap] | None:
    """The static theorem's bound on a bare ring's FE (module docstring, steps 2 and 3): the rigid-block LP on the
    same joints under the FE's own block loads, ``blocks`` (:func:`fe_blocks`), its dead-load deficit against the
    largest one a converged FE state's tolerances can hide, and the check of a converged state's joint resultants
    against the LP's rows (:func:`bridgefem.analysis.evidence.admissible`) that the search runs before it ends on the
    bound. The bound caps every search (no FE equilibrium exists above it); whether the bracket it closes is also the
    limit of the exact voussoirs' weights is the evidence rule's question (:mod:`bridgefem.analysis.evidence`,
    evidence 4). The LP on rank 0, broadcast; None when it fails (no bound). Collective."""
    comm = solver.comm
    pairs_per_joint = comm.allreduce(np.bincount(pairs.joint[pairs.joint >= 0], minlength=blocks.n_joints))
    nodes, radius = block_extents(model, bm, blocks.ref)
    delta = 10 * solver.law.force_tol  # the complementarity residual of a converged pair (N)
    t = blocks.frames()[0]

    def f_scale(level: float) -> float:  # the largest applied nodal force (N), the solver's scale
        local = np.abs(model.f_dead.array + level * model.f_live.array).max(initial=0.0)
        return comm.allreduce(float(local), op=MPI.MAX)

    sigma_max = pairs_per_joint.max(initial=0) * (delta + BOND_RTOL * f_scale(0.0))  # every pair waived
    margin = max(2.0, 1.0 + float(blocks.friction.max(initial=0.0))) * sigma_max
    out = None
    if comm.rank == 0:
        try:
            deficit = standing_deficit(blocks)  # the dead loads alone
            fe_lp = solve_blocks(blocks) if deficit <= margin else LPResult(None, None, Status.UNSTABLE)
            out = StaticBound(fe_lp.level, fe_lp.status, float(deficit), float(margin))
        except (RuntimeError, ValueError):  # no LP answer: no bound
            out = None
    static = comm.bcast(out, root=0)

    def check(step: LoadStep, it: Iterate) -> tuple[bool, str]:
        waived = step.counts.get("frozen", 0) + step.counts.get("bonded", 0)  # the same on every rank
        if waived:
            return False, f"the joint law is waived (frozen or bonded) at {waived} of the pairs"
        forces = joint_resultants(solver, pairs, blocks, it)
        sigma = np.maximum(pairs_per_joint * delta, np.finfo(float).tiny)
        block_force = np.maximum(nodes * EQUILIBRIUM_RTOL * f_scale(step.level), np.finfo(float).tiny)
        result = None
        if comm.rank == 0:
            result = admissible(statics(blocks, step.level, forces), sigma, blocks.friction, t, block_force,
                                2 * radius * block_force)
        return comm.bcast(result, root=0)

    if static is None:
        return None
    return static, StaticCap(static.level, static.falls, check)


def fe_blocks(scene: Scene, model: ElasticModel, bm: BlockMesh, ring: ArchRing | None = None) -> BlockModel:
    """The rigid-block LP's ring on the scene's joints loaded as the FE loads its voussoirs: its assembled
    self-weight and unit live load summed per block (:func:`block_loads`); with a compressive strength its joints'
    rows are the FE's pairs' own polygon on the mesh's joint nodes (:func:`bridgefem.laws.crushing.fe_stations`).
    ``ring``: the scene's ring when the caller has built it already (None: built here). Collective."""
    blocks = dataclasses.replace(ring_model(scene, live=False, ring=ring),
                                 law=scene_law(scene, fe=True, nodes=bm.joint_nodes))
    return ring_with_loads(blocks, *block_loads(model, bm, blocks.ref))


def joint_resultants(solver: ContactSolver, pairs: JointPairs, blocks: BlockModel, it: Iterate) -> np.ndarray:
    """Per joint of ``blocks`` the resultant of the FE's pair forces at an iterate as the LP's joint forces (nj, 3):
    n, s (N) along the joint's normal and tangent, the force on its right block, and m (N·m) = -(moment about the
    joint's centre), the LP's convention (:mod:`bridgefem.limit.rigid_block`); joints without pairs carry none. Every
    pair acts at its place on the joint, ``position`` from the intrados (on a ring interface: on the chord of the
    piece that holds it, :meth:`bridgefem.limit.rigid_block.BlockModel.pieces_at`). Identical on every rank
    (collective)."""
    _, lam, _ = solver.system.split(it.x)
    ring = pairs.joint >= 0
    local = np.column_stack([pairs.joint, lam, pairs.position, pairs.normal, pairs.tangent])[ring]
    table = np.vstack(solver.comm.allgather(local))
    joint, position = blocks.pieces_at(table[:, 0].astype(int), table[:, 3])  # a ring interface: its chords
    lam_n, lam_t = table[:, 1], table[:, 2]
    force = lam_n[:, None] * table[:, 4:6] + lam_t[:, None] * table[:, 6:8]  # on the right face (N)
    _, centre, tangent, normal = blocks.frames()
    arm = blocks.joint_a[joint] + position[:, None] * table[:, 6:8] - centre[joint]
    moment = arm[:, 0] * force[:, 1] - arm[:, 1] * force[:, 0]
    size = blocks.n_joints
    return np.column_stack([np.bincount(joint, (force * normal[joint]).sum(axis=1), size),
                            np.bincount(joint, (force * tangent[joint]).sum(axis=1), size),
                            -np.bincount(joint, moment, size)])


def _ring_nodes(model: ElasticModel, bm: BlockMesh, n_blocks: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """This rank's owned nodes on the ring's ``n_blocks`` blocks (voussoirs, abutments): the block of each, their
    coordinates (m, (n, 2)) and the mask that picks them among the owned nodes."""
    V = model.V
    n_owned = V.dofmap.index_map.size_local
    blk = node_blocks(V, bm)[:n_owned]
    on = (blk >= 0) & (blk < n_blocks)
    return blk[on], V.tabulate_dof_coordinates()[:n_owned, :2][on], on


def block_extents(model: ElasticModel, bm: BlockMesh, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per block of the ring (voussoirs, abutments): its number of nodes and its radius about ``ref`` (nb, 2), the
    largest distance of its nodes from that point (m). Collective."""
    comm = model.V.mesh.comm
    blk, x, _ = _ring_nodes(model, bm, len(ref))
    distance = np.linalg.norm(x - ref[blk], axis=1)
    radius = np.zeros(len(ref))
    np.maximum.at(radius, blk, distance)
    return comm.allreduce(np.bincount(blk, minlength=len(ref))), np.max(comm.allgather(radius), axis=0)


def block_loads(model: ElasticModel, bm: BlockMesh, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The FE's self-weight and unit live load on each block of the ring (voussoirs, abutments) as resultants
    (nb, 3): Fx, Fy (N) and M (N·m, counter-clockwise) about ``ref`` (nb, 2), the sums of the assembled nodal
    forces (the self-weight's are the exact voussoirs' weights and lines of action,
    :func:`bridgefem.fe.model.block_weight_shape`; the live load's as the mesh's faces apply it). Collective."""
    comm = model.V.mesh.comm
    blk, x, on = _ring_nodes(model, bm, len(ref))

    def resultants(vec: PETSc.Vec) -> np.ndarray:
        return comm.allreduce(generalised_loads(ref, blk, x, vec.array[:2 * len(on)].reshape(-1, 2)[on]))

    return resultants(model.f_dead), resultants(model.f_live)
