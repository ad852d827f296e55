"""The joint law at a few pairs on a made-up compliance d = d0 + C lam, against answers derived by hand."""
import numpy as np
import pytest

from bridgefem.contact import OPEN, SLIP, STICK, ContactState, CoulombJoints
from bridgefem.joint_condensation import consistent_states, is_p_matrix

NANO = 1e-9  # m/N


def law(pairs, mu=0.3):
    return CoulombJoints(np.full(pairs, mu), np.full(pairs, 1e9), 1e-3)


def states(*pairs):
    return ContactState(np.array([s for s, _ in pairs], dtype=np.int8), np.array([g for _, g in pairs], dtype=np.int8))


def solve(d0, C, mu=0.3, reference=None):
    p = len(d0)
    reference = reference or ContactState.all_stick(p)
    return consistent_states(law(p, mu), np.array(d0, dtype=float), np.array(C, dtype=float) * NANO, reference,
                             reference)


def test_penetrating_pair_closes_and_sticks():
    """Open it would penetrate 1 um; closed, C_nn lam_n = 1 um gives lam_n = 1000 N, no shear."""
    active, lam = solve([[-1e-6, 0.0]], np.eye(2))
    assert (active.state[0], active.sign[0]) == (STICK, 0)
    assert lam == pytest.approx(np.array([[1000.0, 0.0]]), abs=1e-6)


def test_pair_with_a_gap_opens():
    """Closed it would carry lam_n = -1000 N (tension); open it has a 1 um gap."""
    active, lam = solve([[1e-6, 0.0]], np.eye(2))
    assert active.state[0] == OPEN and not lam.any()


def test_pair_slides_against_the_friction_force():
    """Stick needs lam_t = -2000 N > mu lam_n = 500 N; slip- gives lam_t = -500 N and the slip
    2 um - 0.5 um = 1.5 um > 0, opposite to lam_t (slip+ would need a negative slip: 2.5 um)."""
    active, lam = solve([[-1e-6, 2e-6]], np.eye(2), mu=0.5)
    assert (active.state[0], active.sign[0]) == (SLIP, -1)
    assert lam == pytest.approx(np.array([[1000.0, -500.0]]), rel=1e-9)


def test_shear_coupled_pair_slides():
    """C = [[1, 2], [2, 5]] nm/N: stick needs lam = (5000, -2000) N, outside mu = 0.3; slip- gives
    lam_n (1 - 0.6) nm/N = 1 um, lam = (2500, -750) N, slip 2 x 2500 - 5 x 750 = 1.25 um > 0 (consistent);
    slip+ gives lam_n = 625 N and a positive slip, against its friction force."""
    active, lam = solve([[-1e-6, 0.0]], [[1.0, 2.0], [2.0, 5.0]])
    assert (active.state[0], active.sign[0]) == (SLIP, -1)
    assert lam == pytest.approx(np.array([[2500.0, -750.0]]), rel=1e-9)


def test_negative_normal_compliance_has_no_consistent_state():
    """C_nn = -1 nm/N (not a P-matrix): open penetrates 1 um, closed carries -1000 N: no state fits."""
    assert solve([[-1e-6, 0.0]], [[-1.0, 0.0], [0.0, 1.0]]) is None


@pytest.mark.parametrize("start", [OPEN, STICK])
def test_two_consistent_states_keep_the_reference(start):
    """C_nn = -1 nm/N with a 1 um gap: open (gap) and closed (lam_n = +1000 N) are both consistent; the one of the
    reference active set is kept."""
    active, _ = solve([[1e-6, 0.0]], [[-1.0, 0.0], [0.0, 1.0]], reference=states((start, 0)))
    assert active.state[0] == start


@pytest.mark.parametrize("matrix, expected", [
    ([[2.0, 1.0], [1.0, 2.0]], True),  # minors 2, 2, 3
    ([[1.0, 2.0], [0.0, 1.0]], True),  # not symmetric, minors 1, 1, 1
    ([[1.0, 2.0], [1.0, 1.0]], False),  # det -1
    ([[-1.0]], False),
    ([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]], False),  # one negative diagonal entry
])
def test_p_matrix(matrix, expected):
    """Every principal minor positive, checked on matrices whose minors are counted by hand."""
    assert is_p_matrix(np.array(matrix)) is expected


def test_two_coupled_pairs():
    """Normal compliances [[2, 1], [1, 2]] nm/N, d0_n = (-1, +0.4) um: both closed give lam_n = (800, -600) N
    (tension at the second); the first closed alone carries 500 N and opens the second's gap to 0.9 um."""
    C = [[2.0, 0.0, 1.0, 0.0], [0.0, 2.0, 0.0, 0.0], [1.0, 0.0, 2.0, 0.0], [0.0, 0.0, 0.0, 2.0]]
    active, lam = solve([[-1e-6, 0.0], [0.4e-6, 0.0]], C)
    assert list(active.state) == [STICK, OPEN]
    assert lam == pytest.approx(np.array([[500.0, 0.0], [0.0, 0.0]]), abs=1e-6)


def test_condensed_compliance_reproduces_the_full_solve():
    """The standing block of tests/test_block.py pushed at half its tipping load: the base pairs' response condensed
    from open (d = d0 + C lam, :meth:`ContactSolver._pair_response`) with the converged forces at two base pairs gives
    back their converged relative displacements (closed, no slip), and their consistent state is the converged one
    with the same forces: superposition on the full linear system, independent of the active-set iteration."""
    from test_block import B, RHO, W, standing_block

    from bridgefem.contact import build_pairs
    from bridgefem.mesh import build_block_mesh
    from bridgefem.model import build_elastic_model
    from bridgefem.scene import scene_from_dict
    from bridgefem.solver import ContactSolver

    scene = scene_from_dict({"arch": {"shape": "segmental", "span": 1.0, "rise": 0.5, "thickness": 0.2,
                                      "voussoirs": 2}, "masonry": {"young": 1e9, "poisson": 0.2, "density": RHO},
                             "joints": {"friction": 2.0}})
    ring = standing_block(1.5)
    bm = build_block_mesh(ring, 8)
    model = build_elastic_model(bm, ring, scene)
    xy = model.V.tabulate_dof_coordinates()[:model.V.dofmap.index_map.size_local, :2]
    at = np.flatnonzero(np.linalg.norm(xy - [-B / 2, 1.5], axis=1) < 1e-9)
    with model.f_live.localForm() as loc:
        loc.array[2 * at] += 1.0 / bm.mesh.comm.allreduce(len(at))
    pairs = build_pairs(model.V, bm, ring, 1e-9)
    solver = ContactSolver(model.K, model.f_dead, model.f_live, pairs, 2.0, 1e9 * pairs.length / bm.element_size,
                           1e-10 * W, 60, {})
    level = 0.5 * W * B / (2 * 1.5)
    start = solver.converged_slip_reference(solver.solve_step(0.0, solver.initial_iterate()).iterate)
    out = solver.solve_step(level, start)
    assert out.converged, out.reason
    _, lam, d = solver.split(out.iterate.x)
    closed = np.flatnonzero(out.iterate.active.state != OPEN)
    chosen = np.zeros(len(pairs), dtype=bool)
    chosen[closed[[0, len(closed) // 2]]] = True
    d0, C = solver._pair_response(level, out.iterate.active, chosen, start.slip_ref)
    predicted = d0.ravel() + C @ lam[chosen].ravel()
    assert np.all(lam[chosen][:, 0] > 0) and np.abs(d0).max() > 0  # compressed, and penetrating when open
    assert predicted == pytest.approx(np.zeros(4), abs=1e-6 * np.abs(d0).max())
    law = CoulombJoints(np.full(2, 2.0), solver.law.c[chosen], solver.law.force_tol)
    converged = ContactState(out.iterate.active.state[chosen], out.iterate.active.sign[chosen])
    active, forces = consistent_states(law, d0, C, converged, converged)
    assert list(active.state) == list(out.iterate.active.state[chosen])
    assert forces == pytest.approx(lam[chosen], rel=1e-6, abs=1e-6 * W)
