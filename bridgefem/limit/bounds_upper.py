"""Kinematic (upper-bound) collapse load of a :class:`~bridgefem.limit.bounds_model.LimitProblem` as a second-order
cone programme (Makrodimopoulos & Martin 2007, Int. J. Numer. Anal. Meth. Geomech. 31:835).

The kinematic programme: velocities quadratic on the soil triangles (6 nodes, continuous), rigid-body
velocities ``(u, v, omega)`` of the blocks, velocity jumps on the joints, on the soil-block interfaces and on
the base (the ground at rest; a jump there dissipates as in the soil, ``|s| <= c + tan(phi) p``, which for a
rigid-plastic soil is what a fixed base means), the roller ends without normal velocity. The strain rate is
linear on each triangle; the flow rule (the strain rate in the normal cone of the Mohr-Coulomb set) is enforced
at its three vertices, hence everywhere, and the dissipation is bounded by ``(A/3) sum_vertices pi(strain
rate)`` (``pi`` convex: the support function of the yield set). On an interface or base edge the jump (soil
minus block velocity) is quadratic; its three Bernstein coefficients lie in the flow cone, hence the jump
everywhere, and the dissipation is bounded by ``(L/3) sum pi(coefficient)``. Joints as in the rigid-block LP.
On a bonded edge (a loading beam, a rough footing) the soil moves with its block: the velocity of every node
there is the block's rigid-body velocity at the node, ``(u - omega (y - y_ref), v + omega (x - x_ref))`` (no jump,
no dissipation). Minimise dissipation minus dead-load power with live-load power 1: any feasible velocity field
gives an upper bound.

The programme solved is its conic dual, a maximum load factor under *weak* equilibrium: for every free
velocity unknown, ``-sum_T (w A/3) B_k^T sigma_k + sum_I (w L/3) dJ_k^T f_k + joint forces + dead + lambda live
= 0``, with stresses ``sigma_k`` at the triangle vertices in the Mohr-Coulomb set, interface forces ``f_k``
(per unit length) at the Bernstein points in the Coulomb cone (the Mohr-Coulomb one on the base), joint
forces within their limits. Its optimum equals the kinematic minimum (strong duality); the velocities are its
equality duals (live-load power 1). (The base's Coulomb envelope ignores the soil's tension cut-off: a stronger
base, so the bound stays an upper bound.)
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .bounds_mesh import BONDED, FIXED, INTERFACE, ROAD, ROLLER
from .bounds_model import LimitProblem, block_rows, joint_rows, soil_rows
from .conic import FACTORISATION, NONNEG, ZERO, ConicProgramme, ConicSolution


def upper_bound(problem: LimitProblem, factorisation: str = FACTORISATION) -> tuple[ConicSolution, dict]:
    """Solve the kinematic programme (in its dual form; the KKT ``factorisation`` as in
    :meth:`~bridgefem.limit.conic.ConicProgramme.solve`); returns the solution and the layout: {"free": the
    free velocity unknowns (2 node + component; nodes: vertices, then edge midpoints), "velocities": the matrix
    taking the equality duals to the free velocity unknowns followed by the block velocities (3 per block),
    "factor": the load-factor column}."""
    blocks, mesh = problem.blocks, problem.mesh
    nj, nb = blocks.n_joints, blocks.n_blocks
    ne = mesh.n_triangles if mesh is not None else 0
    n_if = int(np.isin(mesh.edge_kind, (INTERFACE, FIXED)).sum()) if mesh is not None else 0
    cs, cf = 3 * nj, 3 * nj + 9 * ne
    lam = cf + 6 * n_if
    prog = ConicProgramme(lam + 1)
    joint_matrix = joint_rows(prog, blocks).tocoo()
    if mesh is not None:
        row_of, free = _velocity_unknowns(problem)
        n_free = len(free)
        triplets, rhs = _soil(prog, problem, row_of, cs, cf, lam)
    else:
        n_free, free, triplets, rhs = 0, np.zeros(0, int), [], np.zeros(0)
    live = blocks.live.ravel()
    on = np.nonzero(live)[0]
    triplets += [(joint_matrix.row + n_free, joint_matrix.col, joint_matrix.data),
                 (on + n_free, np.full(len(on), lam), live[on])]
    r, c, v = (np.concatenate(t) for t in zip(*triplets))
    keep = r >= 0  # rows of fixed velocity unknowns are dropped
    tie = _bonded_nodes(problem, row_of, n_free) if mesh is not None else sp.identity(3 * nb, format="csr")
    rows = (tie @ sp.csr_matrix((v[keep], (r[keep], c[keep])), shape=(tie.shape[1], lam + 1))).tocoo()
    prog.add(ZERO, rows.row, rows.col, rows.data, tie @ np.concatenate([rhs, -blocks.dead.ravel()]))
    f, s = problem.force_scale, (problem.stress_scale if mesh is not None else 1.0)
    scale = np.concatenate([np.full(cs, f), np.full(9 * ne, s), np.full(6 * n_if, f / max(np.ptp(
        mesh.x, axis=0).max() * problem.width, 1e-300) if mesh is not None else 1.0), [f]])
    layout = {"free": free, "velocities": tie.T.tocsr(), "factor": lam}
    return prog.maximise(lam, scale, factorisation=factorisation), layout


def _bonded_nodes(problem: LimitProblem, row_of: np.ndarray, n_free: int) -> sp.csr_matrix:
    """The matrix (kept rows, ``n_free + 3 nb``) that folds the weak-equilibrium rows of the velocity unknowns of
    nodes on BONDED edges into their block's rows (u, v, omega), weighted by the rigid-body map
    ``(u - omega (y - y_ref), v + omega (x - x_ref))``, and keeps every other row; its transpose takes the kept
    rows' duals (velocities) back to all unknowns."""
    mesh, blocks = problem.mesh, problem.blocks
    nv, n_ext = len(mesh.x), n_free + 3 * blocks.n_blocks
    e = np.nonzero(mesh.edge_kind == BONDED)[0]
    node, first = np.unique(np.concatenate([mesh.edges[e, 0], mesh.edges[e, 1], nv + e]), return_index=True)
    block = np.tile(mesh.edge_block[e], 3)[first]
    xy = np.vstack([mesh.x, mesh.x[mesh.edges].mean(axis=1)])[node]
    arm = xy - blocks.ref[block]
    rx, ry = row_of[2 * node], row_of[2 * node + 1]
    if np.any(rx < 0) or np.any(ry < 0):
        raise ValueError("a bonded block reaches a roller end of the soil (a loading beam at the fill's end)")
    tied = np.zeros(n_ext, bool)
    tied[np.concatenate([rx, ry])] = True
    kept = np.nonzero(~tied)[0]
    new = np.full(n_ext, -1)
    new[kept] = np.arange(len(kept))
    u = new[n_free + 3 * block]
    rows = np.concatenate([new[kept], u, u + 2, u + 1, u + 2])
    cols = np.concatenate([kept, rx, rx, ry, ry])
    vals = np.concatenate([np.ones(len(kept) + len(node)), -arm[:, 1], np.ones(len(node)), arm[:, 0]])
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(kept), n_ext))


def _velocity_unknowns(problem: LimitProblem) -> tuple[np.ndarray, np.ndarray]:
    """Equation row of each velocity unknown ``2 node + component`` (-1 if fixed) and the free unknowns.
    Nodes: vertices, then the midpoint of each edge (``n_vertices + edge``)."""
    mesh = problem.mesh
    nv = len(mesh.x)
    n_nodes = nv + len(mesh.edges)
    fixed = np.zeros((n_nodes, 2), bool)
    _, _, _, normal = mesh.edge_frames()
    e = np.nonzero(mesh.edge_kind == ROLLER)[0]
    nodes = np.column_stack([mesh.edges[e], nv + e])
    comp = np.argmax(np.abs(normal[e]), axis=1)  # a roller stops the velocity along its (axis) normal
    fixed[nodes, :] |= (np.arange(2) == comp[:, None])[:, None, :]
    free = np.nonzero(~fixed.ravel())[0]
    row_of = np.full(2 * n_nodes, -1)
    row_of[free] = np.arange(len(free))
    return row_of, free


def _soil(prog: ConicProgramme, problem: LimitProblem, row_of: np.ndarray, cs: int, cf: int, lam: int):
    """The soil's terms of the weak equilibrium (triplets with rows from ``row_of``, possibly -1) and the
    right-hand side (minus the fill's weight); adds the interface cones and the soil cones to ``prog``."""
    mesh, soil, w = problem.mesh, problem.soil, problem.width
    ne, nv = mesh.n_triangles, len(mesh.x)
    area, grad = mesh.areas(), mesh.gradients()
    # gradient of the 6 quadratic shape functions (3 vertices, 3 side midpoints) at the 3 vertices: (ne, k, i, 2)
    eye = np.eye(3)
    dn = np.zeros((ne, 3, 6, 2))
    dn[:, :, :3] = (4 * eye - 1)[None, :, :, None] * grad[:, None, :, :]
    nxt = [1, 2, 0]
    dn[:, :, 3:] = 4 * (eye[None, :, :, None] * grad[:, None, nxt, :]
                        + eye[:, nxt][None, :, :, None] * grad[:, None, :, :])
    node = np.hstack([mesh.triangles, nv + mesh.triangle_edges])  # (ne, 6)
    sig = cs + 9 * np.arange(ne)[:, None] + 3 * np.arange(3)  # (ne, k): column of sx at vertex k
    weight = -(w * area / 3)[:, None, None]
    gx, gy = weight * dn[..., 0], weight * dn[..., 1]  # (ne, k, i)
    rx, ry = row_of[2 * node][:, None, :], row_of[2 * node + 1][:, None, :]
    shape = gx.shape
    s0 = np.broadcast_to(sig[:, :, None], shape)
    triplets = [(np.broadcast_to(rx, shape), s0, gx), (np.broadcast_to(rx, shape), s0 + 2, gy),
                (np.broadcast_to(ry, shape), s0 + 2, gx), (np.broadcast_to(ry, shape), s0 + 1, gy)]
    triplets = [tuple(np.ravel(a) for a in t) for t in triplets]
    n_rows = int(row_of.max()) + 1
    rhs = np.zeros(n_rows)
    mid_y = row_of[2 * node[:, 3:] + 1]  # the fill's weight: w A/3 at each side midpoint, downward
    ok = mid_y >= 0
    np.add.at(rhs, mid_y[ok], np.repeat(soil.unit_weight * w * area / 3, 3).reshape(ne, 3)[ok])
    ends, length, tangent, normal = mesh.edge_frames()
    # road tractions, P2 consistent nodal forces (L/6, 2L/3, L/6)
    e = np.nonzero(mesh.edge_kind == ROAD)[0]
    nodes = np.column_stack([ends[e], nv + e])
    share = w * length[e, None] * np.array([1 / 6, 1 / 6, 2 / 3])
    for comp in range(2):
        triplets.append((row_of[2 * nodes + comp].ravel(), np.full(nodes.size, lam),
                         (share * mesh.edge_traction[e, comp:comp + 1]).ravel()))
    # interfaces (then the base): forces f_k = p_k n_in + s_k t per unit length at the Bernstein points
    # (a, midpoint, b) from the block (the ground) on the soil
    on_block = np.nonzero(mesh.edge_kind == INTERFACE)[0]
    e = np.concatenate([on_block, np.nonzero(mesh.edge_kind == FIXED)[0]])
    p, nb_edges = len(e), len(on_block)
    col = cf + 6 * np.arange(p)[:, None, None] + 2 * np.arange(3)[None, :, None] + np.arange(2)  # (p, k, p|s)
    direction = np.stack([-normal[e], tangent[e]], axis=1)  # (p, p|s, xy)
    ell = w * length[e] / 3
    nodes = np.column_stack([ends[e, 0], nv + e, ends[e, 1]])
    # soil node j receives sum_k c[j, k] f_k (Bernstein coefficients of the soil's quadratic velocity)
    mix = np.array([[1.0, -0.5, 0.0], [0.0, 2.0, 0.0], [0.0, -0.5, 1.0]])
    for j in range(3):
        for comp in range(2):
            rows = np.repeat(row_of[2 * nodes[:, j] + comp], 6)
            vals = ell[:, None, None] * mix[j][None, :, None] * direction[:, None, :, comp]
            triplets.append((rows, col.reshape(p, 6).ravel(), vals.reshape(p, 6).ravel()))
    b, end_a, end_b = e[:nb_edges], mesh.x[ends[e[:nb_edges], 0]], mesh.x[ends[e[:nb_edges], 1]]
    pts = np.stack([end_a, 0.5 * (end_a + end_b), end_b], axis=1)
    for k in range(3):
        fx = -ell[:nb_edges, None] * direction[:nb_edges, :, 0]
        fy = -ell[:nb_edges, None] * direction[:nb_edges, :, 1]
        triplets.append(block_rows(problem.blocks, mesh.edge_block[b], pts[:, k], col[:nb_edges, k], fx,
                                   col[:nb_edges, k], fy, row0=n_rows))
    # no-tension Coulomb on the blocks: p >= 0, |s| <= mu p; Mohr-Coulomb on the base: |s| <= c + tan(phi) p
    mu = problem.interface_friction
    n = 3 * nb_edges
    rows = 3 * np.arange(n)[:, None] + np.array([0, 1, 1, 2, 2])
    cols = col[:nb_edges].reshape(-1, 2)[:, [0, 1, 0, 1, 0]]
    prog.add(NONNEG, rows, cols, np.tile([-1.0, 1.0, -mu, -1.0, -mu], (n, 1)), np.zeros(3 * n))
    n = 3 * (p - nb_edges)
    tan_phi = np.tan(np.radians(soil.friction_angle))
    rows = 2 * np.arange(n)[:, None] + np.array([0, 0, 1, 1])
    cols = col[nb_edges:].reshape(-1, 2)[:, [1, 0, 1, 0]]
    prog.add(NONNEG, rows, cols, np.tile([1.0, -tan_phi, -1.0, -tan_phi], (n, 1)), np.full(2 * n, soil.cohesion))
    soil_rows(prog, soil, cs, 3 * ne)
    return triplets, rhs
