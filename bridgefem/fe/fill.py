"""The Mohr-Coulomb backfill in the FE model: internal force and consistent tangent at the quadrature points.

The whole body (voussoirs, elastic abutments, loading beams and fill) is integrated at the same quadrature
points: the voussoirs, abutments and beams with their elastic matrices, the fill with the return map of
:mod:`bridgefem.laws.soil` from the plastic strain of the last converged load step.
:meth:`PlasticFill.evaluate` returns, at a displacement u, the internal force f_int(u) (N) and the tangent
K_t(u) (N/m, same sparsity and supports as the elastic K of :mod:`bridgefem.fe.model`), so that the contact
solver's Newton step solves ``K_t du - G^T lam = f - f_int(u) + K_t u`` (the linearisation in total form). Ring
and fill share one quadrature rule: one point per triangle for P1, three for P2 (exact for the elastic
stiffness).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import basix
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix, assemble_vector, create_vector, set_bc
from mpi4py import MPI
from petsc4py import PETSc

from ..laws.soil import MohrCoulomb, elastic_tangent, return_map
from ..scene.model import Scene
from ..structure.materials import BlockMaterials
from .mesh import BlockMesh
from .model import beam_lame, lame, strain

APEX_STIFFNESS = 1e-6  # fraction of the elastic matrix kept in the tangent (points at the cone apex have none)


@dataclass
class FillResponse:
    """The fill at owned displacements ``u`` (m): internal force (owned entries, N), the trial plastic strain
    (n, 4), the consistent tangent moduli at the fill's points (n, 3, 3; Pa) and, once :meth:`PlasticFill.linearise`
    has assembled it, the tangent's CSR values and the right-hand side correction ``K_t u - f_int`` (owned, N)."""

    u: np.ndarray
    f_int: np.ndarray
    plastic_strain: np.ndarray
    moduli: np.ndarray
    tangent_values: np.ndarray | None = None
    correction: np.ndarray | None = None


def _voigt(w):
    e = strain(w)
    return ufl.as_vector([e[0, 0], e[1, 1], 2 * e[0, 1]])


def _elastic_matrix(lmbda: float, mu: float) -> np.ndarray:
    return np.array([[lmbda + 2 * mu, lmbda, 0.0], [lmbda, lmbda + 2 * mu, 0.0], [0.0, 0.0, mu]])


class PointFields:
    """Stress and tangent moduli at the quadrature points of every local cell of V's mesh (plane, Voigt
    ``[xx, yy, xy]`` with engineering shear strain) and the forms integrating them over an out-of-plane ``width``
    (m): the internal force ``width int sigma : eps(v)`` (N) and the tangent ``width int eps(v) : D eps(du)``
    (N/m). One point per triangle for P1 displacements, three for P2 (exact for the elastic stiffness)."""

    def __init__(self, V: fem.FunctionSpace, width: float):
        mesh = V.mesh
        self.degree = max(1, 2 * (V.ufl_element().degree() - 1))
        points, _ = basix.make_quadrature(basix.QuadratureType.Default, basix.CellType.triangle, self.degree)
        self.points_per_cell = len(points)
        cell = mesh.ufl_cell()
        stress_space = fem.FunctionSpace(mesh, ufl.VectorElement("Quadrature", cell, self.degree, dim=3,
                                                                 quad_scheme="default"))
        tangent_space = fem.FunctionSpace(mesh, ufl.TensorElement("Quadrature", cell, self.degree, shape=(3, 3),
                                                                  quad_scheme="default"))
        self.stress, self.tangent = fem.Function(stress_space), fem.Function(tangent_space)
        self.u = fem.Function(V)
        self.n_cells = mesh.topology.index_map(2).size_local + mesh.topology.index_map(2).num_ghosts
        self._cells = np.arange(self.n_cells, dtype=np.int32)
        self._dofs = stress_space.dofmap.list.array.reshape(self.n_cells, len(points)).ravel()
        self._strain = fem.Expression(_voigt(self.u), points)
        dxq = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": self.degree,
                                                       "quadrature_scheme": "default"})
        v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
        self.f_form = fem.form(width * ufl.dot(self.stress, _voigt(v)) * dxq)
        self._f_int = create_vector(self.f_form)
        self.k_form = fem.form(width * ufl.dot(ufl.dot(self.tangent, _voigt(du)), _voigt(v)) * dxq)
        self.n_owned = V.dofmap.index_map.size_local * 2

    def strain(self, u_owned: np.ndarray) -> np.ndarray:
        """Strain ``[exx, eyy, gamma_xy]`` (n_cells * points_per_cell, 3) at the owned displacements (m)."""
        self.u.x.array[:self.n_owned] = u_owned
        self.u.x.scatter_forward()
        return self._strain.eval(self._cells).reshape(-1, 3)

    def set_stress(self, stress: np.ndarray) -> None:
        """Stress (n, 3) (Pa) at the points, in the order of :meth:`strain`."""
        self.stress.x.array.reshape(-1, 3)[self._dofs] = stress

    def set_moduli(self, moduli: np.ndarray) -> None:
        """Tangent moduli (n, 3, 3) (Pa) at the points, in the order of :meth:`strain`."""
        self.tangent.x.array.reshape(-1, 9)[self._dofs] = moduli.reshape(-1, 9)

    def internal_force(self, bcs: list) -> PETSc.Vec:
        """The internal force (N) of the stress set, ghosts added, zero on the ``bcs``' dofs: assembled into the one
        vector this object keeps (valid until the next call), since a vector made per call is never freed (petsc4py
        3.18 leaves a PETSc object that Python drops to ``PETSc.garbage_cleanup``)."""
        with self._f_int.localForm() as local:
            local.set(0.0)
        assemble_vector(self._f_int, self.f_form)
        self._f_int.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(self._f_int, bcs)
        return self._f_int


class PlasticFill:
    """Quadrature-point state of the model with a Mohr-Coulomb fill (see the module docstring); the blocks' elastic
    moduli from ``materials`` (:func:`bridgefem.structure.materials.block_materials`)."""

    def __init__(self, V: fem.FunctionSpace, bm: BlockMesh, scene: Scene, bcs: list, materials: BlockMaterials):
        mesh = bm.mesh
        f = scene.fill
        self.material = MohrCoulomb(f.young, f.poisson, f.friction_angle, f.cohesion, f.tension_cutoff,
                                    f.dilation_angle)
        self.cohesion = f.cohesion  # the scene's (Pa); set_cohesion changes the material's for a while
        self.bcs = bcs
        self.points = PointFields(V, scene.arch.width)
        n_cells, n_qp = self.points.n_cells, self.points.points_per_cell
        block = np.full(n_cells, -1)
        block[bm.cell_tags.indices] = bm.cell_tags.values
        self._fill = np.repeat(block == bm.fill_block, n_qp)
        y = mesh.geometry.x[mesh.geometry.dofmap.array.reshape(n_cells, -1)[block == bm.fill_block], 1]
        comm = mesh.comm
        height = comm.allreduce(y.max() if y.size else -np.inf, op=MPI.MAX) - \
            comm.allreduce(y.min() if y.size else np.inf, op=MPI.MIN)
        self.overburden = f.unit_weight * height  # vertical stress (Pa) of the full fill height, a stress scale
        ring = _elastic_matrix(*lame(scene.masonry.young, scene.masonry.poisson, scene.model.plane))
        self._elastic = np.broadcast_to(ring, (len(self._fill), 3, 3)).copy()  # per point; the fill's is unused
        for b in materials.own(scene):  # elastic abutments, a pier of its own material
            self._elastic[np.repeat(block == b, n_qp)] = _elastic_matrix(
                *lame(materials.young[b], materials.poisson[b], scene.model.plane))
        if bm.beam_blocks:
            self._elastic[np.repeat(np.isin(block, bm.beam_blocks), n_qp)] = _elastic_matrix(*beam_lame(f))
        self._apex = APEX_STIFFNESS * elastic_tangent(self.material)
        self.K = assemble_matrix(self.points.k_form, bcs=bcs)
        self.K.assemble()
        self.n_owned = self.points.n_owned
        self._u_vec = self.K.createVecRight()
        self._ku = self.K.createVecLeft()

    def set_cohesion(self, cohesion: float) -> None:
        """Evaluate the fill with this cohesion (Pa) from now on (the scene's: ``self.cohesion``)."""
        self.material = replace(self.material, cohesion=cohesion)

    def initial_plastic_strain(self) -> np.ndarray:
        return np.zeros((int(self._fill.sum()), 4))

    def evaluate(self, u_owned: np.ndarray, plastic_strain: np.ndarray, tangent: bool = True) -> FillResponse:
        """Stress (into ``stress``) and internal force at displacement ``u_owned`` (m) from the converged plastic
        strain, and the assembled tangent (:meth:`linearise`) unless ``tangent`` is False."""
        eps = self.points.strain(u_owned)
        stress = np.einsum("qij,qj->qi", self._elastic, eps)
        fill_eps = np.column_stack([eps[self._fill, :2], np.zeros(len(plastic_strain)), eps[self._fill, 2]])
        sig, d_alg, new_plastic = return_map(self.material, fill_eps, plastic_strain)
        stress[self._fill] = sig[:, [0, 1, 3]]
        self.points.set_stress(stress)
        f_int = self.points.internal_force(self.bcs)
        response = FillResponse(u_owned.copy(), f_int.array.copy(), new_plastic, d_alg)
        return self.linearise(response) if tangent else response

    def linearise(self, response: FillResponse) -> FillResponse:
        """The response with the consistent tangent K_t assembled at its displacements (CSR values, N/m) and the
        right-hand side correction K_t u - f_int (owned, N)."""
        d = self._elastic.copy()
        d[self._fill] = response.moduli + self._apex
        self.points.set_moduli(d)
        self.K.zeroEntries()
        assemble_matrix(self.K, self.points.k_form, bcs=self.bcs)
        self.K.assemble()
        self._u_vec.array[:] = response.u
        self.K.mult(self._u_vec, self._ku)
        return replace(response, tangent_values=self.K.getValuesCSR()[2].copy(),
                       correction=self._ku.array - response.f_int)
