"""Calibration problems of the fill model: a soil box of the project's Mohr-Coulomb soil pushed by a rigid body.

The fill's constitutive object (:mod:`bridgefem.laws.soil`, the Drucker-Prager cone matched to Mohr-Coulomb in
plane strain) on a plain DOLFINx mesh, with closed-form collapse loads to compare against:

- :func:`strip_footing`: a rigid strip footing of width B on the surface of a half-space, half of it modelled by
  symmetry in the box ``0 <= x <= L``, ``-H <= y <= 0`` (m). The footing (``0 <= x <= B/2`` on ``y = 0``) is
  pushed down by a prescribed settlement; a rough base also holds ``u_x = 0``, a smooth one leaves it free. Axis
  and far side on rollers (``u_x = 0``), base fixed. Bearing pressure ``q = R / (B/2)`` (Pa), R the vertical
  reaction per metre of the half footing. Closed forms: Prandtl (1920) for a weightless soil,
  ``q = c N_c`` with ``N_c = (N_q - 1) cot(phi)``, ``N_q = e^{pi tan phi} tan^2(45 + phi/2)`` (``N_c = 2 + pi`` at
  phi = 0), the same for rough and smooth bases; for a cohesionless soil with unit weight gamma,
  ``q = gamma B N_gamma / 2`` with the exact N_gamma of the method of characteristics (Martin 2005,
  :data:`MARTIN_N_GAMMA`), computed by :func:`cohesionless_n_gamma`.
- :func:`retaining_wall`: a soil column ``0 <= x <= W``, ``0 <= y <= H`` (m) with weight behind a smooth rigid
  wall at ``x = 0`` moved horizontally (away from the soil: active; into it: passive); smooth base
  (``u_y = 0``), far side on rollers. The wall force per metre tends to Rankine's
  ``P = K gamma H^2 / 2 + 2 c sqrt(K) H`` (passive, ``K_p = tan^2(45 + phi/2)``) or ``K_a gamma H^2 / 2`` (active,
  ``K_a = tan^2(45 - phi/2)``, c = 0).

Both solve the elastic-plastic boundary-value problem by displacement control: self-weight in one step, then the
prescribed displacement in equal increments, each by Newton's method with the consistent tangent of
:func:`bridgefem.laws.soil.return_map` and a MUMPS LU factorisation (the tangent is unsymmetric with a dilation
angle below phi). The mesh is a structured triangulation (right diagonals) graded towards the footing's edge
and the surface, where the stress is singular; the collapse load is the reaction at the last increment, on the
plateau of the load-settlement curve (:attr:`PushResult.plateau` measures how flat).

A cohesionless soil (c = 0) puts the unloaded surface at the cone's apex, where the return map's tangent has no
stiffness and Newton's method stalls. :func:`cohesionless_n_gamma` approaches it instead: two runs with a vanishing
cohesion ``c = VANISHING_COHESION x gamma B`` and half of it, each on the cone with a hyperbolic apex (Abbo & Sloan
1995; ``apex_smoothing = APEX_SMOOTHING x k``, :class:`bridgefem.laws.soil.MohrCoulomb`), both of which tend to the
cohesionless cone as c -> 0; the collapse pressure is linear in c near 0, so ``N(0) = 2 N(c/2) - N(c)`` up to
O(c^2). The smoothing is switched on only here: the fill and the other checks use the exact cone.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from math import exp, pi, radians, tan

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import apply_lifting, assemble_matrix, assemble_vector, set_bc
from dolfinx.mesh import CellType, create_rectangle, locate_entities_boundary
from mpi4py import MPI
from petsc4py import PETSc

from ..laws.soil import MohrCoulomb, elastic_tangent, return_map
from .fill import APEX_STIFFNESS, PointFields

PETSC_OPTIONS = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
NEWTON_TOL = 1e-7  # out-of-balance force / the problem's force scale (weight of the box + cohesion x size)
MAX_NEWTON = 40
LINE_SEARCH = 6  # halvings of a Newton step at most
# N_gamma of a cohesionless soil (cohesionless_n_gamma):
APEX_SMOOTHING = 0.9  # a / k of the hyperbolic apex: the surface crosses p = 0 at sqrt(J2) = 0.44 k
VANISHING_COHESION = 0.01  # c / (gamma B) of the first run; the second has half of it
N_GAMMA_STIFFNESS = 300.0  # E / (gamma B): the collapse load does not depend on E; a soft soil keeps the strain
# increments of a step within a few yield strains of the weak surface layer, where Newton converges
N_GAMMA_NEWTON = 150  # Newton iterations per increment at most (the line search often halves the steps)
N_GAMMA_TOL = 1e-6  # out-of-balance / force scale: the 32-cell runs stall at 3e-7 (0.2 N/m; the footing carries
# 1.8e5 N/m)
# N_gamma of the method of characteristics (C.M. Martin 2005, "Exact bearing capacity calculations using the
# method of characteristics", Proc. 11th IACMAG, Turin, 441-450; program ABC): {phi (degrees): (rough, smooth)}.
# Cited, not re-read from the paper (docs/bounds.md, "The N_gamma value").
MARTIN_N_GAMMA = {30.0: (14.75, 7.65)}


def prandtl_nc(friction_angle: float) -> float:
    """Prandtl's N_c = (N_q - 1) cot(phi), N_q = e^{pi tan phi} tan^2(45 + phi/2); 2 + pi at phi = 0 (degrees)."""
    if friction_angle == 0.0:
        return 2.0 + pi
    t = tan(radians(friction_angle))
    nq = exp(pi * t) * tan(radians(45.0 + friction_angle / 2.0)) ** 2
    return (nq - 1.0) / t


def rankine_coefficient(friction_angle: float, passive: bool) -> float:
    """K_p = tan^2(45 + phi/2) or K_a = tan^2(45 - phi/2) (phi in degrees)."""
    return tan(radians(45.0 + (1 if passive else -1) * friction_angle / 2.0)) ** 2


@dataclass
class PushResult:
    """Load-displacement curve of a displacement-controlled rigid body: prescribed displacement (m) and reaction
    (N per metre out of plane; positive against the push); ``newton`` iterations in all; ``plateau`` the relative
    increase of the reaction over the last quarter of the displacement."""

    displacement: np.ndarray
    reaction: np.ndarray
    newton: int
    cells: int
    dofs: int

    @property
    def limit(self) -> float:
        return float(self.reaction[-1])

    @property
    def plateau(self) -> float:
        i = int(np.searchsorted(self.displacement, 0.75 * self.displacement[-1]))
        return float(self.reaction[-1] / self.reaction[i] - 1.0)


def graded(n: int, length: float, at: float, power: float) -> np.ndarray:
    """n + 1 coordinates from 0 to ``length`` (m), one of them at ``at``, cells shrinking towards ``at`` with a
    power law: the cell next to ``at`` is ``(1/n)^power`` of the length on each side, to the nearest cell count."""
    if at <= 0.0:
        return length * (np.arange(n + 1) / n) ** power
    share = 1.0 / (1.0 + ((length - at) / at) ** (1.0 / power))
    k = min(n - 1, max(1, round(share * n)))
    left = at * (1.0 - (1.0 - np.arange(k + 1) / k) ** power)
    right = at + (length - at) * (np.arange(1, n - k + 1) / (n - k)) ** power
    return np.concatenate([left, right])


class SoilBox:
    """The soil box's mesh, displacement space and quadrature-point state (module docstring): ``x`` and ``y``
    are the graded grid lines (m), ``degree`` the Lagrange degree of the displacements, ``unit_weight`` (N/m^3),
    ``size`` (m) the length over which the cohesion makes the force scale of the Newton tolerance."""

    def __init__(self, soil: MohrCoulomb, x: np.ndarray, y: np.ndarray, degree: int, unit_weight: float,
                 size: float, comm: MPI.Comm = MPI.COMM_WORLD):
        self.soil = soil
        self.size = size
        nx, ny = len(x) - 1, len(y) - 1
        self.mesh = create_rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], [nx, ny], CellType.triangle)
        geo = self.mesh.geometry.x  # map the unit square's uniform grid onto the graded lines (exact at nodes)
        geo[:, 0] = np.interp(geo[:, 0], np.linspace(0.0, 1.0, nx + 1), x)
        geo[:, 1] = np.interp(geo[:, 1], np.linspace(0.0, 1.0, ny + 1), y)
        self.V = fem.VectorFunctionSpace(self.mesh, ("Lagrange", degree))
        self.points = PointFields(self.V, 1.0)
        v = ufl.TestFunction(self.V)
        gravity = fem.Constant(self.mesh, PETSc.ScalarType(-unit_weight))
        f_ext = assemble_vector(fem.form(gravity * v[1] * ufl.dx))
        f_ext.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.f_ext = f_ext.array.copy()
        self.n_owned = self.points.n_owned
        self._apex = APEX_STIFFNESS * elastic_tangent(soil)

    def dofs_on(self, where, component: int) -> np.ndarray:
        """Local dofs of a displacement component at the boundary facets where ``where(x)`` holds."""
        facets = locate_entities_boundary(self.mesh, 1, where)
        return fem.locate_dofs_topological(self.V.sub(component), 1, facets)

    def push(self, driven: tuple[np.ndarray, int], held: list[tuple[np.ndarray, int]], displacement: float,
             steps: int, max_newton: int = MAX_NEWTON, tolerance: float = NEWTON_TOL) -> PushResult:
        """Self-weight, then the ``driven`` dofs (of one component, as ``(dofs, component)``) displaced to
        ``displacement`` (m) in ``steps`` equal increments, the ``held`` dofs fixed at 0, at most ``max_newton``
        Newton iterations each, to an out-of-balance force of ``tolerance`` x the force scale. Returns the reaction
        on the driven dofs (N/m, positive against the push) after each converged increment."""
        value = fem.Constant(self.mesh, PETSc.ScalarType(0.0))
        bcs = [fem.dirichletbc(PETSc.ScalarType(0.0), dofs, self.V.sub(c)) for dofs, c in held]
        bcs.append(fem.dirichletbc(value, driven[0], self.V.sub(driven[1])))
        driven_rows = driven[0][driven[0] < self.n_owned]
        K = assemble_matrix(self.points.k_form, bcs=bcs)
        K.assemble()
        ksp = _lu(K)
        u = fem.Function(self.V)
        du, b = u.vector.duplicate(), u.vector.duplicate()
        plastic = np.zeros((len(self.points.strain(u.x.array[:self.n_owned])), 4))
        comm = self.mesh.comm
        scale = comm.allreduce(np.abs(self.f_ext).sum()) + self.soil.cohesion * self.size + 1e-30
        levels = np.concatenate([[0.0], np.linspace(displacement / steps, displacement, steps)])
        reactions, newton = [], 0
        for level in levels:
            value.value = level
            state = self._residual(u, plastic, bcs, b, driven_rows)
            for it in range(max_newton + 1):
                if it > 0 and state[0] <= tolerance * scale:
                    break
                if it == max_newton:
                    raise RuntimeError(f"Newton did not converge at displacement {level:.4g} m "
                                       f"(out-of-balance {state[0]:.3g} N/m)")
                K.zeroEntries()
                assemble_matrix(K, self.points.k_form, bcs=bcs)
                K.assemble()
                ksp.setOperators(K)
                ksp.solve(b, du)
                newton += 1
                start = u.vector.copy()
                for halving in range(LINE_SEARCH + 1):  # backtrack while the out-of-balance force grows
                    u.vector.waxpy(-0.5 ** halving, du, start)
                    u.x.scatter_forward()
                    trial = self._residual(u, plastic, bcs, b, driven_rows)
                    if trial[0] < state[0]:
                        break
                state = trial
            plastic = state[3]
            reactions.append(state[1] if displacement > 0 else -state[1])
        cells = comm.allreduce(self.mesh.topology.index_map(2).size_local)
        return PushResult(np.abs(levels), np.array(reactions), newton, cells,
                          self.V.dofmap.index_map.size_global * 2)

    def _residual(self, u: fem.Function, plastic: np.ndarray, bcs: list, b: PETSc.Vec, driven_rows: np.ndarray):
        """Out-of-balance force at u into ``b`` (lifted, bc rows = u - prescribed), with the tangent moduli at u
        set for the next solve. Returns (norm of b, reaction on the driven rows, moduli, trial plastic strain)."""
        moduli, new_plastic = self._stress(u, plastic)
        self.points.set_moduli(moduli)  # the lifting uses the tangent at u
        with b.localForm() as loc:
            loc.set(0.0)
        assemble_vector(b, self.points.f_form)
        apply_lifting(b, [self.points.k_form], bcs=[bcs], x0=[u.vector], scale=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        b.array[:] -= self.f_ext
        reaction = self.mesh.comm.allreduce(b.array[driven_rows].sum())
        set_bc(b, bcs, u.vector, -1.0)
        return b.norm(), reaction, moduli, new_plastic

    def _stress(self, u: fem.Function, plastic: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return map at u from the converged plastic strain: sets the stress, returns the tangent moduli
        (regularised at the apex, :data:`bridgefem.fe.fill.APEX_STIFFNESS`) and the trial plastic strain."""
        eps = self.points.strain(u.x.array[:self.n_owned])
        full = np.column_stack([eps[:, :2], np.zeros(len(eps)), eps[:, 2]])
        stress, moduli, new_plastic = return_map(self.soil, full, plastic)
        self.points.set_stress(stress[:, [0, 1, 3]])
        return moduli + self._apex, new_plastic


def _lu(K: PETSc.Mat) -> PETSc.KSP:
    ksp = PETSc.KSP().create(K.getComm())
    ksp.setOptionsPrefix("bridgefem_soil_")
    opts = PETSc.Options()
    for key, v in PETSC_OPTIONS.items():
        opts[f"bridgefem_soil_{key}"] = v
    ksp.setOperators(K)
    ksp.setFromOptions()
    return ksp


def strip_footing(soil: MohrCoulomb, width: float, rough: bool, cells: int, degree: int = 2,
                  unit_weight: float = 0.0, extent: tuple[float, float] = (6.0, 3.0), power: float = 2.0,
                  settlement: float = 0.1, steps: int = 20, max_newton: int = MAX_NEWTON,
                  tolerance: float = NEWTON_TOL) -> PushResult:
    """Bearing pressure-settlement curve of a rigid strip footing of ``width`` B (m) (module docstring):
    ``cells`` per side of the half box ``extent`` = (L, H) in units of B, graded with ``power``;
    ``settlement`` in units of B. The reaction is returned as the bearing pressure q (Pa)."""
    b = width / 2.0
    length, depth = extent[0] * width, extent[1] * width
    x = graded(cells, length, b, power)
    y = graded(cells, depth, 0.0, power)[::-1] * -1.0  # from -H up to the surface, fine at the top
    box = SoilBox(soil, x, y, degree, unit_weight, b)
    tol = 1e-9 * width
    under = box.dofs_on(lambda p: np.isclose(p[1], 0.0, atol=tol) & (p[0] <= b + tol), 1)
    held = [(box.dofs_on(lambda p: np.isclose(p[1], -depth, atol=tol), c), c) for c in (0, 1)]
    held.append((box.dofs_on(lambda p: np.isclose(p[0], 0.0, atol=tol) | np.isclose(p[0], length, atol=tol), 0),
                 0))
    if rough:
        held.append((box.dofs_on(lambda p: np.isclose(p[1], 0.0, atol=tol) & (p[0] <= b + tol), 0), 0))
    result = box.push((under, 1), held, -settlement * width, steps, max_newton, tolerance)
    result.reaction = result.reaction / b
    return result


def cohesionless_n_gamma(friction_angle: float, rough: bool, cells: int, degree: int = 2, poisson: float = 0.3,
                         settlement: float = 0.2, steps: int = 40) -> tuple[float, tuple[PushResult, PushResult]]:
    """N_gamma of a rigid strip footing on a cohesionless soil with weight (phi > 0 degrees, associated flow) by
    :func:`strip_footing` (``cells``, ``degree``, ``settlement`` in units of B, ``steps``), extrapolated from two
    vanishing cohesions (module docstring): returns ``2 N(c/2) - N(c)`` and the two runs, their reactions as
    ``N = 2 q / (gamma B)``. B = 2 m, gamma = 10 kN/m^3 (N_gamma does not depend on them)."""
    width, gamma = 2.0, 1e4
    runs = []
    for share in (VANISHING_COHESION, VANISHING_COHESION / 2):
        cone = MohrCoulomb(N_GAMMA_STIFFNESS * gamma * width, poisson, friction_angle, share * gamma * width,
                           tension_cutoff=1e12)
        soil = dataclasses.replace(cone, apex_smoothing=APEX_SMOOTHING * cone.k)
        result = strip_footing(soil, width, rough, cells, degree, gamma, settlement=settlement, steps=steps,
                               max_newton=N_GAMMA_NEWTON, tolerance=N_GAMMA_TOL)
        result.reaction = 2.0 * result.reaction / (gamma * width)
        runs.append(result)
    return 2.0 * runs[1].limit - runs[0].limit, (runs[0], runs[1])


def retaining_wall(soil: MohrCoulomb, height: float, unit_weight: float, passive: bool, cells: int,
                   degree: int = 2, width: float | None = None, movement: float = 0.01, steps: int = 10
                   ) -> PushResult:
    """Force-movement curve of a smooth rigid wall retaining a soil column of ``height`` H and ``width`` W (m,
    default H) (module docstring), moved by ``movement`` x H into the soil (passive) or away from it (active) in
    ``steps`` increments; ``cells`` per side. The reaction is the horizontal wall force (N/m)."""
    width = height if width is None else width
    box = SoilBox(soil, np.linspace(0.0, width, cells + 1), np.linspace(0.0, height, cells + 1), degree,
                  unit_weight, height)
    tol = 1e-9 * height
    wall = box.dofs_on(lambda p: np.isclose(p[0], 0.0, atol=tol), 0)
    held = [(box.dofs_on(lambda p: np.isclose(p[1], 0.0, atol=tol), 1), 1),
            (box.dofs_on(lambda p: np.isclose(p[0], width, atol=tol), 0), 0)]
    result = box.push((wall, 0), held, (1.0 if passive else -1.0) * movement * height, steps)
    result.reaction = np.abs(result.reaction)
    return result
