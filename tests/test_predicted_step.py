"""Newton iterations that start from a predicted active set, and the ranking of proposed changes for damping
(bridgefem/solver/newton.py, *Predictor* and step 3; bridgefem/fe/pairs.py, ``CoulombJoints.classify``)."""

import numpy as np
import pytest
from conftest import run_campaign_scene
from test_block import W, block_solver

from bridgefem.laws.coulomb import ContactState, CoulombJoints

OPEN, STICK, SLIP = CoulombJoints.OPEN, CoulombJoints.STICK, CoulombJoints.SLIP


def test_a_predicted_step_may_return_to_the_start_active_set():
    """The elastic block on the ground (tests/test_block.py) at mu = 0.4, pushed by P = 0.2 W at h = 0.5 m from its
    self-weight state: it sticks (sliding needs mu W = 0.4 W, tipping W b / (2 h) = W). A predictor proposes every
    base pair sliding: that system lets the block slide freely (it diverges); damping returns to every pair sticking,
    the converged start's active set, which was not solved at this load. Counted as a cycle, that return would end the
    step as a mechanism ("damped iterations return to it") at half the sliding load; the step converges, the base
    carrying P in shear and W in compression (equilibrium of the block, closed form) with every pair sticking."""
    solver, _ = block_solver(0.4, 0.5, elements=4)
    weight = solver.solve_step(0.0, solver.initial_iterate())
    assert weight.converged, weight.reason
    start = solver.converged_slip_reference(weight.iterate)
    predictor = start.x.copy()
    lam = predictor.array[solver.n_u:].reshape(-1, 2)
    lam[:, 1] = 0.8 * lam[:, 0]  # twice the friction cone's edge: every base pair proposed to slide
    out = solver.solve_step(0.2 * W, start, predictor, give_up=True)
    assert out.converged and not out.mechanism, out.reason
    _, lam, _ = solver.system.split(out.iterate.x)
    assert np.all(out.iterate.active.state == STICK)
    assert abs(lam[:, 1].sum()) == pytest.approx(0.2 * W, rel=1e-9)
    assert lam[:, 0].sum() == pytest.approx(W, rel=1e-9)


def test_damping_ranks_friction_changes_by_the_cone_not_by_the_normal_force():
    """Two closed sticking pairs proposed to slide, made up: pair 0 carries 100 kN in compression and exceeds its
    friction cone (mu 0.5) by 1 N, pair 1 carries 10 kN and exceeds it by 2 kN; a third, open, closes under a
    1.5 kN contact force (it penetrates 1.5 um at c = 1e9 N/m). The violation that ranks them for damping is the distance from the law each change leaves:
    the cone's excess for a friction change, the contact force for a closing pair: 1 N, 2 kN and 1.5 kN."""
    law = CoulombJoints(np.full(3, 0.5), np.full(3, 1e9), 1e-6)
    prev = ContactState(np.array([STICK, STICK, OPEN], dtype=np.int8), np.zeros(3, dtype=np.int8))
    lam = np.array([[100e3, 50e3 + 1.0], [10e3, 7e3], [0.0, 0.0]])
    d = np.array([[0.0, 0.0], [0.0, 0.0], [-1.5e-6, 0.0]])
    new, violation = law.classify(prev, lam, d, np.zeros(3))
    assert list(new.state) == [SLIP, SLIP, STICK]
    assert violation == pytest.approx([1.0, 2e3, 1.5e3])


@pytest.mark.slow
def test_seed_2_scene_66_reaches_the_lp_limit(tmp_path):
    """Campaign seed 2, scene 66 (elliptical, 22 voussoirs, mu 0.5, point load at 0.40 of the span): it stopped at
    0.81 kN where the LP on the same joints gives 105.6 kN (a solver failure), its trials failing where a predicted
    step's repair, every pair of the right springing sticking, was its start's active set. Now a limit whose bracket
    reaches within 0.5 % of the LP (its agreement: the evidence rule)."""
    run_campaign_scene(tmp_path, 66, 2.2665, seed=2)
