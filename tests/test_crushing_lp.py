"""Crushing in the rigid-block LP (issue 39): closed forms of a block on the ground, a flat two-block arch and a
joint whose thrust sits at its middle, each derived by hand (statics of a rectangular stress block of f_c), the LP
within 1e-6; the tangent rows' error bound (bridgefem.laws.crushing); the scene key reaching the LP, the least
thickness and the deficit programmes; and without the key every row Coulomb's to the last bit."""
import dataclasses

import numpy as np
import pytest

from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.laws.crushing import CrushingJoints, scene_law
from bridgefem.limit.collapse import collapse_load
from bridgefem.limit.rigid_block import (
    BlockModel,
    _Programme,
    generalised_loads,
    solve_blocks,
    standing_deficit,
    statics,
)
from bridgefem.limit.thickness import min_thickness
from bridgefem.scene.reader import scene_from_dict

FINE = 2048  # tangent intervals: the rows within 1/FINE^2 = 2.4e-7 of the parabola's largest moment


def block_on_ground(b=0.6, H=1.2, W=5e3, fc=2e5, w=1.0, tangents=FINE, push="side"):
    """A rigid block of width b (m) and height H on the ground joint, weight W (N) at its centre; live load: a unit
    horizontal force at the top (``side``) or a unit vertical one at the top's middle (``centre``)."""
    ref = np.array([[0.0, H / 2]])
    dead = generalised_loads(ref, [0], ref, [[0.0, -W]])
    live = generalised_loads(ref, [0], [[0.0, H]], [[1.0, 0.0]] if push == "side" else [[0.0, -1.0]])
    law = CrushingJoints.blocks(fc, w, tangents) if fc is not None else CoulombJoints
    return BlockModel(ref, dead, live, joint_a=np.array([[b / 2, 0.0]]), joint_b=np.array([[-b / 2, 0.0]]),
                      joint_left=np.array([-1]), joint_right=np.array([0]), friction=np.array([100.0]), law=law)


def test_a_block_pushed_sideways_topples_at_w_b_minus_w_over_fc_w_over_2h():
    """Toppling about a stress block of depth W/(f_c w) at the edge: H_collapse = W (b - W/(f_c w)) / (2 H)."""
    b, H, W, fc = 0.6, 1.2, 5e3, 2e5
    lp = solve_blocks(block_on_ground(b, H, W, fc))
    assert lp.level == pytest.approx(W * (b - W / fc) / (2 * H), rel=1e-6)
    assert lp.hinges == [0]
    strong = solve_blocks(block_on_ground(b, H, W, None))
    assert strong.level == pytest.approx(W * b / (2 * H), rel=1e-9)


def test_the_tangent_rows_overstate_the_moment_by_at_most_their_stated_bound():
    """K tangents: the LP between the parabola's answer and that plus delta / H, delta = f_c w b^2 / (8 K^2); the
    coarsest (K = 1, a pair at each edge) and a fine one."""
    b, H, W, fc = 0.6, 1.2, 5e3, 2e5
    exact = W * (b - W / fc) / (2 * H)
    for k in (1, 3, 8, 64):
        level = solve_blocks(block_on_ground(b, H, W, fc, tangents=k)).level
        assert exact * (1 - 1e-9) <= level <= exact + fc * b ** 2 / (8 * k * k) / H * (1 + 1e-9)
    law = CrushingJoints.blocks(fc, 1.0, 8)
    n = np.linspace(0, fc * b, 1601)
    gap = law.moment_capacity(np.full(1601, b), n) - law.largest_moment(np.full(1601, b), n)
    assert gap.min() >= -1e-9 and gap.max() == pytest.approx(fc * b ** 2 / (8 * 64), rel=1e-9)


def test_the_conic_bounds_take_the_parabola_exactly():
    """The toppling block as a bare problem of the conic bounds (no soil: both bounds the rigid-block programme on
    the law's conic rows, CrushingJoints.conic and its cones): W (b - W/(f_c w)) / (2 H) to 1e-6, both."""
    from bridgefem.limit.bounds import problem_bounds
    from bridgefem.limit.bounds_model import LimitProblem
    b, H, W, fc = 0.6, 1.2, 5e3, 2e5
    exact = W * (b - W / fc) / (2 * H)
    bounds = problem_bounds(LimitProblem(block_on_ground(b, H, W, fc, tangents=8), 1.0, 1.0))
    assert bounds.lower.load == pytest.approx(exact, rel=1e-6)
    assert bounds.upper.load == pytest.approx(exact, rel=1e-6)
    assert CoulombJoints.conic() is CoulombJoints and CoulombJoints.block_cones(np.ones(2)) is None


def test_a_bare_crushing_ring_lies_between_its_conic_bounds():
    """Without a fill both conic bounds take the exact parabola, so they agree (1e-6) and the LP on its 128 tangents
    lies above them by at most sum_j delta_j |theta_j| (delta_j = f_c w t_j^2 / (8 K^2); theta_j the LP mechanism's
    hinge rotations per unit live-load work)."""
    from bridgefem.limit.bounds import collapse_bounds
    from bridgefem.structure.ring import scene_ring
    sc = ring(1e6)
    b = collapse_bounds(sc)
    lp = collapse_load(sc)
    assert b.lower.load == pytest.approx(b.upper.load, rel=1e-6)
    t = np.array([j.length for j in scene_ring(sc).joints])[:len(lp.joint_rotation)]
    delta = 1e6 * sc.arch.width * t ** 2 / (8 * 128 ** 2)
    assert 0 <= lp.load - b.upper.load <= np.sum(delta * np.abs(lp.joint_rotation)) / lp.work_live


def test_a_joint_with_its_thrust_at_the_middle_crushes_at_fc_h_b():
    """The block pressed on its top's middle: n = W + P, m = 0, crushing at n = f_c b w exactly (any K)."""
    b, W, fc, w = 0.6, 5e3, 2e5, 1.5
    for k in (1, FINE):
        lp = solve_blocks(block_on_ground(b, 1.2, W, fc, w, tangents=k, push="centre"))
        assert lp.level == pytest.approx(fc * b * w - W, rel=1e-6)


def flat_arch(L=1.0, h=0.25, W=400.0, fc=1e5, w=1.0, tangents=FINE):
    """Two rectangular blocks L x h (weight W each) leaning on each other between rigid vertical abutment faces at
    x = 0 and 2L, the crown joint at x = L; a unit load at the crown, half on each block's top corner there."""
    ref = np.array([[L / 2, h / 2], [1.5 * L, h / 2]])
    dead = generalised_loads(ref, [0, 1], ref, [[0.0, -W], [0.0, -W]])
    live = generalised_loads(ref, [0, 1], [[L, h], [L, h]], [[0.0, -0.5], [0.0, -0.5]])
    # joints from a to b with the normal (T_y, -T_x) pointing from the left block into the right one
    a = np.array([[0.0, h], [L, h], [2 * L, h]])
    bb = np.array([[0.0, 0.0], [L, 0.0], [2 * L, 0.0]])
    law = CrushingJoints.blocks(fc, w, tangents) if fc is not None else CoulombJoints
    return BlockModel(ref, dead, live, a, bb, joint_left=np.array([-1, 0, 1]), joint_right=np.array([0, 1, -1]),
                      friction=np.full(3, 100.0), law=law)


def test_a_flat_two_block_arch_carries_fc_w_h2_over_2l_minus_w():
    """Hinges at the springings' bottom and the crown's top, thrust H on stress blocks of depth a = H/(f_c w): the
    left block's moments give H (h - a) = (W + P) L/2, largest at H = f_c w h/2, so P = f_c w h^2/(2 L) - W.
    Infinitely strong, the thrust grows without bound: no collapse."""
    L, h, W, fc = 1.0, 0.25, 400.0, 1e5
    lp = solve_blocks(flat_arch(L, h, W, fc))
    assert lp.status == "limit load found"
    assert lp.level == pytest.approx(fc * h ** 2 / (2 * L) - W, rel=1e-6)
    assert lp.joint_forces["n"] == pytest.approx(np.full(3, fc * h / 2), rel=1e-3)
    assert solve_blocks(flat_arch(L, h, W, None)).status == "no collapse (unbounded)"


RING = {"scene": {"name": "crush"},
        "arch": {"shape": "semicircular", "span": 6.0, "thickness": 0.4, "voussoirs": 8},
        "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0},
        "joints": {"friction": 0.6},
        "load": [{"kind": "point", "position": 0.3}]}


def ring(fc=None, **arch):
    doc = {**RING, "arch": {**RING["arch"], **arch}}
    if fc is not None:
        doc = {**doc, "masonry": {**RING["masonry"], "compressive_strength": fc}}
    return scene_from_dict(doc)


def test_without_strength_every_row_is_coulombs_to_the_last_bit():
    """The scene without the key: Coulomb's law class, and its deficit relaxations the former literal columns."""
    scene = ring()
    assert scene_law(scene) is CoulombJoints
    rules = CoulombJoints.block_yield(np.array([0.3, 0.5]), np.array([0.6, 0.7]), np.zeros(2))
    deficit, standing = rules.relaxations()
    t, mu = np.array([0.3, 0.5]), np.array([0.6, 0.7])
    assert np.array_equal(deficit, -np.column_stack([t / 2, t / 2, np.ones(2), np.ones(2)]))
    assert np.array_equal(standing, np.column_stack([np.zeros(2), np.zeros(2), mu - 1.0, mu - 1.0]))


def test_a_ring_carries_less_as_fc_falls_and_todays_load_when_strong():
    levels = [collapse_load(ring(fc)).level for fc in (None, 1e9, 3e6, 1e6, 5e5)]
    assert levels[1] == pytest.approx(levels[0], rel=1e-4)
    assert levels[0] > levels[2] > levels[3] > levels[4] > 0


def test_the_least_thickness_grows_as_fc_falls():
    """Under self-weight alone the deficit programme with the crushing rows: a weaker masonry needs a thicker ring."""
    t = [min_thickness(ring(fc), rtol=1e-3).thickness for fc in (None, 1e6, 3e5)]
    assert t[0] < t[1] < t[2]


def test_the_static_check_reads_the_crushing_rows():
    """An LP optimum is admissible for its own rows (statics' eccentricity <= 0) and the moment capacity is the
    polygon's, below n t/2."""
    model = dataclasses.replace(block_on_ground(), law=CrushingJoints.blocks(2e5, 1.0, 16))
    lp = solve_blocks(model)
    q = np.column_stack([lp.joint_forces[k] for k in "nsm"])
    st = statics(model, lp.level, q)
    assert st.eccentricity.max() <= 1e-6 * 5e3 * 0.6
    assert np.abs(st.equilibrium).max() <= 1e-6 * 5e3
    assert standing_deficit(model) == pytest.approx(0.0, abs=1e-6)
    assert _Programme(model).joint_yield(np.array([100.0])).per_joint == 2 * 17 + 2
