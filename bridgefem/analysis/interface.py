"""The arch-fill interface at a converged state: the forces the fill exerts on the ring, and the ring's rigid-block
LP under the loads the fill transmits, a lower-bound check of an FE limit with a fill and, under an elastic fill,
the search's collapse state (evidence 5 of :mod:`bridgefem.analysis.evidence`).

Forces are in N for the scene's width, x to the right and y up; levels in N per unit load factor. The interface's
joint forces are nodal forces (the multipliers of the interface pairs), so the rows of :func:`interface_forces`
balance the ring's nodes exactly: the ring receives ``-(lam_n n + lam_t tau)`` at each interface pair, with n the
pair's normal from the ring into the fill and tau that normal turned +90 degrees.

The check (:func:`ring_under_transmitted_loads`):

1. read the interface forces F_S at the settled state (live load 0) and F_L at a converged level P_L;
2. load the ring's rigid-block LP (:func:`bridgefem.limit.ring_blocks.ring_under_forces`) with the dead load ring
   weight + F_S and the live load (F_L - F_S) / P_L;
3. solve it (associative friction, on rank 0): its collapse level lambda.

The FE state at P_L balances every voussoir with joint forces that obey no tension and Coulomb friction pair by
pair, so it is statically admissible for that LP: lambda >= P_L, up to the LP's polygonal voussoirs against the mesh
(the static theorem, Livesley 1978). When the FE limit is a mechanism of the ring (the fill only passes loads on),
the ring under F_L is itself at collapse and lambda ~ P_L; lambda well above P_L means that the fill carried the rest
by changing how it loads the ring (its stiffness or strength restrains the mechanism).

The run reads it at its last converged state (:func:`transmitted_load_check`); under an elastic fill the search
reads it at every converged live-load state (:func:`fill_collapse_check`).

Safeguard: *the ring-side node check*: every interface pair's ring-side node must lie on the extrados, else the
forces would be put on the wrong voussoir; a mismatch raises instead.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dolfinx import fem

from ..fe.mesh import EXTRADOS_TAG, BlockMesh
from ..fe.model import node_blocks
from ..fe.pairs import ARCH_FILL, JointPairs
from ..limit.rigid_block import LPResult, solve_blocks
from ..limit.ring_blocks import ring_under_forces
from ..scene.model import Scene
from ..search.records import CollapseCheck
from ..solver.newton import ContactSolver, Iterate
from ..status import RINGS_UNDER_FILL
from .result import Analysis, TransmittedLoadCheck


@dataclass
class InterfaceForces:
    """What the fill exerts on the ring across the arch-fill interface at one converged state: one row per interface
    pair, identical on every rank, sorted by x. ``points`` (k, 2): the ring-side node (m); ``blocks`` (k,): the
    voussoir it belongs to; ``forces`` (k, 2): the force on that node (N, x and y, whole width); ``normal`` (k,):
    the interface's compression lam_n (N, >= 0); ``shear`` (k,): lam_t (N), the force on the fill along the pair's
    tangent (its normal, from the ring into the fill, turned +90 degrees). The ring receives
    ``-(lam_n n + lam_t tau)``: the multipliers are nodal forces, so these rows balance the ring's nodes exactly."""

    points: np.ndarray
    blocks: np.ndarray
    forces: np.ndarray
    normal: np.ndarray
    shear: np.ndarray


def interface_forces(solver: ContactSolver, pairs: JointPairs, V: fem.FunctionSpace, bm: BlockMesh, it: Iterate
                     ) -> InterfaceForces:
    """The arch-fill interface forces on the ring at a converged iterate of the ``solver`` with the joint ``pairs``,
    the displacement space ``V`` and the mesh ``bm`` (collective; empty without a fill)."""
    comm = solver.comm
    imap = V.dofmap.index_map
    n_owned = imap.size_local
    facets = bm.facet_tags.indices[bm.facet_tags.values == EXTRADOS_TAG]
    nodes = fem.locate_dofs_topological(V, 1, facets)
    nodes = nodes[nodes < n_owned]
    node_block = node_blocks(V, bm)
    coords = V.tabulate_dof_coordinates()[:, :2]
    table = np.vstack(comm.allgather(np.column_stack([imap.local_to_global(nodes.astype(np.int32)), coords[nodes],
                                                      node_block[nodes]])))
    table = table[np.argsort(table[:, 0])]
    _, lam, _ = solver.system.split(it.x)
    on = pairs.joint == ARCH_FILL
    local = np.column_stack([pairs.left[on], pairs.normal[on], pairs.tangent[on], lam[on]])
    rows = np.vstack(comm.allgather(local))
    at = np.searchsorted(table[:, 0], rows[:, 0]) if len(table) else np.zeros(0, int)
    if len(rows) and not np.array_equal(table[np.minimum(at, len(table) - 1), 0], rows[:, 0]):
        raise RuntimeError("arch-fill interface: a ring-side node is not on the extrados")
    ring_rows = table[at]
    forces = -(rows[:, 5:6] * rows[:, 1:3] + rows[:, 6:7] * rows[:, 3:5])
    order = np.argsort(ring_rows[:, 1], kind="stable")
    return InterfaceForces(ring_rows[order, 1:3], ring_rows[order, 3].astype(int), forces[order],
                           rows[order, 5], rows[order, 6])


def ring_under_transmitted_loads(scene: Scene, solver: ContactSolver, pairs: JointPairs, V: fem.FunctionSpace,
                                 bm: BlockMesh, settled: Iterate, state: Iterate, level: float,
                                 friction_model: str = "associative") -> TransmittedLoadCheck:
    """The scene's rings under the loads the fill transmits (module docstring, steps 1-3): the interface forces
    (:func:`interface_forces`, the model's ``solver``, ``pairs``, space ``V`` and mesh ``bm``) at the ``settled``
    state and at the converged ``state`` at ``level`` (N per unit load factor, > 0). The LP on rank 0, broadcast
    (collective); an LP that fails is reported in ``lp.status`` ("LP failed: ...")."""
    dead, live = (interface_forces(solver, pairs, V, bm, it) for it in (settled, state))
    out = None
    if solver.comm.rank == 0:
        increment = (live.forces - dead.forces) / level  # N per unit load level
        model = ring_under_forces(scene, dead.blocks, dead.points, dead.forces, increment)
        try:
            lp = solve_blocks(model, friction_model)
        except RuntimeError as err:  # a check, never the reason a run fails: report it
            lp = LPResult(None, None, f"LP failed: {err}", friction_model)
        out = TransmittedLoadCheck(level, lp.level, lp.level / level if lp.level is not None else None, lp)
    return solver.comm.bcast(out, root=0)


def transmitted_load_check(an: Analysis, friction_model: str = "associative") -> TransmittedLoadCheck | None:
    """The ring under the loads the fill transmits at the run's last converged state, a lower-bound check of the FE
    limit with a fill (:func:`ring_under_transmitted_loads`; collective); None without a fill, a live load or a
    converged live-load step above 0."""
    s = an.search
    if an.scene.fill is None or not an.scene.loads or s.settled is None or s.last is None or not s.lower > 0:
        return None
    return ring_under_transmitted_loads(an.scene, an.solver, an.pairs, an.model.V, an.block_mesh, s.settled, s.last,
                                        s.lower, friction_model)


def fill_collapse_check(scene: Scene, solver: ContactSolver, pairs: JointPairs, V: fem.FunctionSpace, bm: BlockMesh,
                        tolerance: float, unit: float) -> CollapseCheck | None:
    """Evidence 5 of :mod:`bridgefem.analysis.evidence` for the search
    (:class:`bridgefem.search.records.CollapseCheck`, ``at_collapse``): under an elastic fill with live loads, a
    converged state at ``level`` is a collapse state by itself when the rings under the loads the fill transmits
    there (:func:`ring_under_transmitted_loads`, from the settled state) collapse at a level lambda of at most (1 +
    ``tolerance``) x ``level``; the check in words (``unit``: N of live load per unit level). No estimate of the
    limit and no closing-trial rule (the defaults). None without a fill, with a plastic fill (whose own yielding the
    flat curve shows) or without live loads. Collective."""
    if scene.fill is None or solver.material is not None or not scene.loads:
        return None

    def at_collapse(level: float, state: Iterate, settled: Iterate) -> tuple[bool, str]:
        check = ring_under_transmitted_loads(scene, solver, pairs, V, bm, settled, state, level)
        if check.lp_level is None:
            return False, f"{RINGS_UNDER_FILL}: {check.lp.status}"
        return check.lp_level <= (1 + tolerance) * level, (
            f"{RINGS_UNDER_FILL} (rigid-block LP, associative friction) collapse at "
            f"{check.lp_level * unit / 1e3:.6g} kN, {check.ratio:.7f} x the load")

    return CollapseCheck(at_collapse=at_collapse)
