"""The condensation of a cycle (bridgefem/solver/cycles.py) on a made-up linear system whose pair compliance is known: C is
built column by column from unit-force solves in the pairs' (n, t) order, d0 from one solve with the pairs open, and
the small problem is solved on them; the 2p + 1 solves are counted as condensation solves."""
from types import SimpleNamespace

import numpy as np
from mpi4py import MPI

from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.solver.cycles import CycleCondenser

OPEN, STICK = CoulombJoints.OPEN, CoulombJoints.STICK


class MadeUpSystem:
    """Pairs whose relative displacements (m) are ``d_load`` under the loads and the columns of a fixed compliance
    ``S`` (m/N) under a unit force at each law row, whatever the active set: a stand-in for the contact solver."""

    def __init__(self, S: np.ndarray, d_load: np.ndarray):
        self.comm = MPI.COMM_SELF
        self.law = CoulombJoints(np.full(len(d_load), 0.5), np.full(len(d_load), 1e9), 1e-9)
        self.pairs = SimpleNamespace(offset=0)
        self.stats = {"solves": 0, "condensation_solves": 0}
        self.S, self.d_load = S, d_load

    def active_set_displacements(self, level, active, slip_ref):
        self.stats["solves"] += 1
        return self.d_load.copy()

    def unit_force_displacements(self, active, row):
        self.stats["solves"] += 1
        return self.S[:, row].reshape(-1, 2)


def four_pairs():
    """Four pairs, compliance 1 nm/N on the diagonal, 0.2 nm/N between the normal rows of pairs 1 and 3; pair 1
    penetrates 1 um when open, pair 3 has a gap of 1 um, no slip."""
    S = 1e-9 * np.eye(8)
    S[2, 6] = S[6, 2] = 0.2e-9
    d_load = np.zeros((4, 2))
    d_load[1, 0], d_load[3, 0] = -1e-6, 1e-6
    pairs = np.zeros(4, dtype=bool)
    pairs[[1, 3]] = True
    return MadeUpSystem(S, d_load), pairs


def test_compliance_is_the_pairs_block_and_is_kept_until_forgotten():
    system, pairs = four_pairs()
    cycles = CycleCondenser(system, reuse=True)
    held = CoulombJoints.bonded(4)
    d0, C = cycles.pair_response(0.0, held, pairs, np.full(4, 3e-7))
    rows = [2, 3, 6, 7]
    assert np.array_equal(C, system.S[np.ix_(rows, rows)])
    assert np.array_equal(d0, [[-1e-6, -3e-7], [1e-6, -3e-7]])  # slip measured from the reference
    assert system.stats["solves"] == 5
    cycles.pair_response(0.0, held, pairs, np.zeros(4))
    assert system.stats["solves"] == 6  # C kept: only d0
    cycles.forget()
    cycles.pair_response(0.0, held, pairs, np.zeros(4))
    assert system.stats["solves"] == 11


def test_a_cycle_is_solved_in_the_state_the_law_accepts():
    """Pair 1 closes with lam_n = 1 um / 1 nm/N = 1000 N and pushes pair 3's gap to 1 + 0.2 = 1.2 um: pair 1
    sticks, pair 3 stays open, whatever states the cycle held them in; the others keep theirs."""
    system, pairs = four_pairs()
    cycling = CoulombJoints.bonded(4)
    cycling.state[1] = OPEN
    solved = CycleCondenser(system, reuse=False).condensed(0.0, cycling, pairs, np.zeros(4), cycling)
    assert list(solved.state) == [STICK, STICK, STICK, OPEN]
    assert system.stats["condensation_solves"] == system.stats["solves"] == 5
