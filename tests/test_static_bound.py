"""The static theorem's bound on a bare ring (bridgefem.analysis.evidence, evidence 4): the rigid-block LP on the FE's joints
under the FE's own loads bounds every FE equilibrium from above, so the limit search ends on it once a converged
state, checked admissible for that LP, lies within the bracket's width of it."""
import dataclasses

import numpy as np
import pytest
from conftest import campaign_scene

from bridgefem.analysis.evidence import AGREEMENT, admissible
from bridgefem.analysis.runner import run_analysis
from bridgefem.analysis.static_bound import block_loads, fe_blocks, static_cap
from bridgefem.fe.mesh import build_block_mesh
from bridgefem.fe.model import build_elastic_model
from bridgefem.limit.collapse import collapse_load
from bridgefem.limit.rigid_block import BlockModel, Statics, standing_deficit
from bridgefem.limit.ring_blocks import ring_model
from bridgefem.scene.reader import scene_from_dict
from bridgefem.status import Status
from bridgefem.structure.ring import scene_ring

# campaign seed 1, scene 3 (benchmarks/campaign.py): a pointed ring of 32 voussoirs, mu = 2.43, a patch load; its
# FE reaches the LP (no joint slides)
SCENE_3 = campaign_scene(3, 0.4363)
# campaign seed 8, scene 89: a pointed ring of 11 voussoirs 1 % above its least thickness (0.702 m), mu = 1.81, a
# point load at 0.418 whose limit is 0.4 % of the ring's weight
SCENE_89 = campaign_scene(89, 0.709, seed=8)
# campaign seed 1, scene 111: an elliptical ring of 12 voussoirs at mu = 0.331 that cannot stand under its weight
SCENE_111 = campaign_scene(111, 1.5887)


def one_block(offset, mu, hanging=False):
    """A block of weight 1000 N on a joint of length 2 m (on the ground, or hanging from it), its weight acting
    ``offset`` (m) from the joint's centre along it."""
    a, b = (np.array([-1.0, 0.0]), np.array([1.0, 0.0])) if not hanging else (np.array([1.0, 0.0]),
                                                                              np.array([-1.0, 0.0]))
    ref = np.array([[offset, 0.5 if not hanging else -0.5]])
    return BlockModel(ref, np.array([[0.0, -1000.0, 0.0]]), np.zeros((1, 3)), a[None], b[None], np.array([0]),
                      np.array([-1]), np.array([mu]))


@pytest.mark.parametrize("offset, mu, hanging, tau", [
    (0.5, 0.5, False, 0.0),  # the thrust inside the joint: it stands
    (1.5, 0.5, False, 500.0),  # |m| = 1500 N m <= (1000 + tau) x 1 m
    (0.0, 0.5, True, 1000.0),  # hanging: a net tension of 1000 N (n >= -tau), Coulomb 0 <= mu n + tau
    (0.0, 2.0, True, 2000.0),  # ... and with mu = 2, Coulomb needs 0 <= 2 (-1000) + tau
])
def test_the_standing_deficit_of_one_block_is_its_closed_form(offset, mu, hanging, tau):
    assert standing_deficit(one_block(offset, mu, hanging)) == pytest.approx(tau, abs=1e-6)


def test_a_state_that_violates_one_yield_condition_is_not_admissible():
    """Made-up rows: two joints in equilibrium (zero residual), one of them in net tension, Coulomb excess or with
    its thrust outside the joint beyond the tolerance; within the tolerance the state is admissible."""
    sigma, mu, t = np.array([1.0, 1.0]), np.array([0.5, 0.5]), np.array([2.0, 2.0])
    force, moment = np.array([1.0]), np.array([1.0])

    def rows(**violation):
        zero = np.array([-10.0, -10.0])
        return Statics(np.zeros((1, 3)), *(zero + violation.get(k, 0.0) for k in ("t", "f", "e")))

    assert admissible(rows(t=[0.0, 10.5]), sigma, mu, t, force, moment)[0]  # net tension 0.5 N <= sigma
    for violation, name in ((dict(t=[0.0, 11.5]), "net tension"), (dict(f=[0.0, 11.6]), "Coulomb excess"),
                            (dict(e=[12.5, 0.0]), "thrust outside a joint")):
        ok, text = admissible(rows(**violation), sigma, mu, t, force, moment)
        assert not ok and name in text, text
    ok, text = admissible(Statics(np.array([[0.0, 1.5, 0.0]]), *(np.full(2, -10.0),) * 3), sigma, mu, t, force,
                          moment)
    assert not ok and "block force residual" in text


@pytest.mark.slow
def test_the_bracket_of_a_campaign_ring_ends_on_the_static_theorem():
    """The search ends on a converged state within the width of the bound, the bound is the upper end and no trial
    went above it; the bracket holds the independent LP (exact voussoir weights) within AGREEMENT. The converged
    state passes the admissibility check, and fails it once one joint's forces are made tensile, or with a pair's
    law waived."""
    an = run_analysis(scene_from_dict(SCENE_3))
    s = an.search
    assert s.status == Status.LIMIT and s.static and an.verdict.evidence.startswith("static theorem"), s.status
    assert s.upper == an.static.level and s.upper - s.lower <= s.tolerance * s.lower
    assert max(st.level for st in s.steps) <= s.upper
    assert abs(s.lower / an.lp.level - 1) <= AGREEMENT and abs(s.upper / an.lp.level - 1) <= AGREEMENT
    _, cap = static_cap(fe_blocks(an.scene, an.model, an.block_mesh), an.model, an.block_mesh, an.pairs, an.solver)
    assert cap.level == an.static.level
    step = next(st for st in reversed(s.steps) if st.converged)
    assert step.level == s.lower and cap.admissible(step, s.last)[0]
    x = s.last.x.copy()
    lam = x.array[an.solver.n_u:].reshape(-1, 2)
    _, _, lam_now = an.solver.system.split(s.last.x)
    loaded = an.pairs.joint == an.pairs.joint[np.argmax(lam_now[:, 0])]
    lam[loaded, 0] *= -1.0  # the most compressed joint pulled instead
    x.array[an.solver.n_u:] = lam.ravel()
    ok, text = cap.admissible(step, dataclasses.replace(s.last, x=x))
    assert not ok, text
    ok, text = cap.admissible(dataclasses.replace(step, counts={**step.counts, "frozen": 1}), s.last)
    assert not ok and "waived (frozen or bonded) at 1 of the pairs" in text  # a waived law's residual is no static admissibility


@pytest.mark.slow
def test_a_ring_that_cannot_stand_is_unstable_by_the_static_theorem():
    """The rigid blocks under the FE's self-weight need joint tension: the failed self-weight step is the answer,
    "unstable under self-weight" with the static theorem as evidence, the exact LP agreeing. (That it takes one load
    step, where the continuation and the retries cost 259 solves on the campaign before the bound:
    benchmarks/solve_budgets.py.)"""
    an = run_analysis(scene_from_dict(SCENE_111))
    assert an.search.status == Status.UNSTABLE and an.search.static and an.lp.status == Status.UNSTABLE
    assert an.static.deficit > an.static.margin and an.verdict.evidence.startswith("static theorem")


@pytest.mark.parametrize("voussoirs", [11, 12])  # the apex inside the crown voussoir, and at a joint
def test_the_meshed_voussoirs_carry_their_polygons_weights_and_lines_of_action(voussoirs):
    """Each voussoir's assembled self-weight is its polygon's (the rigid-block LP's: shoelace area x unit weight) and
    acts through its polygon's centroid, to round-off, on the coarsest mesh: the mesh's straight cell edges follow
    the curved intrados and extrados (and the pointed crown's cap) by chords that make the meshed voussoir weigh
    O(h^2) differently, and :func:`bridgefem.fe.model.block_weight_shape` corrects each block's weight and moment
    (campaign seed 8, #89 without its load; 2 elements through the thickness)."""
    scene = scene_from_dict({**SCENE_89, "arch": {**SCENE_89["arch"], "voussoirs": voussoirs}, "load": [],
                             "mesh": {"elements_through_thickness": 2}})
    ring = scene_ring(scene)
    mesh = build_block_mesh(ring, scene.mesh.elements_through_thickness)
    polygons = ring_model(scene)
    dead, _ = block_loads(build_elastic_model(mesh, ring, scene), mesh, polygons.ref)
    weight = polygons.dead[:, 1]
    assert np.abs(dead[:, 1] / weight - 1).max() <= 1e-10
    assert np.abs(dead[:, 0]).max() <= 1e-10 * np.abs(weight).max()
    assert np.abs(dead[:, 2] / weight).max() <= 1e-10 * scene.arch.span  # about the polygon's centroid


@pytest.mark.slow
def test_a_live_load_capacity_of_a_ten_thousandth_of_the_weight_is_the_lps():
    """Campaign seed 20261268, #113: an elliptical ring of 18 voussoirs at its least thickness (0.638 m, mu =
    0.831, a patch at 0.28 of the span) whose rigid blocks carry 38.8 N of live load, 3e-4 of its weight. With the
    meshed voussoirs' own weights (O(h^2) off their polygons') the FE's level moved with the mesh across the LP's
    and no evidence agreed; with the exact weights (:func:`bridgefem.fe.model.block_weight_shape`) the static
    theorem's bound is the LP's level (computed here) on the first mesh and the bracket ends on it."""
    an = run_analysis(scene_from_dict(campaign_scene(113, 0.6379, seed=20261268)))
    s, lp = an.search, collapse_load(an.scene)
    assert not an.refinements and an.static.level * an.load_total == pytest.approx(lp.load, rel=1e-6)
    assert lp.load < 1e-3 * (an.model.dead_weight + an.model.support_weight)
    assert s.status == Status.LIMIT and an.verdict.evidence.startswith("static theorem"), s.status
    assert s.lower * an.load_total <= lp.load * (1 + 1e-6) and s.upper * an.load_total >= lp.load * (1 - 1e-6)


def test_a_ring_near_its_least_thickness_is_bracketed_on_the_static_theorem():
    """Campaign seed 8, #89: its limit is so small against its weight (0.4 %) that the crown's 44 N of excess weight
    in the mesh put the static theorem's bound 2.7 % below the LP, a solver failure on every mesh. With the crown
    meshed as its polygon the bracket ends on that bound within AGREEMENT of the LP (computed here)."""
    an = run_analysis(scene_from_dict(SCENE_89))
    s, lp = an.search, collapse_load(an.scene)
    assert s.status == Status.LIMIT and an.verdict.evidence.startswith("static theorem"), s.status
    for end in (s.lower, s.upper):
        assert abs(end * an.load_total / lp.load - 1) <= AGREEMENT
