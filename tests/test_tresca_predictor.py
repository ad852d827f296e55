"""The Tresca QP and its Coulomb fixed point (bridgefem.solver.tresca) against a block on the ground, by hand.

One node (u_x, u_y) held by springs k_x, k_y (N/m), on the ground through one pair whose normal is +y (d_n = u_y,
opening) and tangent +x (d_t = u_x); loads H along x and -W along y (N), friction mu. By hand (Coulomb, no
dilatancy): the pair stays closed (u_y = 0, lam_n = W); for H < mu W it sticks (u_x = 0, lam_t = -H: the friction
force opposes the push); for H > mu W it slides, u_x = (H - mu W) / k_x and lam_t = -mu W. A load P lifting the node
opens the pair: u_y = P / k_y, no joint force.

End to end, a ring whose rigid-block mechanism slides: its failed trials are solved once more from the fixed point.
"""
import numpy as np
import pytest
import scipy.sparse as sp
from conftest import campaign_scene

from bridgefem.analysis.runner import run_analysis
from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.reader import scene_from_dict
from bridgefem.solver.tresca import TrescaProblem
from bridgefem.status import Status

K_X, K_Y, MU, W = 2.0e8, 5.0e8, 0.6, 1.0e4
K = sp.diags([K_X, K_Y]).tocsr()
G = sp.csr_matrix(np.array([[0.0, 1.0], [1.0, 0.0]]))  # rows: normal, tangential of the one pair
BLOCK = TrescaProblem(K, G)
NO_OFFSET, NO_SLIP = np.zeros((1, 2)), np.zeros(1)


def law(cohesion: float = 0.0) -> CoulombJoints:
    """The Coulomb law at the one pair, with a cohesion (N)."""
    return CoulombJoints(np.array([MU]), np.array([K_Y]), 1e-9 * W, cohesion=np.array([cohesion]))


def fixed_point(push: float, lift: float = -W, cohesion: float = 0.0):
    """The Coulomb fixed point from a start without joint force (its first capacity is the cohesion, or the
    floor)."""
    return BLOCK.coulomb_fixed_point(np.array([push, lift]), NO_OFFSET, NO_SLIP, law(cohesion), np.zeros(1))


def test_block_sticks_below_its_sliding_load():
    step = fixed_point(0.5 * MU * W)
    assert step is not None
    assert step.lam_n[0] == pytest.approx(W, rel=1e-6)
    assert step.lam_t[0] == pytest.approx(-0.5 * MU * W, rel=1e-6)
    assert abs(step.u[0]) < 1e-6 * MU * W / K_X and abs(step.u[1]) < 1e-6 * W / K_Y


def test_block_slides_past_its_sliding_load_without_dilatancy():
    step = fixed_point(2.0 * MU * W)
    assert step is not None
    assert step.u[0] == pytest.approx(MU * W / K_X, rel=1e-6)  # (H - mu W) / k_x
    assert step.lam_t[0] == pytest.approx(-MU * W, rel=1e-6)
    assert step.lam_n[0] == pytest.approx(W, rel=1e-6)
    assert abs(step.u[1]) < 1e-6 * W / K_Y  # no opening while it slides


@pytest.mark.parametrize("share", [0.5, 2.0])
def test_cohesion_adds_to_the_shear_the_block_carries(share):
    """With a cohesion k (N) the block sticks below H = mu W + k and slides past it with lam_t = -(mu W + k)."""
    k = 0.4 * MU * W
    push = share * (MU * W + k)
    step = fixed_point(push, cohesion=k)
    assert step is not None and step.lam_n[0] == pytest.approx(W, rel=1e-6)
    assert step.lam_t[0] == pytest.approx(-min(push, MU * W + k), rel=1e-6)
    assert step.u[0] == pytest.approx(max(push - MU * W - k, 0.0) / K_X, rel=1e-6, abs=1e-6 * W / K_X)


def test_lifted_block_keeps_its_cohesion():
    """Lifted off the ground (open) the block still carries a push below its cohesion k: u_x = 0, lam_t = -H."""
    k, push = 0.3 * W, 0.2 * W
    step = fixed_point(push, lift=3.0e3, cohesion=k)
    assert step is not None and abs(step.lam_n[0]) < 1e-6 * W
    assert step.u[1] == pytest.approx(3.0e3 / K_Y, rel=1e-6)
    assert step.lam_t[0] == pytest.approx(-push, rel=1e-6) and abs(step.u[0]) < 1e-6 * W / K_X


def test_lifted_block_opens_with_no_joint_force():
    step = BLOCK.step(np.array([0.0, 3.0e3]), NO_OFFSET, NO_SLIP, np.array([MU * W]))
    assert step is not None
    assert step.u[1] == pytest.approx(3.0e3 / K_Y, rel=1e-6)
    assert abs(step.lam_n[0]) < 1e-6 * 3.0e3 and abs(step.lam_t[0]) < 1e-6 * 3.0e3


class PanicException(BaseException):
    """Named as pyo3 names a Rust panic, which derives from BaseException, not Exception."""


class Raising:
    """Stands in for clarabel.DefaultSolver: building it raises ``error``."""

    error: BaseException = PanicException("index out of bounds")

    def __init__(self, *args):
        raise self.error


def test_a_clarabel_panic_is_no_prediction_and_no_crash(monkeypatch):
    import clarabel
    monkeypatch.setattr(clarabel, "DefaultSolver", Raising)
    assert BLOCK.step(np.array([1.0, -W]), NO_OFFSET, NO_SLIP, np.array([MU * W])) is None
    assert fixed_point(0.5 * MU * W) is None


def test_a_clarabel_panic_is_a_conic_solver_failure_and_an_interrupt_is_not_caught(monkeypatch):
    import clarabel

    from bridgefem.limit.conic import NONNEG, ConicProgramme
    programme = ConicProgramme(1)
    programme.add(NONNEG, [0], [0], [1.0], [1.0])  # x <= 1
    monkeypatch.setattr(clarabel, "DefaultSolver", Raising)
    solution = programme.solve(np.array([-1.0]), np.ones(1))
    assert solution.status == "solver failure: Clarabel raised PanicException: index out of bounds"
    assert solution.x is None
    monkeypatch.setattr(Raising, "error", KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt):
        programme.solve(np.array([-1.0]), np.ones(1))


@pytest.mark.slow
def test_a_ring_whose_mechanism_slides_reaches_its_limit_through_predicted_trials():
    """Campaign seed 9, scene 159 (pointed, span 4.93 m, t = 0.571 m, 179 voussoirs of 0.049 m, mu = 0.331, a point
    load at 0.289 of the span): the rigid-block LP on the same joints (computed here independently) hinges at joints
    74 and 145 and slides at 69 and the springing 179. Its failed trials are solved once more from the Tresca fixed
    point (bridgefem.solver.tresca): the limit within 0.05 % of that LP (the associative and the non-associative
    rigid-block loads coincide here). (Its solves against the issue's 150, 246 when the fixed point was used only on
    rings whose mechanism does not slide: benchmarks/solve_budgets.py.)"""
    scene = scene_from_dict(campaign_scene(159, 0.5711, seed=9))
    lp = collapse_load(scene)
    assert lp.sliding == [69, 179] and collapse_load(scene, friction_model="non-associative").load == \
        pytest.approx(lp.load, rel=1e-9)
    an = run_analysis(scene)
    assert an.search.status == Status.LIMIT
    lower, upper = an.search.lower * an.load_total, an.search.upper * an.load_total
    assert lower == pytest.approx(lp.load, rel=5e-4) and upper == pytest.approx(lp.load, rel=5e-4)
