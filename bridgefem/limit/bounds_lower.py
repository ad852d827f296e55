"""Static (lower-bound) collapse load of a :class:`~bridgefem.limit.bounds_model.LimitProblem` as a second-order cone
programme (Makrodimopoulos & Martin 2006, Int. J. Numer. Meth. Engng 66:604; Sloan 1988 for the linear
stress triangles).

1. Stresses ``(sx, sy, txy)`` vary linearly on each soil triangle (unknowns at its three vertices, separate
   per triangle: statically admissible discontinuities on every edge).
2. Equilibrium inside each triangle: ``div sigma + (0, -unit_weight) = 0`` (two rows, the divergence is
   constant).
3. Across interior edges the traction ``sigma n`` is continuous at both ends (hence along the edge).
4. Road edges carry their traction (load factor x traction per unit factor); roller ends carry no shear;
   the fixed base carries anything.
5. Interface edges: the traction at both ends lies in the no-tension Coulomb cone of the interface
   (``p = -n.sigma.n >= 0``, ``|t.sigma.n| <= mu p``); bonded edges (a loading beam, a rough footing) carry
   any traction (only the soil's cones bound it). The resultant (linear along the edge: consistent nodal forces
   ``L (t_a/3 + t_b/6)`` at ``a``) acts, reversed, on the block.
6. Every block is in equilibrium under its dead and live loads, the joint forces (the rigid-block LP's) and the
   interface forces; joint forces within their yield limits; Mohr-Coulomb cones at the triangle vertices (the
   stress is linear and the cone convex, so it then holds everywhere).

Maximise the load factor ``lambda >= 0``: every feasible point is statically admissible, so the optimum is a
lower bound of the collapse load factor. Without soil this is the rigid-block LP itself.
"""
from __future__ import annotations

import numpy as np

from .bounds_mesh import INTERFACE, INTERIOR, ON_BLOCK, ROAD, ROLLER
from .bounds_model import LimitProblem, block_rows, joint_rows, soil_rows
from .conic import FACTORISATION, MAX_ITERATIONS, NONNEG, ZERO, ConicProgramme, ConicSolution


def _traction_coefficients(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients (p, 3) on (sx, sy, txy) of the traction components t_x, t_y for unit normals (p, 2)."""
    nx, ny = normal[:, 0], normal[:, 1]
    zero = np.zeros_like(nx)
    return np.column_stack([nx, zero, ny]), np.column_stack([zero, ny, nx])


def lower_bound(problem: LimitProblem, max_iter: int = MAX_ITERATIONS, factorisation: str = FACTORISATION
                ) -> tuple[ConicSolution, dict]:
    """Solve the static programme in at most ``max_iter`` interior-point iterations (the KKT ``factorisation`` as in
    :meth:`~bridgefem.limit.conic.ConicProgramme.solve`); returns the solution and the column layout {"joints",
    "stress", "factor"} (stress columns: ``9 triangle + 3 vertex + component``)."""
    blocks, mesh = problem.blocks, problem.mesh
    nj = blocks.n_joints
    ne = mesh.n_triangles if mesh is not None else 0
    cs, lam = 3 * nj, 3 * nj + 9 * ne
    prog = ConicProgramme(lam + 1)
    joint_matrix = joint_rows(prog, blocks).tocoo()
    rows, cols, vals = [joint_matrix.row], [joint_matrix.col], [joint_matrix.data]
    live = blocks.live.ravel()
    rows.append(np.nonzero(live)[0])
    cols.append(np.full(len(rows[-1]), lam))
    vals.append(live[rows[-1]])
    if mesh is not None:
        for r, c, v in _soil(prog, problem, cs, lam):
            rows.append(r)
            cols.append(c)
            vals.append(v)
    prog.add(ZERO, np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), -blocks.dead.ravel())
    f, s = problem.force_scale, (problem.stress_scale if mesh is not None else 1.0)
    scale = np.concatenate([np.full(cs, f), np.full(9 * ne, s), [f]])
    layout = {"joints": slice(0, cs), "stress": slice(cs, lam), "factor": lam}
    return prog.maximise(lam, scale, max_iter, factorisation), layout


def _soil(prog: ConicProgramme, problem: LimitProblem, cs: int, lam: int):
    """Add the soil's rows (steps 1-5 and its cones) to ``prog``; returns the triplets of the interface forces
    on the blocks' equilibrium rows."""
    mesh, soil = problem.mesh, problem.soil
    ne = mesh.n_triangles
    area, grad = mesh.areas(), mesh.gradients()
    col = cs + 9 * np.arange(ne)[:, None, None] + 3 * np.arange(3)[None, :, None] + np.arange(3)
    # 2. equilibrium: row x: sum_k sx_k dLk/dx + txy_k dLk/dy; row y: sum_k txy_k dLk/dx + sy_k dLk/dy (x area)
    gx, gy = grad[..., 0] * area[:, None], grad[..., 1] * area[:, None]
    r = 2 * np.arange(ne)[:, None]
    prog.add(ZERO, np.hstack([r, r, r, r, r, r, r + 1, r + 1, r + 1, r + 1, r + 1, r + 1]),
             np.hstack([col[:, :, 0], col[:, :, 2], col[:, :, 2], col[:, :, 1]]),
             np.hstack([gx, gy, gx, gy]), np.column_stack([np.zeros(ne), soil.unit_weight * area]))
    ends, length, tangent, normal = mesh.edge_frames()
    tri, side = mesh.edge_triangles, mesh.edge_sides
    local = np.stack([side[:, 0], (side[:, 0] + 1) % 3], axis=1)  # edge ends a, b in the first triangle
    tx, ty = _traction_coefficients(normal)
    # 3. interior edges: traction jump zero at both ends (the second triangle runs the edge from b to a)
    e = np.nonzero(mesh.edge_kind == INTERIOR)[0]
    other = np.stack([(side[e, 1] + 1) % 3, side[e, 1]], axis=1)
    rows, cols, vals = [], [], []
    for end in range(2):
        for comp, coef in enumerate((tx, ty)):
            row = 4 * np.arange(len(e)) + 2 * end + comp
            rows.append(np.repeat(row, 6))
            cols.append(np.hstack([col[tri[e, 0], local[e, end]], col[tri[e, 1], other[:, end]]]))
            vals.append(np.hstack([coef[e], -coef[e]]))
    prog.add(ZERO, np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), np.zeros(4 * len(e)))
    # 4. road: sigma n - lambda g = 0; roller ends: t . sigma n = 0
    for kind in (ROAD, ROLLER):
        e = np.nonzero(mesh.edge_kind == kind)[0]
        rows, cols, vals = [], [], []
        for end in range(2):
            c = col[tri[e, 0], local[e, end]]
            if kind == ROAD:
                for comp, coef in enumerate((tx, ty)):
                    row = 4 * np.arange(len(e)) + 2 * end + comp
                    rows.append(np.repeat(row, 4))
                    cols.append(np.hstack([c, np.full((len(e), 1), lam)]))
                    vals.append(np.hstack([coef[e], -mesh.edge_traction[e, comp:comp + 1]]))
            else:
                rows.append(np.repeat(2 * np.arange(len(e)) + end, 3))
                cols.append(c)
                vals.append(tangent[e, :1] * tx[e] + tangent[e, 1:] * ty[e])
        prog.add(ZERO, np.concatenate(rows), np.concatenate(cols), np.concatenate(vals),
                 np.zeros((4 if kind == ROAD else 2) * len(e)))
    # 5. interface: no-tension Coulomb at both ends (bonded edges: no condition); forces on the blocks
    e = np.nonzero(np.isin(mesh.edge_kind, ON_BLOCK))[0]
    e = e[np.argsort(mesh.edge_kind[e] != INTERFACE, kind="stable")]  # Coulomb interfaces first
    n_coulomb = int((mesh.edge_kind[e] == INTERFACE).sum())
    nx, ny, t_x, t_y = normal[e, 0], normal[e, 1], tangent[e, 0], tangent[e, 1]
    nn = np.column_stack([nx * nx, ny * ny, 2 * nx * ny])
    nt = np.column_stack([t_x * nx, t_y * ny, t_x * ny + t_y * nx])
    mu = problem.interface_friction
    coef = np.stack([nn, nt + mu * nn, -nt + mu * nn], axis=1)  # (p, 3 rows, 3)
    forces = []
    rows = 6 * np.arange(len(e))[:, None, None] + 3 * np.arange(2)[None, :, None] + np.arange(3)
    c_ab = np.stack([col[tri[e, 0], local[e, 0]], col[tri[e, 0], local[e, 1]]], axis=1)  # (p, 2, 3)
    k = n_coulomb
    prog.add(NONNEG, np.repeat(rows[:k], 3, axis=2), np.repeat(c_ab[:k, :, None, :], 3, axis=2),
             np.repeat(coef[:k, None], 2, axis=1), np.zeros(6 * k))
    w = problem.width
    blk = mesh.edge_block[e]
    for at in range(2):  # force on the block at end `at` from the traction at end `by`: -w L (1/3 or 1/6) t
        point = mesh.x[ends[e, at]]
        for by in range(2):
            weight = -w * length[e] * (1 / 3 if at == by else 1 / 6)
            forces.append(block_rows(problem.blocks, blk, point, c_ab[:, by], weight[:, None] * tx[e],
                                     c_ab[:, by], weight[:, None] * ty[e]))
    soil_rows(prog, soil, cs, 3 * ne)
    return forces
