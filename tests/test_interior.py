"""The contact system's solves with the blocks' interiors condensed out (bridgefem.solver.interior) against the whole
system factorised by MUMPS: the same solution for active sets of every kind, a mechanism the same for both, and the
whole system solved where condensing cannot be done or does not pay."""
import tomllib

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import ROOT, scene_dict
from mpi4py import MPI
from petsc4py import PETSc
from scipy.sparse.linalg import splu

from bridgefem.analysis.build import Clock, build_model
from bridgefem.laws.base import ContactState
from bridgefem.scene.reader import scene_from_dict
from bridgefem.solver.interior import REDUCED_SHARE, InteriorCondensation, gathered, trailing_schur
from bridgefem.solver.linear import CheckedSolve


@pytest.fixture(scope="module")
def system():
    scene = scene_from_dict(scene_dict(mesh={"elements_through_thickness": 8}))  # a reduced system of 30 %
    model = build_model(scene, MPI.COMM_WORLD, None, lambda name: None, Clock(MPI.COMM_WORLD))
    return model.solver.system


def active_set(system, seed: int, open_share: float, slip_share: float) -> ContactState:
    """Pairs stuck, but ``open_share`` of them open and ``slip_share`` sliding either way, drawn with ``seed``."""
    law, m = system.law, len(system.pairs)
    draw = np.random.default_rng(seed).random(m)
    state = np.full(m, law.STICK, dtype=np.int8)
    state[draw < open_share + slip_share] = law.SLIP
    state[draw < open_share] = law.OPEN
    sign = np.where(state == law.SLIP, np.where(draw * 1e3 % 2 < 1, 1, -1), 0).astype(np.int8)
    return ContactState(state, sign)


def both_solves(system, active: ContactState, level: float):
    """The condensed solve of ``active``'s system and the whole system's MUMPS LU of the same matrix and right-hand
    side: (x condensed, failure), (x whole, failure)."""
    assert system.linear.condensation is not None
    x = system.vector()
    condensed = system.solve_set(level, active, np.zeros(len(system.pairs)), x)
    whole = CheckedSolve(system.A, {})
    y = system.vector()
    failure = whole.solve(system.b, y)
    whole.ksp.destroy()
    return (x, condensed), (y, failure)


@pytest.mark.parametrize("seed, open_share, slip_share",
                         [(0, 0.0, 0.0), (1, 0.2, 0.0), (2, 0.1, 0.3), (3, 0.3, 0.3), (4, 0.0, 0.6)])
def test_a_condensed_solve_is_the_whole_systems(system, seed, open_share, slip_share):
    active = active_set(system, seed, open_share, slip_share)
    (x, condensed), (y, whole) = both_solves(system, active, level=7.5e4)
    assert (condensed is None) == (whole is None)
    if whole is None:
        scale = y.norm(PETSc.NormType.INFINITY)
        assert (x - y).norm(PETSc.NormType.INFINITY) <= 1e-8 * scale


def test_every_pair_open_is_a_mechanism_for_both(system):
    """Voussoirs without a closed joint are a mechanism: the condensed solve fails as the whole one does, or both
    return displacements of kilometres (what the divergence test reads as a mechanism's mode)."""
    m = len(system.pairs)
    active = ContactState(np.full(m, system.law.OPEN, dtype=np.int8), np.zeros(m, dtype=np.int8))
    (x, condensed), (y, whole) = both_solves(system, active, level=0.0)
    assert (condensed is None) == (whole is None)
    if whole is None:
        u = slice(0, system.n_u)
        assert np.abs(x.array[u]).max() > 1e3 and np.abs(y.array[u]).max() > 1e3
    else:
        assert condensed.singular == whole.singular


def schur_by_solves(K_II, K_IF, K_FI) -> np.ndarray:
    """K_FI K_II^-1 K_IF by dense linear algebra."""
    return K_FI.toarray() @ np.linalg.solve(K_II.toarray(), K_IF.toarray())


def interior_lu(K_II: sp.spmatrix):
    return splu(sp.csc_matrix(K_II), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True})


def free_line(n: int) -> sp.csr_matrix:
    """The stiffness of n nodes in a line joined by unit springs, its ends free: singular by its translation."""
    K = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n)).tolil()
    K[0, 0] = K[n - 1, n - 1] = 1.0
    return K.tocsr()


def test_a_free_blocks_schur_complement_is_its_trailing_factor():
    """A free body (a grid of springs in two directions: singular by its two translations) with its two end
    columns as faces: the Schur complement read from one factorisation with the faces last is the one by solves."""
    nx, ny = 30, 7
    K = sp.kron(sp.kron(sp.eye(nx), free_line(ny)) + sp.kron(free_line(nx), sp.eye(ny)), sp.eye(2)).tocsr()
    assert np.abs(K @ np.tile([1.0, 0.0], nx * ny)).max() < 1e-12  # singular: it translates freely
    faces = np.r_[np.arange(2 * ny), np.arange(K.shape[0] - 2 * ny, K.shape[0])]
    interior = np.setdiff1d(np.arange(K.shape[0]), faces)
    K_II = K[interior][:, interior].tocsc()
    K_IF, K_FI, K_FF = K[interior][:, faces], K[faces][:, interior], K[faces][:, faces]
    Z = trailing_schur(interior_lu(K_II), K_II, K_IF, K_FI, K_FF)
    reference = schur_by_solves(K_II, K_IF, K_FI)
    assert Z is not None and np.abs(Z - reference).max() <= 1e-12 * np.abs(reference).max()


def test_each_voussoirs_schur_complement_is_its_trailing_factor(system):
    """The fixture's voussoirs (their stiffness from the FE model, every block of the condensation): the trailing
    factor gives each block's Schur complement onto its faces as the solves do."""
    condensation, A = system.linear.condensation, gathered(system.A)
    blocks = condensation._blocks()
    assert len(blocks) == 16
    for dofs, faces in blocks:
        I, F = condensation.I[dofs], condensation.B[faces]
        K_II, K_IF, K_FI, K_FF = A[I][:, I].tocsc(), A[I][:, F], A[F][:, I], A[F][:, F]
        Z = trailing_schur(interior_lu(K_II), K_II, K_IF, K_FI, K_FF)
        reference = schur_by_solves(K_II, K_IF, K_FI)
        assert Z is not None and np.abs(Z - reference).max() <= 1e-11 * np.abs(reference).max()


def combined(blocks: list[np.ndarray], law_rows: list[dict[int, float]]) -> PETSc.Mat:
    """A serial combined matrix: the stiffness blocks on the diagonal, then one row per law row (column: value)
    whose own diagonal is 1."""
    n_u = sum(len(b) for b in blocks)
    N = n_u + len(law_rows)
    A = np.zeros((N, N))
    at = 0
    for b in blocks:
        A[at:at + len(b), at:at + len(b)] = b
        at += len(b)
    for r, row in enumerate(law_rows):
        A[n_u + r, n_u + r] = 1.0
        for col, value in row.items():
            A[n_u + r, col] = value
            A[col, n_u + r] = -value
    M = PETSc.Mat().createAIJ(A.shape, csr=_csr(A), comm=PETSc.COMM_SELF)
    M.assemble()
    return M


def _csr(A: np.ndarray):
    rows, cols = np.nonzero(A)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=A.shape[0]))])
    return indptr.astype(PETSc.IntType), cols.astype(PETSc.IntType), A[rows, cols]


def chain(n: int) -> np.ndarray:
    """The stiffness (N/m) of n nodes joined by unit springs and held at both ends by unit springs: nonsingular."""
    return 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)


FREE = np.array([[1.0, -1.0], [-1.0, 1.0]])  # a free two-node bar: singular


def test_a_chain_is_condensed_onto_its_law_dofs():
    A = combined([chain(6)], [{5: 1.0}])
    condensation = InteriorCondensation.of(A, np.array([6]))
    assert list(condensation.B) == [5] and list(condensation.I) == [0, 1, 2, 3, 4]
    b = A.createVecLeft()
    b.array[:] = [1.0, -2.0, 0.5, 0.0, 3.0, 0.25, -1.5]
    x, ksp = A.createVecRight(), CheckedSolve(A, {}, condensation).ksp
    condensation.solve(ksp, b, x)
    assert x.array == pytest.approx(np.linalg.solve(A.convert("dense").getDenseArray(), b.array), rel=1e-12)


def test_a_block_no_law_row_touches_is_not_condensed():
    """The free bar has no interface dof: its K_II is singular, so the whole system is solved instead."""
    A = combined([chain(6), FREE], [{5: 1.0}])
    assert InteriorCondensation.of(A, np.array([8])) is None


def test_a_reduced_system_of_more_than_its_share_is_not_condensed():
    """Two of four unknowns on the law's side: the whole system is solved."""
    assert 2 / 4 > REDUCED_SHARE
    assert InteriorCondensation.of(combined([chain(3)], [{2: 1.0}]), np.array([3])) is None


def test_an_elastic_fill_along_the_extrados_is_not_condensed():
    """The fill is one block whose faces run along the whole extrados: its dense Schur complement would give R more
    entries than the whole system, so the whole system is factorised (though under a third of its unknowns are on
    the joints)."""
    d = tomllib.loads((ROOT / "demos" / "small_bridge.toml").read_text())
    d["fill"] = {k: v for k, v in d["fill"].items() if k not in ("friction_angle", "cohesion")}
    d["fill"]["material"] = "elastic"
    model = build_model(scene_from_dict(d), MPI.COMM_WORLD, None, lambda name: None, Clock(MPI.COMM_WORLD))
    system = model.solver.system
    assert system.material is None and system.linear.condensation is None
