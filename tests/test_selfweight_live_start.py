"""The live load's start after the self-weight (bridgefem/solver.py, ``ContactSolver.converged_slip_reference`` with
``live_load``): sliding pairs that a live-load increment would slide backwards stick, the state itself unchanged."""
import numpy as np
import pytest

from bridgefem.contact import SLIP, STICK

from test_block import W, block_solver

PUSH = 0.3  # of the weight W: the elastic block at mu = 0.4 sticks as a whole (sliding needs 0.4 W), its base's
# trailing pairs slide


@pytest.fixture
def pushed():
    """The elastic block on the ground (tests/test_block.py), mu = 0.4, pushed in +x by 0.3 W at h = 0.5 m from its
    self-weight state: a converged state with some base pairs sliding in the push's sense."""
    solver, _ = block_solver(0.4, 0.5, elements=4)
    weight = solver.solve_step(0.0, solver.initial_iterate())
    out = solver.solve_step(PUSH * W, solver.converged_slip_reference(weight.iterate))
    assert out.converged, out.reason
    assert np.any(out.iterate.active.state == SLIP)
    return solver, out.iterate


def test_a_live_load_that_drives_the_slip_on_keeps_the_pairs_sliding(pushed):
    """A further push in +x slides the sliding pairs further (their friction force is at the cone's edge and the
    sticking pairs carry the rest elastically): the start keeps every pair's state."""
    solver, it = pushed
    start = solver.converged_slip_reference(it, live_load=True)
    assert np.array_equal(start.active.state, it.active.state) and np.array_equal(start.active.sign, it.active.sign)


def test_a_live_load_that_reverses_the_slip_makes_the_pairs_stick(pushed):
    """A push in -x unloads the base's friction: every sliding pair sticks, no other pair changes, and the start is
    the same converged state (displacements, forces, slip reference): solved again at the push that reached it, it
    converges in one Newton iteration on the start's active set."""
    solver, it = pushed
    plain = solver.converged_slip_reference(it)
    solver.f_live.scale(-1.0)
    start = solver.converged_slip_reference(it, live_load=True)
    solver.f_live.scale(-1.0)
    sliding = it.active.state == SLIP
    assert np.all(start.active.state[sliding] == STICK) and np.all(start.active.sign[sliding] == 0)
    assert np.array_equal(start.active.state[~sliding], it.active.state[~sliding])
    assert np.array_equal(start.slip_ref, plain.slip_ref) and start.x is it.x
    again = solver.solve_step(PUSH * W, start)
    assert again.converged and again.iterations == 1, again.reason
    assert np.array_equal(again.iterate.active.state, start.active.state)
    assert np.allclose(again.iterate.x.array, it.x.array, rtol=1e-9, atol=1e-12 * np.abs(it.x.array).max())


@pytest.mark.slow
def test_the_live_load_goes_on_at_once_after_the_friction_continuation():
    """Campaign seed 1, scene 76 (elliptical, 145 voussoirs, mu = 0.582, 8 elements through the thickness): the one
    self-weight step fails and the friction continuation carries the self-weight with about 200 pairs sliding. The
    first live-load trial after it converges (from the converged active set, it and six halvings down to 1/64 of it
    each diverged after reversing slips). The bracket closes on the static theorem's bound (the LP under the FE's own
    loads), at most 1.005 x the associative rigid-block LP on the same joints (computed here), its lower end within
    1 % of it (a joint slides: the FE's non-associative friction may stop below the associative LP)."""
    from bridgefem.analysis import run_analysis
    from bridgefem.rigid_block import collapse_load
    from bridgefem.scene import scene_from_dict
    from bridgefem.status import Status

    from conftest import campaign_scene

    scene = scene_from_dict({**campaign_scene(76, 2.4907), "mesh": {"elements_through_thickness": 8}})
    an = run_analysis(scene)
    steps = an.search.steps
    live = next(i for i, s in enumerate(steps) if s.level > 0)
    assert any(s.friction_factor is not None for s in steps[:live]) and steps[live - 1].converged
    assert steps[live].converged, steps[live].reason
    assert an.search.status == Status.LIMIT
    lp = collapse_load(scene).load
    assert an.search.static and an.search.upper * an.load_total <= 1.005 * lp
    assert an.search.lower * an.load_total >= 0.99 * lp
