"""Linear elasticity of the voussoirs assembled once with DOLFINx: stiffness, self-weight and live-load vectors.

All quantities are for the full out-of-plane width of the ring: K in N/m, forces in N. The live-load
vector is for a unit load level (1 N times each load's ``factor``); loads point down (-y).

The body is every block of the mesh (:mod:`bridgefem.fe.mesh`): voussoirs, elastic abutments, the fill and its
loading beams, in plane strain (or plane stress for the masonry, ``[model] plane``), with Lagrange elements of the
scene's degree on triangles. :func:`build_elastic_model`

1. sets each cell's Lame constants and unit weight by its block (its material,
   :func:`bridgefem.structure.materials.block_materials`: masonry, a pier's own, an abutment; the fill; a loading beam
   ``BEAM_STIFFNESS`` times as stiff as the fill, so rigid against it and weightless);
2. assembles ``K`` from ``width (sigma(u) : eps(v)) dx`` with the fill's supports (fixed base, roller ends) built in;
3. assembles the self-weight ``-width gamma w v_y dx``, ``w`` the factor that gives each meshed block its exact
   polygon's weight and line of action (:func:`block_weight_shape`; 1 on the fill), and records the rings', the
   fill's and the supports' (abutments', piers') weights;
4. assembles the live load for a unit level: a patch as a uniform pressure per horizontal metre on the extrados of a
   bare ring, on the road or on a loading beam's top over a fill; a point load as a nodal force shared by the nodes
   at its point (``POINT_TOL``) of the blocks that carry it, on a joint the side the rigid-block LP finds least
   favourable (:func:`least_favourable_sides`), so that the FE and the LP load the same voussoir;
5. picks the monitor nodes: the ring's extrados nodes under the first load (at the crown without one), whose mean
   vertical displacement is the load-deflection curve's deflection.

The joints are not in ``K``: the voussoirs are independent bodies whose node pairs the contact solver joins
(:mod:`bridgefem.fe.pairs`). Reference: DOLFINx (the FEniCS Project; Baratta et al. 2023, *DOLFINx: the next
generation FEniCS problem solving environment*).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix, assemble_vector, set_bc
from mpi4py import MPI
from petsc4py import PETSc

from ..geometry.ring import ArchRing, joint_under, point_load_blocks, polygon_area_centroid
from ..scene.model import Fill, Scene
from ..structure.materials import block_materials
from .mesh import BEAM_TOP_TAG, EXTRADOS_TAG, FILL_BASE_TAG, FILL_END_TAG, ROAD_TAG, BlockMesh, marked

POINT_RTOL = 1e-7  # of the span: a mesh node closer than this to a load point carries the load (the nodes at the
# point coincide up to round-off, 1e-16 of the span, and the mesh has no other node within 1e-5 of the span)
BEAM_STIFFNESS = 1000.0  # Young's modulus of a loading beam / the fill's: rigid against the fill (docs/fill.md)


@dataclass
class ElasticModel:
    """Assembled operators; ``monitor`` holds the owned node indices (blocked) of the ring's extrados whose mean
    vertical displacement is the deflection under the first load (at the crown without live load).
    ``dead_weight`` is the rings' weight (every span's voussoirs), ``fill_weight`` the fill's and ``support_weight``
    that of the blocks that carry the spans: the elastic abutments and the piers (N); ``bcs`` the fill's supports."""

    V: fem.FunctionSpace
    K: PETSc.Mat
    f_dead: PETSc.Vec
    f_live: PETSc.Vec
    monitor: np.ndarray
    dead_weight: float
    live_per_level: float
    fill_weight: float = 0.0
    bcs: list = field(default_factory=list)
    support_weight: float = 0.0


def lame(young: float, poisson: float, plane: str) -> tuple[float, float]:
    """Lame constants (Pa) of the 2D model; plane stress uses lambda* = 2 lambda mu / (lambda + 2 mu)."""
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    return (2 * lam * mu / (lam + 2 * mu) if plane == "stress" else lam), mu


def _owned_distances(V: fem.FunctionSpace, point: np.ndarray) -> np.ndarray:
    """Distance (m) from ``point`` to every owned node of V."""
    n_owned = V.dofmap.index_map.size_local
    return np.linalg.norm(V.tabulate_dof_coordinates()[:n_owned, :2] - point, axis=1)


def _owned_nodes_at(V: fem.FunctionSpace, point: np.ndarray, tol: float) -> np.ndarray:
    return np.flatnonzero(_owned_distances(V, point) < tol)


def beam_lame(fill: Fill) -> tuple[float, float]:
    """Lame constants (Pa, plane strain) of a loading beam: ``BEAM_STIFFNESS`` x the fill's Young's modulus, the
    fill's Poisson's ratio."""
    return lame(BEAM_STIFFNESS * fill.young, fill.poisson, "strain")


def cell_constant(bm: BlockMesh, arch_value: float, fill_value: float = 0.0,
                  block_values: dict[int, float] | None = None, Q: fem.FunctionSpace | None = None,
                  beam_value: float = 0.0) -> fem.Function:
    """A piecewise constant (DG0) field: ``arch_value`` on the masonry's blocks, ``fill_value`` on the fill,
    ``block_values`` on the blocks of their own material (by block id: elastic abutments, a pier of its own; default
    none) and ``beam_value`` on loading beams; ``Q``: the DG0 space (default: a new one)."""
    Q = fem.FunctionSpace(bm.mesh, ("DG", 0)) if Q is None else Q
    q = fem.Function(Q)
    tags = bm.cell_tags
    is_fill = tags.values == bm.fill_block if bm.fill_block is not None else np.zeros(len(tags.values), bool)
    value = np.where(is_fill, fill_value, arch_value)
    if block_values:
        blocks = np.fromiter(block_values, dtype=np.int64)
        order = np.argsort(blocks)
        own = np.isin(tags.values, blocks)
        value[own] = np.fromiter(block_values.values(), dtype=float)[order][
            np.searchsorted(blocks[order], tags.values[own])]
    value[np.isin(tags.values, bm.beam_blocks)] = beam_value
    q.x.array[Q.dofmap.list.array[tags.indices]] = value
    q.x.scatter_forward()
    return q


def block_weight_shape(bm: BlockMesh, ring: ArchRing, Q: fem.FunctionSpace) -> ufl.core.expr.Expr:
    """The factor on each block's unit weight that gives its meshed cells the exact block's weight and line of
    action: ``a + c (x - X)`` on block b's cells, 1 on the fill and the loading beams.

    The mesh's cells follow a voussoir's curved intrados and extrados by straight edges, so the meshed voussoir
    weighs O(h^2) differently from the block (:attr:`bridgefem.geometry.ring.ArchRing.blocks`, its polygon) that the
    rigid-block LP, the bounds and the evidence rule load; a live-load capacity small against the self-weight moves
    by that difference. The factor makes the resultant of the block's self-weight, the only thing of it its rigid
    body's equilibrium sees, the block's own, on any mesh:

    1. per block, the meshed area A, first moment S = int x dA and second moment about its centroid X = S / A,
       I = int (x - X)^2 dA, summed over each rank's owned cells (straight-edged triangles, exact) and over the ranks;
    2. the block's polygon area A_e and centroid abscissa X_e (:func:`bridgefem.geometry.ring.polygon_area_centroid`);
    3. a = A_e / A (the weight) and c = A_e (X_e - X) / I (the moment about X: int (a + c (x - X)) x dA = A_e X_e).

    A block drawn with straight edges (a pier's course, an abutment) has a = 1 and c = 0 to round-off. Units: a
    dimensionless, c in 1/m, X in m."""
    mesh = bm.mesh
    nb = len(ring.blocks)
    owned = bm.cell_tags.indices < mesh.topology.index_map(mesh.topology.dim).size_local
    cells, blocks = bm.cell_tags.indices[owned], bm.cell_tags.values[owned]
    keep = blocks < nb
    cells, blocks = cells[keep], blocks[keep]
    corners = mesh.geometry.x[mesh.geometry.dofmap.array.reshape(-1, 3)[cells], :2]  # (cells, 3 vertices, xy)
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    x = corners[:, :, 0]
    second = area * (np.sum(x ** 2, axis=1) + x[:, 0] * x[:, 1] + x[:, 0] * x[:, 2] + x[:, 1] * x[:, 2]) / 6
    sums = np.vstack([np.bincount(blocks, w, minlength=nb) for w in (area, area * x.mean(axis=1), second)])
    A, S, second_moment = mesh.comm.allreduce(sums)
    X = S / A
    inertia = second_moment - A * X ** 2
    exact = [polygon_area_centroid(b.polygon) for b in ring.blocks]
    A_e = np.array([a for a, _ in exact])
    X_e = np.array([c[0] for _, c in exact])
    a, c = A_e / A, A_e * (X_e - X) / inertia

    def per_block(values: np.ndarray, other: float) -> fem.Function:  # ``other`` on the fill and the beams
        return cell_constant(bm, other, other, dict(enumerate(values)), Q, other)

    return per_block(a, 1.0) + per_block(c, 0.0) * (ufl.SpatialCoordinate(mesh)[0] - per_block(X, 0.0))


def node_blocks(V: fem.FunctionSpace, bm: BlockMesh) -> np.ndarray:
    """The block (cell tag: voussoir, abutment or fill) of each local node of V, owned then ghost (-1: none).
    Nodes are duplicated at the joints, so each belongs to one block; a loading beam's nodes count as the fill's
    (it is bonded to the road)."""
    imap = V.dofmap.index_map
    dofs = V.dofmap.list.array.reshape(-1, V.dofmap.dof_layout.num_dofs)
    block = np.full(imap.size_local + imap.num_ghosts, -1)
    tags = bm.cell_tags.values.copy()
    if bm.beam_blocks:
        tags[np.isin(tags, bm.beam_blocks)] = bm.fill_block
    block[dofs[bm.cell_tags.indices].ravel()] = np.repeat(tags, dofs.shape[1])
    return block


def fill_supports(V: fem.FunctionSpace, bm: BlockMesh) -> list[fem.DirichletBCMetaClass]:
    """The fill's supports: its base fixed, its vertical ends on rollers (u_x = 0); none without fill."""
    if bm.fill_block is None:
        return []
    tags = bm.facet_tags
    zero = PETSc.ScalarType(0.0)
    base = fem.locate_dofs_topological(V, 1, tags.indices[tags.values == FILL_BASE_TAG])
    ends = fem.locate_dofs_topological(V.sub(0), 1, tags.indices[tags.values == FILL_END_TAG])
    return [fem.dirichletbc(np.zeros(2, dtype=PETSc.ScalarType), base, V),
            fem.dirichletbc(zero, ends, V.sub(0))]


def strain(w):
    return ufl.sym(ufl.grad(w))


def build_elastic_model(bm: BlockMesh, ring: ArchRing, scene: Scene,
                        point_load_sides: list[str | None] | None = None) -> ElasticModel:
    """Assemble K, the self-weight vector and the unit live-load vector. Live loads act on the extrados of a bare
    arch and on the road over a fill, a patch on the top face of its loading beam when the mesh has beams
    (weightless, elastic with :func:`beam_lame`); the fill's supports are built into K and the loads. A point
    load is a nodal force shared equally by the nodes at the load point of the blocks that carry it
    (:func:`load_point`): a load on a joint is on the side given per scene load by ``point_load_sides`` ("left" |
    "right" | "split"; None for a load off the joints), by default the rigid-block LP's least favourable one
    (:func:`least_favourable_sides`), so that the FE and the LP load the same block."""
    mesh, comm = bm.mesh, bm.mesh.comm
    fill = scene.fill
    V = fem.VectorFunctionSpace(mesh, ("Lagrange", scene.mesh.degree))
    Q = fem.FunctionSpace(mesh, ("DG", 0))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    materials = block_materials(scene, ring)
    own = materials.own(scene)  # the blocks not of the masonry: elastic abutments, a pier of its own material
    arch_lame = lame(scene.masonry.young, scene.masonry.poisson, scene.model.plane)
    fill_lame = lame(fill.young, fill.poisson, "strain") if fill is not None else (0.0, 0.0)
    own_lame = [{b: lame(materials.young[b], materials.poisson[b], scene.model.plane)[k] for b in own} for k in (0, 1)]
    beam = beam_lame(fill) if bm.beam_blocks else (0.0, 0.0)
    lam, mu = (cell_constant(bm, a, f, b, Q, e) for a, f, b, e in zip(arch_lame, fill_lame, own_lame, beam))
    width = scene.arch.width
    bcs = fill_supports(V, bm)

    sigma = 2 * mu * strain(u) + lam * ufl.tr(strain(u)) * ufl.Identity(2)
    K = assemble_matrix(fem.form(width * ufl.inner(sigma, strain(v)) * ufl.dx), bcs=bcs)
    K.assemble()

    rho_g = scene.masonry.density * scene.gravity
    weight = cell_constant(bm, rho_g, fill.unit_weight if fill is not None else 0.0,
                           {b: materials.unit_weight[b] for b in own}, Q) * block_weight_shape(bm, ring, Q)
    f_dead = _load_vector(-width * weight * v[1] * ufl.dx, bcs)

    def weight_of(blocks: tuple[int, ...]) -> float:
        """Weight (N) of the cells with these tags (marked 1 in a tag of their own: one form for any blocks)."""
        if not blocks:
            return 0.0
        dx = ufl.Measure("dx", domain=mesh, subdomain_data=marked(mesh, bm.cell_tags, blocks))
        return comm.allreduce(fem.assemble_scalar(fem.form(width * weight * dx(1))))

    dead_total = comm.allreduce(fem.assemble_scalar(fem.form(width * weight * ufl.dx)))
    fill_weight = weight_of((bm.fill_block,) if fill is not None else ())
    support_weight = weight_of(bm.support_blocks)

    surface = (BEAM_TOP_TAG if bm.beam_blocks else ROAD_TAG) if fill is not None else EXTRADOS_TAG
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=bm.facet_tags)
    x = ufl.SpatialCoordinate(mesh)
    n = ufl.FacetNormal(mesh)
    patch = ufl.inner(fem.Constant(mesh, PETSc.ScalarType((0.0, 0.0))), v) * ufl.dx
    for ld in scene.loads:
        if ld.kind == "patch":
            a, b = ld.x_range(scene.arch.span)
            inside = ufl.conditional(ufl.And(ufl.ge(x[0], a), ufl.le(x[0], b)), 1.0, 0.0)
            patch = patch - ld.factor / ld.length * inside * abs(n[1]) * v[1] * ds(surface)
    f_live = _load_vector(patch, bcs)
    if point_load_sides is None:
        point_load_sides = least_favourable_sides(scene, comm)
    blocks = node_blocks(V, bm)
    for ld, side in zip(scene.loads, point_load_sides):
        if ld.kind == "point":
            point, carriers = load_point(ring, scene, ld.x_range(scene.arch.span)[0], side or "split")
            nodes = _owned_nodes_at(V, point, POINT_RTOL * scene.arch.span)
            nodes = nodes[np.isin(blocks[nodes], carriers)]
            count = comm.allreduce(len(nodes))
            if count == 0:
                raise RuntimeError(f"no mesh node at the point load x = {point[0]:.6g} m")
            with f_live.localForm() as loc:
                loc.array[2 * nodes + 1] -= ld.factor / count
    live = -f_live.sum()

    x_mon = 0.5 * sum(scene.loads[0].x_range(scene.arch.span)) if scene.loads else 0.0
    ring_nodes = _ring_nodes(V, bm)
    point = ring.extrados_point(x_mon)
    d = _owned_distances(V, point)[ring_nodes]
    tol = comm.allreduce(d.min() if len(d) else np.inf, op=MPI.MIN) + POINT_RTOL * scene.arch.span
    monitor = ring_nodes[d < tol]
    return ElasticModel(V, K, f_dead, f_live, monitor, dead_total - fill_weight - support_weight, live, fill_weight,
                        bcs, support_weight)


def load_point(ring: ArchRing, scene: Scene, x: float, side: str = "split") -> tuple[np.ndarray, tuple[int, ...]]:
    """Where a point load at horizontal position x (m) acts and the blocks whose nodes there carry it: on the road
    over a fill (the fill's block), else on the ring's extrados as :func:`bridgefem.geometry.ring.point_load_blocks`
    says for ``side`` (a load on a joint acts at the joint's extrados corner)."""
    if scene.fill is not None:
        return np.array([x, ring.crown_extrados + scene.fill.depth]), (ring.n_blocks,)
    j = joint_under(ring, x)
    point = ring.extrados_vertex(x) if j is None else ring.joints[j].extrados
    return point, point_load_blocks(ring, x, side)


def least_favourable_sides(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> list[str | None]:
    """Per scene load, the block side ("left" | "right") that carries a point load lying on a joint in the
    rigid-block LP's least favourable allocation (:func:`bridgefem.limit.collapse.collapse_load`), else None. Over
    a fill the loads act on the road and no side is needed. Computed on rank 0 and broadcast; if the LP fails (a
    RuntimeError from HiGHS) the loads stay shared by both faces (None)."""
    if scene.fill is not None or not any(ld.kind == "point" for ld in scene.loads):
        return [None] * len(scene.loads)
    from ..limit.collapse import collapse_load

    def sides() -> list[str | None]:
        try:
            return collapse_load(scene).load_sides
        except RuntimeError:
            return [None] * len(scene.loads)

    return comm.bcast(sides() if comm.rank == 0 else None, root=0)


def _ring_nodes(V: fem.FunctionSpace, bm: BlockMesh) -> np.ndarray:
    """Owned (blocked) node indices of the voussoirs' extrados faces."""
    facets = bm.facet_tags.indices[bm.facet_tags.values == EXTRADOS_TAG]
    nodes = fem.locate_dofs_topological(V, 1, facets)
    return nodes[nodes < V.dofmap.index_map.size_local]


def _load_vector(form, bcs) -> PETSc.Vec:
    """Assemble a load vector (N), add ghost contributions and zero it on supported dofs."""
    vec = assemble_vector(fem.form(form))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    set_bc(vec, bcs)
    return vec
