"""The collapse mechanism read off a converged state: per-joint resultants, hinges and sliding joints, the ground's
reactions, and the voussoirs' rigid motion (:func:`bridgefem.analysis.runner.run_analysis` reads them at the last
converged step).

Units and signs: forces in N for the scene's width, compression positive; lengths in m; rotations in rad,
anticlockwise. A joint's resultant (normal force N along its normal, shear V along its tangent) acts on its right
face; its eccentricity e is measured from the joint's centre, positive towards the extrados.

1. *Resultants* (:func:`joint_states`): per joint, N and V are the sums of its pairs' multipliers, e = sum(lam_n
   (p - L/2)) / N with p a pair's place from the intrados and L the joint's length, and the open part of its length
   is the tributary length of its open pairs.
   *Crushing* (a law with a compressive strength, :meth:`bridgefem.laws.base.JointLaw.crushed`): the crushed part of
   a joint is the tributary length of its crushed pairs (their normal force at the law's bound), its compressed depth
   that of its closed pairs (the compressed zone of a hinge), and its stress-block depth N / (f_c w) the depth of the
   rectangular stress block at the strength f_c over the width w that carries N
   (:meth:`bridgefem.laws.base.JointLaw.stress_block_depth`).
2. *Hinges* (:func:`_mark_hinges`), on voussoir joints, springings and bases: a joint is *cracked* when it is open over at least ``HINGE_OPEN_FRACTION`` of
   its length or its thrust lies within ``1/2 - HINGE_ECCENTRICITY`` of the length from a face (with one element
   through the thickness a joint has only two pairs, so the opening alone cannot say it). Consecutive cracked joints
   that share a block and whose thrusts lie on the same side form a run; the hinge is the joint of the run with the
   largest |e| (the thrust line touches the ring there), at the intrados when e < 0 and at the extrados when e > 0
   (for an abutment's base: at its inner and outer edge). A ring interface is never a hinge: it is *separated*
   when it is open over at least ``HINGE_OPEN_FRACTION`` of its length.
3. *Sliding* (:func:`joint_states`): a joint slides when every closed pair of it slips, all the same way.
4. *Reactions* (:func:`springing_reactions`): the ground's force on the structure at each joint on the ground.
5. *Rigid motion* (:func:`voussoir_motion`, :func:`collapse_mode`): the least-squares rigid motion of each block
   under a displacement field; over the last converged increment it shows how the mechanism starts.

Safeguard: *hinge tie* ``HINGE_TIE``: eccentricities that agree within that fraction of the length (thrusts on the
edge pair) tie, and the larger opening wins, so that rounding never picks the hinge.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fe.mesh import BlockMesh
from ..fe.model import ElasticModel, node_blocks
from ..fe.pairs import JointPairs
from ..geometry.ring import ArchRing
from ..solver.newton import ContactSolver, Iterate

HINGE_OPEN_FRACTION = 0.5  # a hinge joint is open over at least this fraction of its length,
HINGE_ECCENTRICITY = 0.49  # or its thrust is this close to a face (fraction of its length from the centre)
HINGE_TIE = 1e-6  # eccentricities (fraction of the length) that agree this closely tie; the largest opening wins


@dataclass
class JointState:
    """Resultants and state of one joint at a converged step (module docstring; forces in N, lengths in m):
    ``eccentricity`` of the thrust from the joint's centre, ``open_fraction`` of its length, ``opening`` the largest
    normal gap of its pairs (0 when closed), ``sliding`` the sense of the slip of a sliding joint (+1 or -1, the
    pairs' slip sign; 0: not sliding), ``hinge`` "intrados", "extrados" or "" (no hinge); ``crushed_fraction`` of its
    length whose pairs are crushed (0..1; 0 without a compressive strength), ``compressed_depth`` (m) the length of
    its closed pairs (those that carry compression: a hinge's compressed zone), ``stress_block_depth`` (m) N / (f_c w),
    the depth of the stress block at the compressive strength f_c over the width w that carries N (None without a
    strength); ``separated``: a ring interface open over at least ``HINGE_OPEN_FRACTION`` of its length."""

    id: int
    normal_force: float
    shear_force: float
    eccentricity: float
    open_fraction: float
    opening: float
    sliding: int
    hinge: str = ""
    crushed_fraction: float = 0.0
    compressed_depth: float = 0.0
    stress_block_depth: float | None = None
    separated: bool = False


def joint_states(solver: ContactSolver, pairs: JointPairs, ring: ArchRing, it: Iterate) -> list[JointState]:
    """Per-joint resultants, hinges, sliding and crushing at a converged iterate (identical on every rank)."""
    _, lam, d = solver.system.split(it.x)
    law = solver.law
    local = np.column_stack([pairs.joint, lam, pairs.position, pairs.length, law.closed(it.active),
                             law.sliding(it.active), it.active.sign, d[:, 0], law.crushed(it.active)])
    table = np.vstack(solver.comm.allgather(local))
    states = []
    for jt in (j for j in ring.joints if not j.free):
        rows = table[table[:, 0] == jt.id]
        lam_n, lam_t, pos, length, closed, slips, sign, gap, crushed = rows[:, 1:10].T
        n_force = lam_n.sum()
        ecc = float((lam_n * (pos - jt.length / 2)).sum() / n_force) if n_force > 0 else 0.0
        closed, slips, crushed = closed.astype(bool), slips.astype(bool), crushed.astype(bool)
        slip_signs = set(sign[closed & slips])
        sliding = int(slip_signs.pop()) if closed.any() and np.all(slips[closed]) and len(slip_signs) == 1 else 0
        states.append(JointState(jt.id, float(n_force), float(lam_t.sum()), ecc,
                                 float(length[~closed].sum() / length.sum()), float(gap[~closed].max(initial=0.0)),
                                 sliding, crushed_fraction=float(length[crushed].sum() / length.sum()),
                                 compressed_depth=float(length[closed].sum()),
                                 stress_block_depth=law.stress_block_depth(n_force)))
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
    """Set ``hinge`` on the joint of each run of cracked joints in ``states`` (in joint order) whose thrust is the
    most eccentric, and ``separated`` on the open ring interfaces (module docstring, step 2)."""
    for s in states:
        s.separated = ring.joints[s.id].kind == "ring" and s.open_fraction >= HINGE_OPEN_FRACTION
    cracked = [ring.joints[s.id].kind != "ring" and (s.open_fraction >= HINGE_OPEN_FRACTION
               or abs(s.eccentricity) >= HINGE_ECCENTRICITY * ring.joints[s.id].length) for s in states]

    def adjacent(a: JointState, b: JointState) -> bool:
        blocks = {ring.joints[a.id].left, ring.joints[a.id].right} & {ring.joints[b.id].left, ring.joints[b.id].right}
        return bool(blocks - {None})

    run: list[JointState] = []
    for s, c in zip(states + [None], cracked + [False]):
        if c and run and adjacent(s, run[-1]) and np.sign(s.eccentricity) == np.sign(run[-1].eccentricity):
            run.append(s)
            continue
        if run:
            best = max(run, key=lambda r: (round(abs(r.eccentricity) / ring.joints[r.id].length / HINGE_TIE),
                                           r.opening))
            best.hinge = "extrados" if best.eccentricity > 0 else "intrados"
        run = [s] if c else []


def voussoir_motion(model: ElasticModel, block_mesh: BlockMesh, ring: ArchRing, u: np.ndarray) -> np.ndarray:
    """Least-squares rigid motion (ux m, uy m, rotation rad, anticlockwise) of each block (voussoirs, abutments,
    then the fill) under the owned displacement dofs ``u`` (m), one row per block (collective)."""
    V, bm = model.V, block_mesh
    n_owned = V.dofmap.index_map.size_local
    n_blocks = ring.n_blocks + (bm.fill_block is not None)  # the same on every rank
    blk = node_blocks(V, bm)[:n_owned]
    x = V.tabulate_dof_coordinates()[:n_owned, :2]
    u = u[:2 * n_owned].reshape(-1, 2)
    comm = V.mesh.comm

    def total(w):
        return comm.allreduce(np.bincount(blk, weights=w, minlength=n_blocks))

    count = total(np.ones(len(blk)))
    xc = np.column_stack([total(x[:, 0]), total(x[:, 1])]) / count[:, None]
    r = x - xc[blk]
    theta = total(r[:, 0] * u[:, 1] - r[:, 1] * u[:, 0]) / total((r ** 2).sum(axis=1))
    mean_u = np.column_stack([total(u[:, 0]), total(u[:, 1])]) / count[:, None]
    return np.column_stack([mean_u - np.column_stack([-theta * xc[:, 1], theta * xc[:, 0]]), theta])


def collapse_mode(model: ElasticModel, block_mesh: BlockMesh, ring: ArchRing, converged: list[np.ndarray]
                  ) -> np.ndarray | None:
    """The blocks' rigid motion over the last converged increment of live load (the motion the mechanism starts
    with; :func:`voussoir_motion` rows), from the owned displacement dofs of the ``converged`` states in order (m),
    or over the whole path when only one state converged; None without a converged state. Collective."""
    if not converged:
        return None
    last = converged[-1]
    before = converged[-2] if len(converged) > 1 else np.zeros_like(last)
    return voussoir_motion(model, block_mesh, ring, last - before)
