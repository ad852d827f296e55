"""The rigid-block checks of an FE limit analysis: the rigid-block LP on the same joints (the search's guess and the
verdict's evidence), and the non-associative checks of a converged state with sliding joints (evidence 3 of
:mod:`bridgefem.analysis.evidence`), at the end of the search and at its converged states.

Levels in N per unit load factor, forces in N. Every LP is solved on rank 0 and broadcast, so each function here is
collective; an LP that fails is a check that confirms nothing, never the reason a run fails.

1. *The LP* (:func:`rigid_block_check`): the scene's ring as rigid blocks on the same joints with associative
   friction (Livesley 1978; Gilbert & Melbourne 1994): its collapse level is the search's guess, its verdict the
   evidence of rule 2, and it decides on which side of a joint a load on that joint sits.
2. *The frozen LP* (:func:`frozen_collapse`): the rigid blocks loaded as the FE loads its voussoirs, each joint's
   shear capacity frozen at mu x the FE's normal force there; the sliding joints of its mechanism whose FE forces
   are at their Coulomb limit against the slip.
3. *The slip check* (:func:`slip_check`, :func:`slip_state`): for an unproven limit with sliding joints that the
   associative LP does not confirm, the frozen LP at the last converged state, the same under the scene's exact
   voussoir weights, and the Tresca fixed point from it (Gilbert, Casapulla & Ahmed 2006); on a barrel of rings the
   frozen LPs on the FE's own blocks and pairs (:class:`PairCheck`).
4. *The collapse check* (:func:`collapse_check`): the frozen LP at each converged state of the search, for its
   *Collapse state* rule (:mod:`bridgefem.search.target`).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from mpi4py import MPI

from ..fe.pairs import JointPairs
from ..geometry.ring import ArchRing
from ..laws.crushing import scene_law
from ..limit.collapse import collapse_load, collapse_state_from, sided_ring
from ..limit.contacts import PointContacts, frozen_contact_collapse
from ..limit.rigid_block import BlockModel, LPResult, frozen_capacity_collapse, solve_blocks
from ..scene.model import Scene
from ..search.records import CollapseCheck, LimitSearch
from ..solver.newton import ContactSolver, Iterate
from ..status import Status
from .evidence import AGREEMENT, SlipCheck, coulomb_limited, needs_slip_check
from .mechanism import JointState, joint_states


def rigid_block_check(scene: Scene, comm: MPI.Comm, nodes: tuple[float, ...] | None = None,
                      ring: ArchRing | None = None) -> LPResult:
    """The rigid-block LP of the scene's ring on the same joints (:func:`bridgefem.limit.collapse.collapse_load`,
    associative friction; with a compressive strength the rows of the FE's joint stations on the element ends
    ``nodes``, :func:`bridgefem.laws.crushing.fe_stations`), solved on rank 0 and broadcast: the search's guess and
    the evidence for its verdict. An LP that fails gives the status "LP failed: ..." (no guess, no evidence).
    ``ring``: the scene's ring when the caller has built it already (None: built here)."""
    lp = None
    if comm.rank == 0:
        try:
            lp = collapse_load(scene, law=scene_law(scene, fe=True, nodes=nodes), ring=ring)  # crushing: the FE's joints
        except (RuntimeError, ValueError) as err:  # the LP is a check: its failure is reported, not raised
            lp = LPResult(None, None, f"LP failed: {err}")
    return comm.bcast(lp, root=0)


def slip_check(scene: Scene, comm: MPI.Comm, search: LimitSearch, lp: LPResult, joints: list[JointState],
               blocks: BlockModel | None, contacts: PairCheck | None) -> SlipCheck | None:
    """The non-associative rigid-block check (:func:`slip_state`) of an unproven limit with sliding joints that the
    associative LP does not confirm (:func:`bridgefem.analysis.evidence.needs_slip_check`), from the joint forces of
    the last converged step on the rigid ``blocks`` loaded as the FE loads them (None with a fill: no check).
    On a barrel of rings (blocks whose joints are pieces of the FE's: a ring interface's chords, :func:`per_piece`)
    the check is on the FE's own pairs (``contacts``, :class:`PairCheck`), and it is needed where any pair slides (a
    curved ring interface slides with some of its pairs, seldom with all). Elsewhere it is needed where a joint
    slides or carries its Coulomb capacity (:func:`coulomb_loaded`). Collective; None when no check is needed."""
    if not per_piece(blocks) and contacts is None:
        return None
    if contacts is not None:
        slides = search.last is not None and contacts.slides(search.last)
    else:
        slides = any(j.sliding for j in joints) or coulomb_loaded(joints, blocks)
    if not needs_slip_check(search.status, search.lower, search.upper, search.proved, lp.status, lp.level,
                            scene.fill is not None, slides):
        return None
    return contacts.state(search.last) if contacts is not None else slip_state(scene, comm, lp, joints, blocks)


def coulomb_loaded(joints: list[JointState], blocks: BlockModel) -> bool:
    """Whether a joint of a converged state carries its Coulomb capacity, |shear| >= (1 - ``AGREEMENT``) mu x its
    normal force (> 0): a non-associative collapse state can hold a joint at its limit while a pair of it sticks, so
    that the joint does not count as sliding (:func:`bridgefem.analysis.mechanism.joint_states`)."""
    return any(j.normal_force > 0 and abs(j.shear_force) >= (1 - AGREEMENT) * blocks.friction[j.id] * j.normal_force
               for j in joints)


def slip_state(scene: Scene, comm: MPI.Comm, lp: LPResult, joints: list[JointState], blocks: BlockModel,
               fixed_point: bool = True) -> SlipCheck:
    """The non-associative rigid-block check of a converged state's ``joints`` (evidence 3 of
    :mod:`bridgefem.analysis.evidence`): the rigid ``blocks`` loaded as the FE loads its voussoirs
    (:func:`bridgefem.analysis.static_bound.fe_blocks`) with their shear capacities frozen at the joints' friction x
    normal force (:func:`frozen_collapse`) and, with ``fixed_point``, the Tresca fixed point from them (its LPs are the
    check's dearest; none of evidence 3's rules asks for it), and the frozen LP under the scene's own block loads
    (:func:`bridgefem.limit.collapse.collapse_state_from`).
    The LPs on rank 0, broadcast (collective)."""
    sliding = tuple(j.id for j in joints if j.sliding)
    out = None
    if comm.rank == 0:
        try:
            normal, frozen, limited = frozen_collapse(joints, blocks)
            fixed = (solve_blocks(blocks, "non-associative", seed=normal) if fixed_point
                     else LPResult(None, None, "not computed", converged=False, iterations=0))
            exact = collapse_state_from(scene, normal, lp.load_sides, max_iterations=1)
            out = SlipCheck(sliding, frozen.level, tuple(frozen.sliding), tuple(frozen.hinges), limited,
                            exact.level, fixed.converged, fixed.level, tuple(fixed.sliding), tuple(fixed.hinges),
                            fixed.iterations)
        except (RuntimeError, ValueError):  # a check that fails confirms nothing
            out = SlipCheck(sliding, None, (), (), (), None, False, None, (), (), 0)
    return comm.bcast(out, root=0)


def per_piece(blocks: BlockModel | None) -> bool:
    """Whether the FE's joint states are the ``blocks``' joints one for one, as the frozen LP needs them: not without
    blocks (a fill), nor where a joint is several LP joints (a ring interface's chords, whose normal forces the FE's
    resultant of the whole joint does not give)."""
    return blocks is not None and blocks.joint_ids is None


def frozen_collapse(joints: list[JointState], blocks: BlockModel) -> tuple[np.ndarray, LPResult, tuple[int, ...]]:
    """The ``blocks`` with each joint's shear capacity frozen at mu x its normal force in ``joints``
    (:func:`bridgefem.limit.rigid_block.frozen_capacity_collapse`): the normal forces (N per joint), the LP's result
    and those of its sliding joints where the joints' forces are at their Coulomb limit against the slip
    (:func:`bridgefem.analysis.evidence.coulomb_limited`). Raises RuntimeError or ValueError when the LP fails."""
    normal, shear = np.zeros(blocks.n_joints), np.zeros(blocks.n_joints)
    ids = [j.id for j in joints]
    normal[ids], shear[ids] = [j.normal_force for j in joints], [j.shear_force for j in joints]
    frozen = frozen_capacity_collapse(blocks, normal)
    limited = () if frozen.level is None else coulomb_limited(normal, shear, blocks.friction, frozen.joint_slip,
                                                               frozen.sliding)
    return normal, frozen, limited


class PairCheck:
    """Evidence 3 on a barrel of rings, whose ring interfaces are curves that the LP's joints cut into chords: the
    frozen LP on the FE's own joint pairs (:func:`bridgefem.limit.contacts.frozen_contact_collapse`), each block of
    the mesh rigid, each pair a point contact with its shear capacity frozen at the joint law's at the FE's normal
    force there. The blocks are loaded as the FE loads them (``blocks``' loads, :func:`bridgefem.analysis.static_bound
    .fe_blocks`) and, for the exact voussoirs' weights, as the scene's blocks are with the LP's load sides
    (:func:`bridgefem.limit.collapse.sided_ring`). A joint of the structure slides in the mechanism where its pairs do
    more than ``AGREEMENT`` of the mechanism's friction dissipation, and is at its Coulomb limit where the FE's shears
    do all but ``AGREEMENT`` of its pairs' share (:meth:`bridgefem.limit.contacts.ContactCollapse.shortfall`): a
    degenerate programme's mechanism may slide a pair or two elsewhere at rates that change its level by far less
    than the bracket's width. The pairs' geometry is gathered once, on rank 0. Collective."""

    def __init__(self, scene: Scene, comm: MPI.Comm, lp: LPResult, blocks: BlockModel, solver: ContactSolver,
                 pairs: JointPairs, ring: ArchRing):
        self.comm, self.solver, self.pairs, self.ring = comm, solver, pairs, ring
        local = np.column_stack([pairs.joint, pairs.point, pairs.normal, pairs.tangent, pairs.block])
        table = comm.gather(local, root=0)
        self.joint, self.fe, self.exact = None, None, None
        if comm.rank == 0:
            table = np.vstack(table)
            self.joint = table[:, 0].astype(int)
            geometry = dict(point=table[:, 1:3], normal=table[:, 3:5], tangent=table[:, 5:7],
                            left=table[:, 7].astype(int), right=table[:, 8].astype(int))
            self.fe = PointContacts(blocks.ref, blocks.dead, blocks.live, **geometry)
            exact = sided_ring(scene, lp.load_sides, ring)
            self.exact = PointContacts(exact.ref, exact.dead, exact.live, **geometry)

    @classmethod
    def of(cls, scene: Scene, comm: MPI.Comm, lp: LPResult, blocks: BlockModel | None, solver: ContactSolver,
           pairs: JointPairs, ring: ArchRing) -> "PairCheck | None":
        """The check of a barrel of rings whose LP found a limit; None elsewhere (a bare ring's joints are the
        LP's: :func:`per_piece`)."""
        if blocks is None or per_piece(blocks) or lp.status != Status.LIMIT or lp.level is None:
            return None
        return cls(scene, comm, lp, blocks, solver, pairs, ring)

    def slides(self, state: Iterate) -> bool:
        """Whether any pair slides at the converged ``state``. Collective."""
        return self.comm.allreduce(bool(self.solver.law.sliding(state.active).any()), op=MPI.LOR)

    def state(self, state: Iterate) -> SlipCheck:
        """The frozen LPs at the converged ``state`` (under the FE's and the scene's exact block loads), as a
        :class:`bridgefem.analysis.evidence.SlipCheck` without the Tresca fixed point. Collective."""
        joints = joint_states(self.solver, self.pairs, self.ring, state)
        sliding = tuple(j.id for j in joints if j.sliding)
        _, lam, _ = self.solver.system.split(state.x)
        gathered = self.comm.gather(np.column_stack([lam, self.solver.law.shear_capacity(lam[:, 0])]), root=0)
        out = None
        if self.comm.rank == 0:
            forces = np.vstack(gathered)
            capacity = forces[:, 2]
            frozen = frozen_contact_collapse(self.fe, capacity)
            exact = frozen_contact_collapse(self.exact, capacity)
            size = int(self.joint.max(initial=-1)) + 1
            work = np.bincount(self.joint, frozen.dissipation(capacity), size)
            short = np.bincount(self.joint, frozen.shortfall(forces[:, :2], capacity), size)
            slides = work > AGREEMENT * work.sum()
            out = SlipCheck(sliding, frozen.level, tuple(int(j) for j in np.flatnonzero(slides)),
                            tuple(int(j) for j in np.unique(self.joint[frozen.opening])),
                            tuple(int(j) for j in np.flatnonzero(slides & (short <= AGREEMENT * work))),
                            exact.level, False, None, (), (), 0)
        return self.comm.bcast(out, root=0)


def collapse_check(scene: Scene, comm: MPI.Comm, lp: LPResult, blocks: BlockModel | None, solver: ContactSolver,
                   pairs: JointPairs, ring: ArchRing, tolerance: float, unit: float, contacts: PairCheck | None
                   ) -> CollapseCheck | None:
    """Evidence 3 at the search's converged states (:class:`bridgefem.search.records.CollapseCheck`): the frozen
    LP's level of a state whose mechanism slides only where the state's joints are at their Coulomb limit
    (:func:`frozen_collapse`; the search's estimate of the limit), and whether a state at ``lower`` settles the
    bracket [``lower``, ``trial``] of relative width ``tolerance``
    (:meth:`bridgefem.analysis.evidence.SlipCheck.settles`) or, after every solver setting failed the closing trial,
    ends it (:meth:`bridgefem.analysis.evidence.SlipCheck.upper_end`), with the check in words (``unit``: N of live
    load per unit level), on the rigid ``blocks`` loaded as the FE loads them. On a barrel of rings
    (:func:`per_piece`) the closing trial's readings alone, on its own pairs (``contacts``, :class:`PairCheck`),
    without the estimate: the estimate steers the search's path, which on a barrel can then reach another
    non-associative collapse state (``docs/robustness.md``, *Rings*). None with a fill (``blocks`` None) or without
    an LP limit (evidence 3 does not apply). Collective."""
    def readings(check: Callable[[Iterate], SlipCheck]) -> dict:
        def settles(lower: float, trial: float, state: Iterate) -> tuple[bool, str]:
            slip = check(state)
            return slip.settles(lower, trial, lp.level, tolerance), slip.describe(unit)

        def upper_end(lower: float, trial: float, state: Iterate) -> tuple[float | None, str]:
            slip = check(state)
            return slip.upper_end(lower, trial, lp.level), slip.describe(unit)

        return dict(settles=settles, upper_end=upper_end)

    if contacts is not None:
        return CollapseCheck(**readings(contacts.state))
    if not per_piece(blocks) or lp.status != Status.LIMIT or lp.level is None:
        return None

    def level(state: Iterate) -> float | None:
        joints, out = joint_states(solver, pairs, ring, state), None
        if comm.rank == 0:
            try:
                _, frozen, limited = frozen_collapse(joints, blocks)
                out = frozen.level if frozen.sliding and set(frozen.sliding) == set(limited) else None
            except (RuntimeError, ValueError):  # no estimate
                out = None
        return comm.bcast(out, root=0)

    def slip(state: Iterate) -> SlipCheck:
        return slip_state(scene, comm, lp, joint_states(solver, pairs, ring, state), blocks, fixed_point=False)

    return CollapseCheck(level, **readings(slip))

