"""Joint node pairs and the unilateral contact / Coulomb friction laws (seed paper, eqs. 1-6).

Each joint is a set of coincident node pairs (left face, right face; a springing pairs a voussoir face
with the rigid ground). Per pair k, with unit normal n from the left face into the right face and tangent
tau = n rotated +90 degrees:

- relative displacement ``d = [(u_R - u_L).n, (u_R - u_L).tau]`` (m); ``d_n >= 0`` is opening
  (eq. 1 with zero initial gap: ``h = -d_n <= 0``); on the ground side u is the imposed ground movement
  (zero, or a support movement: :func:`ground_offsets`);
- joint force on the right face ``lam = [lam_n, lam_t]`` (N, whole width); ``lam_n >= 0`` is compression
  (eq. 2) and ``lam_n d_n = 0`` (eq. 3);
- Coulomb friction (eqs. 4-6): ``|lam_t| <= mu lam_n``; stick (``Delta d_t = 0``) while strictly inside the
  cone; slip in either direction with ``lam_t = -mu lam_n sign(Delta d_t)`` (friction opposes the slip of the
  right face). ``Delta d_t`` is the slip since the last converged load step (incremental, path following).

A ring interface (between two rings of a barrel) is a curved joint: its pairs take the normal and tangent of the
curve where they are (:meth:`bridgefem.geometry.ring.Joint.frame_at`), the ring friction, and a cohesion (shear
strength at no normal force) that the law adds to the friction bound (:class:`bridgefem.laws.coulomb.CoulombJoints`).
Where three or more block copies meet, the pairs there are thinned to a forest (:func:`build_pairs`, step 3).

The laws are written as Alart-Curnier complementarity functions with the constant c (N/m per pair):
``sigma_n = lam_n - c d_n`` (contact iff > 0), ``sigma_t = lam_t - c Delta d_t`` (stick iff |sigma_t| <= mu
sigma_n), in the law object :class:`bridgefem.laws.coulomb.CoulombJoints`. Their semismooth Newton method is the
primal-dual active-set method of :mod:`bridgefem.solver.newton`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector
from petsc4py import PETSc
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..geometry.ring import ArchRing
from .mesh import BOUNDARY_TAGS, EXTRADOS_TAG, FILL_BASE_TAG, FILL_INTERFACE_TAG, BlockMesh, joint_face_tag, marked
from .model import node_blocks

GROUND = -1
ARCH_FILL = -2  # joint id of the arch-fill interface pairs
FILL_KIND = "fill"  # kind of the arch-fill interface pairs (the joints': geometry.ring.JOINT_KINDS)


@dataclass
class JointPairs:
    """The node pairs of this rank (a contiguous share ``offset .. offset + len`` of ``total`` pairs).

    ``kind`` is its joint's kind (:data:`bridgefem.geometry.ring.JOINT_KINDS`, ``FILL_KIND`` on the arch-fill
    interface); ``left``/``right`` are global blocked node indices of the vector space (``GROUND`` for the rigid
    ground); ``normal`` and ``tangent`` the unit vectors at the pair (the joint's, or on a curved ring interface and
    the arch-fill interface the curve's there); ``length`` is the tributary length (m) of the pair along its joint;
    ``position`` its distance along the joint from its intrados end (m), or its x (m) on the arch-fill interface
    (joint id ``ARCH_FILL``); ``point`` its place (m, (k, 2)); ``block`` the blocks (cell tags) of its left and right
    nodes ((k, 2), ``GROUND`` for the ground).
    """

    joint: np.ndarray
    kind: np.ndarray
    left: np.ndarray
    right: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    length: np.ndarray
    position: np.ndarray
    point: np.ndarray
    block: np.ndarray
    offset: int
    total: int

    def __len__(self) -> int:
        return len(self.joint)


def _tributary_lengths(V: fem.FunctionSpace, bm: BlockMesh, tags: list[int]) -> np.ndarray:
    """Integral of each basis function over the joint faces: the tributary length per blocked dof (m).

    The faces are marked 1 in a tag of their own (:func:`bridgefem.fe.mesh.marked`), so that the form does not depend
    on which tags (how many voussoirs) are integrated over: compiled once, not per joint layout."""
    ds = ufl.Measure("ds", domain=bm.mesh, subdomain_data=marked(bm.mesh, bm.facet_tags, tags))
    v = ufl.TestFunction(V)
    vec = assemble_vector(fem.form(v[0] * ds(1)))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return vec.array[0::2].copy()


def _gather_face_nodes(V: fem.FunctionSpace, bm: BlockMesh, tags: list[int]) -> np.ndarray:
    """Rows (tag, global blocked node, x, y, tributary length, block) of the owned nodes on each facet tag,
    gathered from all ranks (every rank calls the collective dof location for every tag, with or without facets).

    A node's tributary length is its length on that tag's faces alone, also where it lies on the faces of two tags
    (a voussoir's corner on a ring interface and a voussoir joint, an abutment's corner under two rings'
    springings): the tags are coloured so that no two tags of one colour share a node (:func:`_colours`), and the
    lengths are integrated colour by colour (one colour, one integration, when no node is shared)."""
    comm = bm.mesh.comm
    imap = V.dofmap.index_map
    blocks = node_blocks(V, bm)
    coords = V.tabulate_dof_coordinates()[:, :2]
    located = []
    for tag in tags:
        facets = bm.facet_tags.indices[bm.facet_tags.values == tag]
        nodes = fem.locate_dofs_topological(V, 1, facets)
        located.append(nodes[nodes < imap.size_local])
    owned = [imap.local_to_global(nodes.astype(np.int32)) for nodes in located]
    members = [np.concatenate(per_tag) for per_tag in zip(*comm.allgather(owned))] if tags else []
    colour = _colours(members)
    weights = {c: _tributary_lengths(V, bm, [t for t, k in zip(tags, colour) if k == c]) for c in sorted(set(colour))}
    rows = [np.column_stack([np.full(len(nodes), tag), g, coords[nodes], weights[k][nodes], blocks[nodes]])
            for tag, nodes, g, k in zip(tags, located, owned, colour)]
    return np.vstack(comm.allgather(np.vstack(rows) if rows else np.zeros((0, 6))))


def _colours(members: list[np.ndarray]) -> list[int]:
    """A colour per set of ``members`` (global nodes per tag) such that no two sets of one colour share a member:
    greedily, each set the least colour that none of the earlier sets it meets has."""
    tag = np.concatenate([np.full(len(m), i) for i, m in enumerate(members)]) if members else np.zeros(0, int)
    node = np.concatenate(members) if members else np.zeros(0, int)
    order = np.argsort(node, kind="stable")
    _, start, count = np.unique(node[order], return_index=True, return_counts=True)
    meets: dict[int, set[int]] = {}
    for first, n in zip(start[count > 1], count[count > 1]):  # the few nodes on the faces of several tags
        together = {int(t) for t in tag[order[first:first + n]]}
        for t in together:
            meets.setdefault(t, set()).update(together - {t})
    colour: list[int] = []
    for i in range(len(members)):
        used = {colour[j] for j in meets.get(i, ()) if j < i}
        colour.append(next(c for c in range(len(members)) if c not in used))
    return colour


def _interface_pairs(V: fem.FunctionSpace, bm: BlockMesh, match_tol: float) -> dict:
    """Pairs of the arch-fill interface: each fill node on the extrados (except those on the fixed base) with
    the ring node at its place. At a joint's extrados corner two voussoir faces meet: the fill node is paired
    with one of them, since pairing both would over-constrain a closed joint: the voussoir with the lower block
    number (the one on the left of the joint), a choice of the geometry, not of the node numbering, which differs
    between partitions (pairing by the lower global index made the fill ride on different voussoirs under MPI
    once a joint opened). Normal from
    the ring into the fill, from the neighbouring interface nodes (central differences)."""
    table = _gather_face_nodes(V, bm, [EXTRADOS_TAG, FILL_INTERFACE_TAG, FILL_BASE_TAG])
    ring_rows = table[table[:, 0] == EXTRADOS_TAG]
    fill_rows = table[table[:, 0] == FILL_INTERFACE_TAG]
    fill_rows = fill_rows[~np.isin(fill_rows[:, 1], table[table[:, 0] == FILL_BASE_TAG][:, 1])]
    fill_rows = fill_rows[np.argsort(fill_rows[:, 2])]
    dist, idx = cKDTree(ring_rows[:, 2:4]).query(fill_rows[:, 2:4], k=2)
    if np.any(dist[:, 0] > match_tol):
        raise RuntimeError("arch-fill interface: fill nodes without a ring node at their place")
    near = dist <= match_tol
    left = np.argmin(np.where(near, ring_rows[idx, 5], np.inf), axis=1)  # the voussoir on the joint's left
    ring_node = ring_rows[idx[np.arange(len(idx)), left], 1]
    x = fill_rows[:, 2:4]
    tangent = np.gradient(x, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    n = len(fill_rows)
    return {"joint": np.full(n, ARCH_FILL), "kind": np.full(n, FILL_KIND), "left": ring_node.astype(np.int64),
            "right": fill_rows[:, 1].astype(np.int64), "normal": normal,
            "tangent": np.column_stack([-normal[:, 1], normal[:, 0]]), "length": fill_rows[:, 4],
            "position": x[:, 0], "point": x,
            "block": np.column_stack([ring_rows[idx[np.arange(len(idx)), left], 5], fill_rows[:, 5]]).astype(np.int64)}


def build_pairs(V: fem.FunctionSpace, bm: BlockMesh, ring: ArchRing, match_tol: float) -> JointPairs:
    """Pair the nodes of both faces of every joint by position along the joint (any degree, any partition),
    and, with a fill, the ring and fill nodes of the extrados (joint id ``ARCH_FILL``, kind ``FILL_KIND``).

    1. The owned face nodes of all ranks are gathered (only joint nodes: small), and every rank pairs them the same
       way.
    2. Each joint's face nodes are sorted by their position along it (:meth:`bridgefem.geometry.ring.Joint.frame_at`:
       along its chord, or along its curve on a ring interface) and paired in that order; each pair takes the
       joint's unit normal and tangent there (a curved joint's, of its piece nearest the pair) and the mean of its
       two nodes' tributary lengths.
    3. Where three or more copies of a node meet (a ring interface's end at a voussoir joint of either ring, or at
       the springings on the ground or on an abutment), the pairs there would close a cycle, and with the pairs'
       hard constraints the system of a closed cycle is singular: only a forest of them is kept
       (:func:`_forest`), the redundant pair of a ring interface dropped and its tributary length given to the
       kept interface pair at that point (on the same interface: the same normal), where there is one.
    4. The pairs are split evenly over the ranks. ``match_tol`` (m) is the largest allowed distance within a pair.
    """
    comm = bm.mesh.comm
    local_tags = [int(t) for t in np.unique(bm.facet_tags.values) if t not in BOUNDARY_TAGS]
    table = _gather_face_nodes(V, bm, sorted(set(comm.allreduce(local_tags))))

    cols = {k: [] for k in ("joint", "kind", "left", "right", "normal", "tangent", "length", "position", "point",
                            "block")}
    for jt in (j for j in ring.joints if not j.free):
        faces = []
        for side in (0, 1):
            sel = table[table[:, 0] == joint_face_tag(jt.id, side)]
            faces.append(sel[np.argsort(jt.frame_at(sel[:, 2:4])[0], kind="stable")])
        present = [f for f in faces if len(f)]
        if len(present) == 2 and len(present[0]) != len(present[1]):
            raise RuntimeError(f"joint {jt.id}: {len(present[0])} and {len(present[1])} nodes on its faces")
        if len(present) == 2 and np.abs(present[0][:, 2:4] - present[1][:, 2:4]).max() > match_tol:
            raise RuntimeError(f"joint {jt.id}: face nodes do not coincide")
        ref = present[0]
        n = len(ref)
        position, normal, tangent = jt.frame_at(ref[:, 2:4])
        side_nodes = [f[:, 1].astype(np.int64) if len(f) else np.full(n, GROUND) for f in faces]
        cols["block"].append(np.column_stack([f[:, 5].astype(np.int64) if len(f) else np.full(n, GROUND)
                                              for f in faces]))
        cols["joint"].append(np.full(n, jt.id))
        cols["kind"].append(np.full(n, jt.kind))
        cols["left"].append(side_nodes[0])
        cols["right"].append(side_nodes[1])
        cols["normal"].append(normal)
        cols["tangent"].append(tangent)
        cols["length"].append(np.mean([f[:, 4] for f in present], axis=0))
        cols["position"].append(position)
        cols["point"].append(ref[:, 2:4])
    keep, length = _forest(*(np.concatenate(cols[k]) for k in ("kind", "left", "right", "length", "point")),
                           match_tol)
    cols = {k: [np.concatenate(v)[keep]] for k, v in cols.items()}
    cols["length"] = [length[keep]]
    if bm.fill_block is not None:
        for k, v in _interface_pairs(V, bm, match_tol).items():
            cols[k].append(v)
    total = sum(len(c) for c in cols["joint"])
    share = np.array_split(np.arange(total), comm.size)[comm.rank]
    lo, hi = (int(share[0]), int(share[-1]) + 1) if len(share) else (0, 0)
    return JointPairs(**{k: np.concatenate(v)[lo:hi] for k, v in cols.items()}, offset=lo, total=total)


def _forest(kind: np.ndarray, left: np.ndarray, right: np.ndarray, length: np.ndarray, point: np.ndarray,
            tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Which joint pairs to keep so that no pairs close a cycle of node copies at one point, and the tributary
    lengths (m) after the dropped pairs gave theirs.

    ``kind``, ``left``, ``right`` (global node copies, ``GROUND`` for the ground), ``length``: per pair, in the
    joints' order; ``point`` (m): where the pair is; pairs within ``tol`` (m) are at one point. At each point with
    more than one pair:

    1. the pairs are taken in their order, ring-interface pairs (kind "ring") after all others, and a pair is kept
       unless its two copies are already joined by the pairs kept before it at that point (a union-find of the
       copies, the ground one copy: a cycle through the ground at two points is no cycle of constraints);
    2. a dropped ring-interface pair gives its tributary length to the first kept ring-interface pair at that point.

    The order is the joints' and their pairs' along them, never the node numbering, so every partition keeps the same
    pairs. Returns the mask of kept pairs and the lengths."""
    keep, length = np.ones(len(kind), dtype=bool), length.copy()
    close = cKDTree(point).query_pairs(tol, output_type="ndarray")
    groups = connected_components(coo_matrix((np.ones(len(close)), (close[:, 0], close[:, 1])),
                                             shape=(len(kind), len(kind))), directed=False)[1]
    shared = np.flatnonzero(np.bincount(groups)[groups] > 1)
    for group in np.unique(groups[shared]):
        members = shared[groups[shared] == group]
        members = members[np.argsort(kind[members] == "ring", kind="stable")]
        parent: dict[int, int] = {}

        def root(node: int) -> int:
            while parent.get(node, node) != node:
                node = parent[node]
            return node

        for k in members:
            a, b = root(int(left[k])), root(int(right[k]))
            if a == b:
                keep[k] = False
            else:
                parent[a] = b
        interface = members[kind[members] == "ring"]
        kept = interface[keep[interface]]
        if len(kept):
            length[kept[0]] += length[interface[~keep[interface]]].sum()
    return keep, length


def ground_offsets(pairs: JointPairs, motion: dict[int, np.ndarray]) -> np.ndarray:
    """What a ground movement adds to the relative displacement of each local pair, (m, 2) in m (normal,
    tangential): ``d = G u + offset``. ``motion``: joint id -> ground displacement (m; x, y) under that joint."""
    delta = np.zeros((len(pairs), 2))
    for joint, vector in motion.items():  # a few supports, not pairs
        delta[pairs.joint == joint] = vector
    side = np.where(pairs.right == GROUND, 1.0, np.where(pairs.left == GROUND, -1.0, 0.0))  # ground is R / L
    return side[:, None] * np.column_stack([(delta * pairs.normal).sum(axis=1), (delta * pairs.tangent).sum(axis=1)])


