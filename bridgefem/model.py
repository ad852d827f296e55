"""Linear elasticity of the voussoirs assembled once with DOLFINx: stiffness, self-weight and live-load vectors.

All quantities are for the full out-of-plane width of the ring: K in N/m, forces in N. The live-load
vector is for a unit load level (1 N times each load's ``factor``); loads point down (-y).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix, assemble_vector
from mpi4py import MPI
from petsc4py import PETSc

from .geometry import ArchRing
from .mesh import EXTRADOS_TAG, BlockMesh
from .scene import Scene

POINT_TOL = 1e-6  # m: a mesh node closer than this to a load point carries the load


@dataclass
class ElasticModel:
    """Assembled operators; ``monitor`` holds the owned node indices (blocked) whose mean vertical
    displacement is the deflection under the first load (at the crown without live load)."""

    V: fem.FunctionSpace
    K: PETSc.Mat
    f_dead: PETSc.Vec
    f_live: PETSc.Vec
    monitor: np.ndarray
    dead_weight: float
    live_per_level: float


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


def build_elastic_model(bm: BlockMesh, ring: ArchRing, scene: Scene) -> ElasticModel:
    """Assemble K, the self-weight vector and the unit live-load vector (point loads as nodal forces shared
    equally by the nodes at the load point — both faces of a joint placed under it)."""
    mesh, comm = bm.mesh, bm.mesh.comm
    V = fem.VectorFunctionSpace(mesh, ("Lagrange", scene.mesh.degree))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    lam, mu = lame(scene.masonry.young, scene.masonry.poisson, scene.model.plane)
    width = scene.arch.width

    def eps(w):
        return ufl.sym(ufl.grad(w))

    sigma = 2 * mu * eps(u) + lam * ufl.tr(eps(u)) * ufl.Identity(2)
    K = assemble_matrix(fem.form(width * ufl.inner(sigma, eps(v)) * ufl.dx))
    K.assemble()

    rho_g = scene.masonry.density * scene.gravity
    f_dead = assemble_vector(fem.form(-width * rho_g * v[1] * ufl.dx))
    f_dead.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    dead_weight = comm.allreduce(fem.assemble_scalar(fem.form(width * rho_g * ufl.dx(domain=mesh))))

    ds = ufl.Measure("ds", domain=mesh, subdomain_data=bm.facet_tags)
    x = ufl.SpatialCoordinate(mesh)
    n = ufl.FacetNormal(mesh)
    patch = ufl.inner(fem.Constant(mesh, PETSc.ScalarType((0.0, 0.0))), v) * ufl.dx
    for ld in scene.loads:
        if ld.kind == "patch":
            a, b = ld.x_range(scene.arch.span)
            inside = ufl.conditional(ufl.And(ufl.ge(x[0], a), ufl.le(x[0], b)), 1.0, 0.0)
            patch = patch - ld.factor / ld.length * inside * abs(n[1]) * v[1] * ds(EXTRADOS_TAG)
    f_live = assemble_vector(fem.form(patch))
    f_live.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    for ld in scene.loads:
        if ld.kind == "point":
            point = ring.extrados_point(ld.x_range(scene.arch.span)[0])
            nodes = _owned_nodes_at(V, point, POINT_TOL)
            count = comm.allreduce(len(nodes))
            if count == 0:
                raise RuntimeError(f"no mesh node at the point load x = {point[0]:.6g} m")
            with f_live.localForm() as loc:
                loc.array[2 * nodes + 1] -= ld.factor / count
    live = -f_live.sum()

    x_mon = 0.5 * sum(scene.loads[0].x_range(scene.arch.span)) if scene.loads else 0.0
    monitor = _owned_nodes_at(V, ring.extrados_point(x_mon), _monitor_tol(V, ring, x_mon))
    return ElasticModel(V, K, f_dead, f_live, monitor, dead_weight, live)


def _monitor_tol(V: fem.FunctionSpace, ring: ArchRing, x: float) -> float:
    """Distance to the extrados node nearest to x (all ranks), padded, so that coincident copies are all found."""
    d = _owned_distances(V, ring.extrados_point(x))
    return V.mesh.comm.allreduce(d.min() if len(d) else np.inf, op=MPI.MIN) + POINT_TOL
