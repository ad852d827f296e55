"""The divergence test of a solve (bridgefem.solver.divergence) on the elastic block on rigid ground of tests/test_block.py,
mu = 2, pushed at h = 1.5 m: its rigid-block tipping load about the far corner of its base is P = W b / (2 h)."""
import numpy as np
import pytest
from test_block import B, W, block_solver

from bridgefem.laws.coulomb import ContactState, CoulombJoints
from bridgefem.solver.divergence import DIVERGENCE_FACTOR

OPEN, STICK = CoulombJoints.OPEN, CoulombJoints.STICK

H_PUSH = 1.5
TIPPING = W * B / (2 * H_PUSH)


def _weighted_block():
    """The block's solver after its self-weight step (every base pair closed and sticking), and that state."""
    solver, _ = block_solver(2.0, H_PUSH, elements=4)
    weight = solver.solve_step(0.0, solver.initial_iterate())
    assert weight.converged, weight.reason
    return solver, weight.iterate


def test_the_cap_is_the_factor_times_the_bonded_self_weight_response_and_that_response_is_within_it():
    """The self-weight step converges at its first solve, every pair bonded: that solve sets the cap
    (DIVERGENCE_FACTOR times its largest displacement), and its own solution is no divergence."""
    solver, start = _weighted_block()
    test, system = solver.divergence, solver.system
    assert solver.stats["solves"] == 1
    assert test.cap == pytest.approx(DIVERGENCE_FACTOR * system.norm_inf(start.x.array[:system.n_u]), rel=1e-12)
    assert test.failure(0.0, start.active, start.x, solver.initial_iterate().x, start.x) is None


@pytest.mark.parametrize("push,proof", [(0.99, False), (1.01, True)])
def test_a_hinge_at_the_toe_proves_collapse_only_above_the_tipping_load(push, proof):
    """The base's pair at the toe (the intrados end, x = +b/2: the push acts in +x at x = -b/2) sticking and every
    other base pair open: the block is free to rotate about the toe, the system singular, the solve runs off along
    that rigid rotation. Its mode opens the heel, a hinge mode on which the push does positive work; the whole load
    does positive work, a proof of collapse, only when P h > W b / 2: 1 % either side of the closed-form tipping
    load, a mechanism without proof below, a proved one above."""
    solver, start = _weighted_block()
    pairs = solver.pairs
    toe = (pairs.joint == 0) & (pairs.position == 0.0)
    assert np.count_nonzero(toe) == 1
    hinge = ContactState(np.where(toe, STICK, OPEN).astype(np.int8), np.zeros(len(pairs), dtype=np.int8))
    x = start.x.copy()
    assert solver.system.solve_set(push * TIPPING, hinge, start.slip_ref, x) is None
    failure = solver.divergence.failure(push * TIPPING, hinge, x, start.x, start.x)
    assert failure is not None and failure.mechanism and failure.repair is None
    assert failure.proof == proof
