"""The joint law at a few pairs on a made-up compliance d = d0 + C lam, against answers derived by hand."""
import numpy as np
import pytest

from bridgefem.laws.coulomb import ContactState, CoulombJoints
from bridgefem.solver.condensation import consistent_states, is_p_matrix, lcp_active_set, lemke, opens_when_pulled

OPEN, STICK, SLIP = CoulombJoints.OPEN, CoulombJoints.STICK, CoulombJoints.SLIP

NANO = 1e-9  # m/N


def law(pairs, mu=0.3):
    return CoulombJoints(np.full(pairs, mu), np.full(pairs, 1e9), 1e-3)


def states(*pairs):
    return ContactState(np.array([s for s, _ in pairs], dtype=np.int8), np.array([g for _, g in pairs], dtype=np.int8))


def solve(d0, C, mu=0.3, reference=None):
    p = len(d0)
    reference = reference or CoulombJoints.bonded(p)
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
    from open (d = d0 + C lam, :meth:`bridgefem.solver.cycles.CycleCondenser.pair_response`) with the converged forces at
    two base pairs gives back their converged relative displacements (closed, no slip), and their consistent state is
    the converged one with the same forces: superposition on the full linear system, independent of the active-set
    iteration."""
    from test_block import RHO, B, W, standing_block

    from bridgefem.fe.mesh import build_block_mesh
    from bridgefem.fe.model import build_elastic_model
    from bridgefem.fe.pairs import build_pairs
    from bridgefem.scene.reader import scene_from_dict
    from bridgefem.solver.newton import ContactSolver

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
    law = CoulombJoints.for_pairs(pairs, 2.0, 1e9 * pairs.length / bm.element_size, 1e-10 * W)
    solver = ContactSolver(model.K, model.f_dead, model.f_live, pairs, law, 60, {})
    level = 0.5 * W * B / (2 * 1.5)
    start = solver.converged_slip_reference(solver.solve_step(0.0, solver.initial_iterate()).iterate)
    out = solver.solve_step(level, start)
    assert out.converged, out.reason
    _, lam, d = solver.system.split(out.iterate.x)
    closed = np.flatnonzero(out.iterate.active.state != OPEN)
    chosen = np.zeros(len(pairs), dtype=bool)
    chosen[closed[[0, len(closed) // 2]]] = True
    d0, C = solver.cycles.pair_response(level, out.iterate.active, chosen, start.slip_ref)
    predicted = d0.ravel() + C @ lam[chosen].ravel()
    assert np.all(lam[chosen][:, 0] > 0) and np.abs(d0).max() > 0  # compressed, and penetrating when open
    assert predicted == pytest.approx(np.zeros(4), abs=1e-6 * np.abs(d0).max())
    law = CoulombJoints(np.full(2, 2.0), solver.law.c[chosen], solver.law.force_tol)
    converged = ContactState(out.iterate.active.state[chosen], out.iterate.active.sign[chosen])
    active, forces = consistent_states(law, d0, C, converged, converged)
    assert list(active.state) == list(out.iterate.active.state[chosen])
    assert forces == pytest.approx(lam[chosen], rel=1e-6, abs=1e-6 * W)


@pytest.mark.parametrize("d0, C, mu, expected", [
    ([[-1e-6, 0.0]], np.eye(2), 0.3, [(STICK, 0)]),  # the cases above, one pair: the same active sets
    ([[1e-6, 0.0]], np.eye(2), 0.3, [(OPEN, 0)]),
    ([[-1e-6, 2e-6]], np.eye(2), 0.5, [(SLIP, -1)]),
    ([[-1e-6, 0.0]], [[1.0, 2.0], [2.0, 5.0]], 0.3, [(SLIP, -1)]),
    ([[-1e-6, 0.0], [0.4e-6, 0.0]], [[2.0, 0.0, 1.0, 0.0], [0.0, 2.0, 0.0, 0.0], [1.0, 0.0, 2.0, 0.0],
                                     [0.0, 0.0, 0.0, 2.0]], 0.3, [(STICK, 0), (OPEN, 0)]),
])
def test_lemke_finds_the_hand_derived_states(d0, C, mu, expected):
    """Lemke's method on the Coulomb LCP gives the unique consistent active set of each hand-derived case above."""
    found = lcp_active_set(law(len(d0), mu), np.array(d0, dtype=float), np.array(C, dtype=float) * NANO)
    assert list(zip(found.state, found.sign)) == expected


def test_lemke_on_a_textbook_lcp():
    """w = q + M z with M = [[2, 1], [1, 2]], q = (-5, -6): both unknowns positive, 2 z1 + z2 = 5, z1 + 2 z2 = 6,
    z = (4/3, 7/3); and w = -1 - z (no z >= 0 gives w >= 0) ends on a ray."""
    assert lemke(np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-5.0, -6.0])) == pytest.approx([4 / 3, 7 / 3])
    assert lemke(np.array([[-1.0]]), np.array([-1.0])) is None


def coupled_ring(pairs=20, opening=5, coupling=0.5):
    """``pairs`` pairs whose normal compliances are coupled through one shared term, C_nn = I + a 1 1^T nm/N
    (C_tt = I, C_nt = 0); d0_n = +1 um (a gap) at the first ``opening`` pairs, -1 um at the others, and d0_t = 2 um at
    every other closed pair."""
    C = np.eye(2 * pairs)
    C[0::2, 0::2] += coupling
    d0 = np.zeros((pairs, 2))
    d0[:, 0] = np.where(np.arange(pairs) < opening, 1e-6, -1e-6)
    d0[opening::2, 1] = 2e-6
    return d0, C * NANO


def test_twenty_coupled_pairs():
    """20 pairs (4^20 = 1e12 combinations): with the first 5 open, the 15 closed carry lam_n from
    (1 + a 15) lam_n = 1 um / 1 nm/N, lam_n = 1000 / 8.5 = 117.65 N, and the open ones' gap grows to
    1 + 0.5 x 15 x 0.11765 = 1.88 um > 0 (consistent). A closed pair with d0_t = 2 um would need lam_t = -2000 N to
    stick, beyond mu lam_n = 35.3 N: it slides (slip-) with lam_t = -35.3 N and slip 2 um - 35.3 nm > 0; the others
    stick with lam_t = 0. The normal block is a P-matrix (its symmetric part is positive definite)."""
    d0, C = coupled_ring()
    active, lam = consistent_states(law(20), d0, C, CoulombJoints.bonded(20), CoulombJoints.bonded(20))
    lam_n = 1000.0 / 8.5
    sliding = np.zeros(20, dtype=bool)
    sliding[5::2] = True
    assert list(active.state[:5]) == [OPEN] * 5
    assert np.all(active.state[5:][sliding[5:]] == SLIP) and np.all(active.sign[sliding] == -1)
    assert np.all(active.state[5:][~sliding[5:]] == STICK)
    assert lam[5:, 0] == pytest.approx(np.full(15, lam_n), rel=1e-9)
    assert lam[:, 1] == pytest.approx(np.where(sliding, -0.3 * lam_n, 0.0), abs=1e-6)
    assert opens_when_pulled(C)


def test_twenty_pairs_one_with_negative_normal_compliance():
    """The 20 pairs above with pair 7's normal compliance -1 nm/N beyond the coupling, decoupled from the others
    (not a P-matrix): open it penetrates 1 um, closed it carries -1000 N (tension), whatever the others do: no
    consistent active set, and the condensation is declined before it is solved."""
    d0, C = coupled_ring()
    C[14, :], C[:, 14] = 0.0, 0.0
    C[14, 14] = -NANO
    assert consistent_states(law(20), d0, C, CoulombJoints.bonded(20), CoulombJoints.bonded(20)) is None
    assert not opens_when_pulled(C)


def test_reference_kept_when_consistent_above_enumeration():
    """Five uncoupled copies of the pair with C_nn = -1 nm/N and a 1 um gap, open and closed both consistent at each:
    with more pairs than are enumerated, the reference active set (all closed) is kept as it is."""
    C = np.kron(np.eye(5), np.diag([-1.0, 1.0])) * NANO
    d0 = np.tile([1e-6, 0.0], (5, 1))
    active, lam = consistent_states(law(5), d0, C, CoulombJoints.bonded(5), CoulombJoints.bonded(5))
    assert list(active.state) == [STICK] * 5 and lam[:, 0] == pytest.approx(np.full(5, 1000.0))
