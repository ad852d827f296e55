"""Linear solves and what they are spent on (bridgefem/solver.py). A cycle's condensation (bridgefem/cycles.py;
``CycleCondenser.compliance``) costs 2p + 1 solves for p pairs the first time, one (the open response d0) when the
same pairs are condensed again with the same held states, and only the normal columns up to the pair that shows a
normal block that is not a P-matrix, that pair first the next time; the solves of condensations and of retries are
counted apart (``condensation_solves``, ``retry_solves``)."""
import numpy as np
import pytest
from test_block import W, block_solver

from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.solver import cycles as cycles_module
from bridgefem.solver import newton as solver_module

OPEN = CoulombJoints.OPEN


def settled_block():
    """The elastic block on the ground (tests/test_block.py, mu = 0.6, push at h = 1 m) at its self-weight state, a
    live level of 0.2 W (it sticks), and three of its closed base pairs."""
    solver, _ = block_solver(0.6, 1.0, elements=4)
    out = solver.solve_step(0.0, solver.initial_iterate())
    assert out.converged, out.reason
    start = solver.converged_slip_reference(out.iterate)
    pairs = np.zeros(len(solver.pairs), dtype=bool)
    closed = np.flatnonzero(start.active.state != OPEN)
    pairs[closed[[0, len(closed) // 2, -1]]] = True
    return solver, start, pairs, 0.2 * W


def test_a_condensation_repeated_with_the_same_held_states_costs_one_solve():
    """Three pairs: 7 solves, then 1 for the same pairs and held states, with the same d0 and C; other pairs (two of
    the three) cost 2 x 2 + 1 again."""
    solver, start, pairs, level = settled_block()
    solves = solver.stats["solves"]
    d0, C = solver.cycles.pair_response(level, start.active, pairs, start.slip_ref)
    assert solver.stats["solves"] - solves == 7
    again = solver.stats["solves"]
    d0_again, C_again = solver.cycles.pair_response(level, start.active, pairs, start.slip_ref)
    assert solver.stats["solves"] - again == 1
    assert np.array_equal(C, C_again) and np.array_equal(d0, d0_again)
    fewer = pairs.copy()
    fewer[np.flatnonzero(pairs)[0]] = False
    before = solver.stats["solves"]
    assert solver.cycles.pair_response(level, start.active, fewer, start.slip_ref) is not None
    assert solver.stats["solves"] - before == 5


def test_a_declined_condensation_stops_at_the_pair_that_shows_it(monkeypatch):
    """A made-up normal test that declines every block of two or more pairs: the condensation of three pairs stops
    after the normal columns of the first two (2 solves), and the same condensation again costs none."""
    monkeypatch.setattr(cycles_module, "opens_when_pulled", lambda C: len(C) < 4)
    solver, start, pairs, level = settled_block()
    solves = solver.stats["solves"]
    assert solver.cycles.pair_response(level, start.active, pairs, start.slip_ref) is None
    assert solver.stats["solves"] - solves == 2
    assert solver.cycles.pair_response(level, start.active, pairs, start.slip_ref) is None
    assert solver.stats["solves"] - solves == 2


def test_a_pair_that_declined_a_condensation_is_solved_first_the_next_time(monkeypatch):
    """A made-up normal test that declines every block of two or more pairs: pairs (a, b, c) decline at b, after the
    normal solves of a and b; then (a, b) is solved from b, the pair that showed it (a first without that memory)."""
    monkeypatch.setattr(cycles_module, "opens_when_pulled", lambda block: len(block) < 4)
    solver, start, pairs, level = settled_block()
    a, b, _ = np.flatnonzero(pairs)
    unit_rows = []
    system = solver.system
    solve = system._solve
    monkeypatch.setattr(system, "_solve", lambda active, x: unit_rows.append(np.flatnonzero(system.b.array)[0])
                        or solve(active, x))
    assert solver.cycles.pair_response(level, start.active, pairs, start.slip_ref) is None
    assert unit_rows == [solver.n_u + 2 * a, solver.n_u + 2 * b]
    both = np.zeros_like(pairs)
    both[[a, b]] = True
    unit_rows.clear()
    assert solver.cycles.pair_response(level, start.active, both, start.slip_ref) is None
    assert unit_rows == [solver.n_u + 2 * b, solver.n_u + 2 * a]


@pytest.mark.parametrize("change", ["friction", "setting"])
def test_a_changed_law_computes_the_compliance_again(change):
    """New friction coefficients or Alart-Curnier constants change the matrix: the compliance is solved again."""
    solver, start, pairs, level = settled_block()
    solver.cycles.pair_response(level, start.active, pairs, start.slip_ref)
    if change == "friction":
        solver.set_friction_factor(2.0)
    else:
        solver.use(solver_module.Setting(scale=10.0))
    solves = solver.stats["solves"]
    solver.cycles.pair_response(level, start.active, pairs, start.slip_ref)
    assert solver.stats["solves"] - solves == 7


def test_the_solves_of_a_retry_and_of_a_condensation_are_counted_apart():
    """A step solved with the Alart-Curnier constants x 10 counts its Newton iterations (one solve each, no cycle in a
    sticking block) as retry solves; a condensation of three pairs counts its 7."""
    solver, start, pairs, level = settled_block()
    solver.use(solver_module.Setting(scale=10.0))
    out = solver.solve_step(level, start)
    solver.use(solver_module.DEFAULT_SETTING)
    assert out.converged and solver.stats["retry_solves"] == out.iterations
    solver.solve_step(level, start)
    assert solver.stats["retry_solves"] == out.iterations
    solver.cycles.condensed(level, start.active, pairs, start.slip_ref, start.active)
    assert solver.stats["condensation_solves"] == 7
