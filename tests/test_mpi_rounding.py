"""Decisions that must not depend on rounding, which differs between serial and MPI runs (MUMPS orders and rounds
otherwise on 2 ranks): a cycle's condensation is kept only when its normal block is a P-matrix by more than the
measured error of its entries (bridgefem/solver/cycles.py, *Rounding*). Checked on made-up cases with known answers: the
refinement's correction is the forward error of a perturbed solution, the P-matrix margin is the least singular
value of the principal submatrices, and a condensation whose normal entry is within its error is declined whatever
its sign."""
import numpy as np
import pytest
from petsc4py import PETSc
from test_cycles import MadeUpSystem

from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.solver.condensation import opens_when_pulled, pulled_margin
from bridgefem.solver.cycles import CycleCondenser
from bridgefem.solver.linear import CheckedSolve

OPEN, STICK = CoulombJoints.OPEN, CoulombJoints.STICK


def test_the_refinement_correction_is_the_error_of_a_perturbed_solution():
    """A x* = b with x* known; for x = x* + e the correction A^-1 (b - A x) is -e, at the cost of one solve."""
    A = PETSc.Mat().createDense([3, 3], array=np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]]),
                                comm=PETSc.COMM_SELF)
    A.assemble()
    exact, e = np.array([1.0, -2.0, 3.0]), np.array([1e-3, -2e-3, 5e-4])
    b, x = A.createVecLeft(), A.createVecRight()
    A.mult(PETSc.Vec().createWithArray(exact, comm=PETSc.COMM_SELF), b)
    x.array[:] = exact + e
    solve = CheckedSolve(A, {"pc_factor_mat_solver_type": "petsc"})
    correction = solve.correction(b, x)
    assert correction.array == pytest.approx(-e, rel=1e-10)
    assert solve.stats["solves"] == 1


def normal_block(normal: np.ndarray) -> np.ndarray:
    """A compliance (2p, 2p) with the given normal block and a unit tangential diagonal."""
    C = np.eye(2 * len(normal))
    C[0::2, 0::2] = normal
    return C


def test_the_margin_is_the_smallest_perturbation_that_can_fail_the_test():
    """[[1, 0], [3, 1]] is a P-matrix (minors 1, 1, 1) whose least singular value (sqrt(13) - 3) / 2 is below
    the diagonal's 1: the margin; removing 1.01 times its rank-one part gives a negative determinant, 0.99 times
    keeps a P-matrix. Above four pairs the margin is the least eigenvalue of the symmetric part (here 0.5)."""
    M = np.array([[1.0, 0.0], [3.0, 1.0]])
    margin = pulled_margin(normal_block(M))
    assert margin == pytest.approx((np.sqrt(13.0) - 3.0) / 2.0, rel=1e-12)
    U, s, Vt = np.linalg.svd(M)
    rank_one = s[-1] * np.outer(U[:, -1], Vt[-1])
    assert not opens_when_pulled(normal_block(M - 1.01 * rank_one))
    assert opens_when_pulled(normal_block(M - 0.99 * rank_one))
    assert pulled_margin(normal_block(np.diag([2.0, 0.5, 1.0, 3.0, 1.5]))) == pytest.approx(0.5)
    assert pulled_margin(normal_block(-M)) == 0.0


class NearMechanism(MadeUpSystem):
    """Two pairs; a unit normal force at pair 1 moves it by 0.43 nm/N and pair 0 (not in the cycle) by 1e5 m/N, as a
    nearly singular system does; its measured error at pair 1's normal is ``error`` m/N. Open, pair 1 penetrates
    1 um: with C_nn = 0.43 nm/N resolved it closes and sticks with lam_n = 1 um / 0.43 nm/N."""

    def __init__(self, error: float):
        S = 1e-9 * np.eye(4)
        S[2, 2], S[0, 2] = 0.43e-9, 1e5
        d_load = np.array([[0.0, 0.0], [-1e-6, 0.0]])
        super().__init__(S, d_load)
        self.error = error

    def unit_force_error(self):
        self.stats["solves"] += 1
        return np.array([[0.0, 0.0], [self.error, 0.0]])


@pytest.mark.parametrize("error, solved", [(2.1e-10, False), (1e-20, True)])
def test_a_normal_entry_within_its_rounding_is_declined(error, solved):
    """#193's crack-tip pair (cycles.py, *Rounding*): C_nn = +4.3e-10 m/N with an error of 2.1e-10 m/N is no
    P-matrix verdict (declined: its sign came out negative on 2 ranks); the same entry measured to 1e-20 m/N is
    used. Either way its amplified column costs one more solve (d0, two columns, the refinement)."""
    system = NearMechanism(error)
    cycling = CoulombJoints.bonded(2)
    cycling.state[1] = OPEN
    pairs = np.array([False, True])
    result = CycleCondenser(system, reuse=False).condensed(0.0, cycling, pairs, np.zeros(2), cycling)
    assert (result is not None) is solved
    if solved:
        assert list(result.state) == [STICK, STICK]
    assert system.stats["solves"] == (4 if solved else 2)
