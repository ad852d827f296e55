"""The pair compliance a cycle's condensation uses (bridgefem.solver.cycles, ``CycleCondenser.pair_response``) on the
elastic block on rigid ground of tests/test_block.py: C (the pairs' relative displacements under unit forces at
their (n, t) rows, the cycle's pairs released, the others as held) and d0 (their relative displacements under the
loads). What the condensation costs (2p + 1 solves, one when it is repeated) is a budget of
benchmarks/solve_budgets.py."""
import numpy as np
from test_block import W, block_solver

from bridgefem.laws.coulomb import CoulombJoints

OPEN = CoulombJoints.OPEN


def settled_block():
    """The elastic block of tests/test_block.py (mu = 0.6, push at h = 1 m, 4 elements) at its self-weight state, a
    live level of 0.2 W (it sticks), and three of its closed base pairs."""
    solver, _ = block_solver(0.6, 1.0, elements=4)
    out = solver.solve_step(0.0, solver.initial_iterate())
    assert out.converged, out.reason
    start = solver.converged_slip_reference(out.iterate)
    pairs = np.zeros(len(solver.pairs), dtype=bool)
    closed = np.flatnonzero(start.active.state != OPEN)
    pairs[closed[[0, len(closed) // 2, -1]]] = True
    return solver, start, pairs, 0.2 * W


def test_a_repeated_condensation_gives_what_a_fresh_solver_computes():
    """The same pairs and held states condensed again (the compliance kept, d0 solved again) give the d0 and C that a
    solver which never condensed them computes."""
    solver, start, pairs, level = settled_block()
    solver.cycles.pair_response(level, start.active, pairs, start.slip_ref)
    d0, C = solver.cycles.pair_response(level, start.active, pairs, start.slip_ref)
    fresh, fresh_start, _, _ = settled_block()
    d0_fresh, C_fresh = fresh.cycles.pair_response(level, fresh_start.active, pairs, fresh_start.slip_ref)
    np.testing.assert_allclose(C, C_fresh, rtol=0, atol=1e-12 * np.abs(C_fresh).max())
    np.testing.assert_allclose(d0, d0_fresh, rtol=0, atol=1e-12 * np.abs(d0_fresh).max())


def test_the_pair_compliance_is_symmetric():
    """Maxwell-Betti: the relative displacement at pair row i under a unit force at row j equals the one at j under a
    unit force at i, in any linear elastic body with the other pairs held; 1e-12 of the largest entry (rounding)."""
    solver, start, pairs, level = settled_block()
    _, C = solver.cycles.pair_response(level, start.active, pairs, start.slip_ref)
    assert C.shape == (6, 6) and np.abs(C).max() > 0
    np.testing.assert_allclose(C, C.T, rtol=0, atol=1e-12 * np.abs(C).max())
