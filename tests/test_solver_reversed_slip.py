"""A reversed slip is proposed as stick (bridgefem/solver/newton.py, *Reversed slips*): a path choice of the Newton method
that must leave what counts as converged, the fixed points of the joint law's classification, unchanged."""
import numpy as np

from bridgefem.laws.coulomb import ContactState, CoulombJoints

OPEN, STICK, SLIP = CoulombJoints.OPEN, CoulombJoints.STICK, CoulombJoints.SLIP


def random_pairs(rng: np.random.Generator, n: int) -> tuple[CoulombJoints, ContactState, np.ndarray, np.ndarray]:
    """Made-up pairs: states open / stick / slip +- at random, forces (N) and relative displacements (m) around the
    friction cone's edge and the contact's onset, so that every change the law can propose occurs."""
    law = CoulombJoints(rng.uniform(0.3, 2.0, n), np.full(n, 1e9), 1e-3)
    state = rng.choice([OPEN, STICK, SLIP], n).astype(np.int8)
    sign = np.where(state == SLIP, rng.choice([-1, 1], n), 0).astype(np.int8)
    lam_n = rng.uniform(-1e3, 1e4, n)
    lam = np.column_stack([lam_n, rng.uniform(-2.0, 2.0, n) * law.mu * np.abs(lam_n)])
    d = rng.normal(0.0, 1e-6, (n, 2))
    return law, ContactState(state, sign), lam, d


def test_a_reversed_slip_sticks_and_nothing_else_changes():
    """Over 2000 made-up pairs: where the law proposes that a sliding pair slide the other way, the proposal is
    stick; everywhere else it is the law's own."""
    law, prev, lam, d = random_pairs(np.random.default_rng(12), 2000)
    new, _ = law.classify(prev, lam, d, np.zeros(len(lam)))
    reversed_slip = (prev.state == SLIP) & (new.state == SLIP) & (new.sign != prev.sign)
    assert reversed_slip.sum() > 50  # the campaign of made-up pairs does reach the case
    proposed = new.copy()
    law.hold_reversals(proposed, prev)
    assert np.all(proposed.state[reversed_slip] == STICK) and np.all(proposed.sign[reversed_slip] == 0)
    assert np.array_equal(proposed.state[~reversed_slip], new.state[~reversed_slip])
    assert np.array_equal(proposed.sign[~reversed_slip], new.sign[~reversed_slip])


def test_the_proposal_keeps_the_laws_fixed_points():
    """A step converges when the proposal changes no pair: over 20 seeds of 500 made-up pairs, a pair's proposal
    keeps its state exactly where the law's classification does (same fixed points, so the same converged states)."""
    for seed in range(20):
        law, prev, lam, d = random_pairs(np.random.default_rng(seed), 500)
        new, _ = law.classify(prev, lam, d, np.zeros(len(lam)))
        proposed = new.copy()
        law.hold_reversals(proposed, prev)
        kept_by_law = (new.state == prev.state) & (new.sign == prev.sign)
        kept = (proposed.state == prev.state) & (proposed.sign == prev.sign)
        assert np.array_equal(kept, kept_by_law)
