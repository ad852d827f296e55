"""Crushing in the FE (issue 39): the scene's compressive strength chooses bridgefem.laws.crushing.CrushingJoints;
its converged equilibria obey the rigid-block rows of the FE's own joint stations, so the FE's limit meets the
rigid-block LP on the same joints (the static theorem); the joints are graded towards their edges from the LP's
hinge zones, so that the FE's limit meets the rectangular stress block's LP on default meshes, below the infinitely
strong ring; a crushing mode's proof counts the crushed pairs' work."""
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import SMALL_RING
from mpi4py import MPI

from bridgefem.analysis.refinement import coarse_stress_block, refinement_reason
from bridgefem.analysis.runner import run_analysis
from bridgefem.laws.base import ModeRules
from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.laws.crushing import CrushingJoints, fe_stations, scene_law
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.model import with_mesh
from bridgefem.scene.reader import scene_from_dict
from bridgefem.solver.mechanism import Mode, judge
from bridgefem.status import Status
from bridgefem.structure.grading import graded_nodes, graded_within
from bridgefem.structure.sizing import most_graded_elements

RING = {**SMALL_RING, "scene": {"name": "crush"}, "mesh": {"elements_through_thickness": 16}}


def scene(fc=None):
    masonry = {**RING["masonry"], **({} if fc is None else {"compressive_strength": fc})}
    return scene_from_dict({**RING, "masonry": masonry})


def test_the_stations_of_linear_elements_are_the_tangents_polygon():
    """16 linear elements: 17 evenly spaced stations with trapezoidal weights, the 16 tangents' polygon."""
    law = CrushingJoints.blocks(1e6, 1.0, stations=fe_stations(scene(1e6)))
    a, b = law.polygon()
    a16, b16 = CrushingJoints.blocks(1e6, 1.0, 16).polygon()
    assert a == pytest.approx(a16) and b == pytest.approx(b16)
    assert b16 == pytest.approx(np.arange(17) ** 2 / (2 * 16 ** 2))


def test_graded_joints_resolve_the_stress_block_to_the_tolerance():
    """The stations of graded joints (16 even elements, tolerance 1e-3, hinge zones 0.02-0.1 of the depth) against
    the parabola g(n) = n (t - n/(f_c w))/2 at every zone x from 0.02 to 0.2: the polygon is outside it and above it
    by at most twice the tolerance of the hinge moment n t/2 (the vertices' f_c w s^2/8 and the unequal neighbours'
    share); the even elements overstate the thinnest zone's moment by its whole stress block (x/2 of n t/2); no
    grading where the even elements resolve the thinnest zone."""
    nodes = np.array(graded_nodes(16, 1e-3, (0.02, 0.1)))
    assert nodes[0] == 0 and nodes[-1] == 1 and np.all(np.diff(nodes) > 0)
    assert nodes == pytest.approx(1 - nodes[::-1])
    assert np.diff(nodes).max() <= 1 / 16 + 1e-12
    sc = scene(1e6)
    t, x = 1.0, np.linspace(0.02, 0.2, 181)
    n = 1e6 * x
    law = CrushingJoints.blocks(1e6, 1.0, stations=fe_stations(sc, tuple(nodes)))
    excess = law.moment_capacity(np.full(len(x), t), n) / law.largest_moment(np.full(len(x), t), n) - 1
    assert excess.min() >= -1e-12
    assert np.all(excess * (1 - x) <= 2 * 1e-3 + 1e-12)
    even = CrushingJoints.blocks(1e6, 1.0, stations=fe_stations(sc))
    assert even.moment_capacity([t], [2e4])[0] == pytest.approx(2e4 * t / 2)
    assert graded_nodes(4, 0.05, (0.5, 0.5)) == pytest.approx((0.0, 0.25, 0.5, 0.75, 1.0))


def test_a_grading_beyond_its_budget_is_the_finest_within_it():
    """graded_within: the grading itself when it fits; bounded, a symmetric grading of at most that many elements,
    coarser at the edges than the unbounded one, and the finest within the bound (its tolerance, read off its first
    spacing 2 sqrt(t zones[0]), 0.2 % smaller gives more elements); at the even elements' count, at most that many."""
    zones = (0.02, 0.1)
    free = graded_nodes(16, 1e-3, zones)
    assert graded_within(16, 1e-3, zones, len(free) - 1) == free
    most = len(free) - 11
    bounded = np.array(graded_within(16, 1e-3, zones, most))
    assert bounded[0] == 0 and bounded[-1] == 1 and np.all(np.diff(bounded) > 0)
    assert bounded == pytest.approx(1 - bounded[::-1])
    assert len(bounded) - 1 <= most and bounded[1] > free[1]
    tolerance = bounded[1] ** 2 / (4 * zones[0])
    assert 1e-3 < tolerance < zones[0] and graded_nodes(16, tolerance, zones) == pytest.approx(bounded)
    assert len(graded_nodes(16, tolerance / 1.002, zones)) - 1 > most
    assert len(graded_within(16, 1e-3, zones, 16)) - 1 <= 16


def test_a_coarse_stress_block_at_the_size_budget_is_not_re_run():
    """A 1 MPa ring of 8 voussoirs (9 joints: at most 332 elements each within the 3000 pairs, on 4 or 8 elements
    through the thickness) whose LP on the FE's joints is 2 % above the stress block's: re-run on a finer mesh with
    even joints or graded ones below the budget, not with graded joints at it (the finer mesh would grade them the
    same); the run's check still names the coarse stress block."""
    sc = scene_from_dict({**RING, "mesh": {"elements_through_thickness": 4},
                          "masonry": {**RING["masonry"], "compressive_strength": 1e6}})
    block = collapse_load(sc)

    def run(nodes):
        return SimpleNamespace(scene=sc, lp=SimpleNamespace(status=Status.LIMIT, level=1.02 * block.level,
                                                            load=1.02 * block.load),
                               block_mesh=SimpleNamespace(joint_nodes=nodes), verdict=SimpleNamespace(
                                   mesh_dependent=False), search=SimpleNamespace(status=Status.LIMIT, proved=False))

    assert most_graded_elements(sc) == most_graded_elements(with_mesh(sc, 8)) == 332
    at_budget, below = tuple(np.linspace(0.0, 1.0, 333)), tuple(np.linspace(0.0, 1.0, 41))  # 332 and 40 elements
    assert refinement_reason(run(at_budget), 4) == "" and "2.0% stronger" in coarse_stress_block(run(at_budget))
    assert refinement_reason(run(None), 4).startswith("the FE's 4 elements through the thickness crush a joint 2.0%")
    assert refinement_reason(run(below), 4) == coarse_stress_block(run(below))


@pytest.mark.slow
@pytest.mark.parametrize("fc", [None, 100e6, 10e6, 3e6, 1e6, 0.7e6])
def test_the_fe_meets_the_stress_block_lp_across_strengths(fc):
    """docs/validation.md row 29: a 6 m semicircle 0.4 m thick, 8 voussoirs, a point load at 0.3 of the span, on the
    default mesh (4 even elements, graded where the stress block needs it): the FE's bracket within 2 % of the
    rigid-block LP on the rectangular stress block (128 tangents) at every strength, and without re-runs; an
    infinitely strong or a 100 MPa ring keeps its even joints."""
    ring = {**SMALL_RING, "scene": {"name": "row29"}}
    sc = scene_from_dict({**ring, "masonry": {**ring["masonry"], **({} if fc is None else
                                                                   {"compressive_strength": fc})}})
    an = run_analysis(sc, MPI.COMM_WORLD, max_refinements=0)
    block = collapse_load(sc).level
    assert an.search.status == "limit load found"
    assert abs(an.search.lower / block - 1) <= 0.02 and abs(an.search.upper / block - 1) <= 0.02
    assert (an.block_mesh.joint_nodes is None) == (fc is None or fc >= 100e6)
    assert not an.warnings


@pytest.mark.slow
def test_a_crushing_ring_meets_the_lp_on_its_own_joints():
    """f_c = 1 MPa on a 6 m semicircle 0.4 m thick: the FE's limit within 0.5 % of the LP on its own joints (16
    elements, graded), crushed pairs in its last state, below the infinitely strong ring's and above the parabola's
    LP (the polygon is outside the parabola) by less than 0.5 %; the pairs through a joint are the stations."""
    sc = scene(1e6)
    an = run_analysis(sc, MPI.COMM_WORLD, max_refinements=0)
    nodes = an.block_mesh.joint_nodes
    assert isinstance(an.solver.law, CrushingJoints)
    assert an.search.status == "limit load found"
    own = collapse_load(sc, law=scene_law(sc, fe=True, nodes=nodes)).level
    block = collapse_load(sc).level
    strong = collapse_load(scene()).level
    assert abs(an.search.lower / own - 1) <= 0.005
    assert block < an.search.lower < 1.005 * block < strong
    assert an.search.steps[-1].counts.get("crushed", 0) + an.search.steps[-1].counts.get("crushed-slip", 0) > 0 \
        or any(s.counts.get("crushed", 0) for s in an.search.steps if s.converged)
    assert an.verdict.evidence
    s, w = np.array(fe_stations(sc, nodes)).T  # the pairs through joint 4 are the stations
    at = an.pairs.joint == 4
    order = np.argsort(an.pairs.position[at])
    t = sc.arch.thickness
    assert an.pairs.position[at][order] == pytest.approx(s * t, abs=1e-9 * t)
    assert an.pairs.length[at][order] == pytest.approx(w * t, rel=1e-6)


def test_without_strength_the_scene_law_is_coulombs():
    from bridgefem.laws.crushing import scene_law_factory
    assert scene_law_factory(scene()) == CoulombJoints.for_pairs
    assert scene_law(scene()) is CoulombJoints


def test_a_mode_closing_crushed_pairs_must_outwork_their_crushing_force():
    """Two pairs: one crushed (C = 10 N), one open; the mode opens the open pair by 1 and closes the crushed one by
    1 (a hinge turning about its crushed edge). Load work 5 < C x 1: no proof; 15 > 10: a proof."""
    d = np.array([[-1.0, 0.0], [1.0, 0.0]])
    rules = ModeRules(np.array([False, True]), np.full(2, np.nan), np.array([True, True]), np.zeros(2),
                      np.array([10.0, 0.0]))
    for work, proof in ((5.0, False), (15.0, True)):
        mode = Mode(d, rules, np.array([0, 0]), (work, work), (1.0, 1.0))
        assert judge(mode).proof is proof


@pytest.mark.slow
def test_a_creeping_crushing_ring_under_a_plastic_fill_is_not_flat_below_its_conic_lower_bound():
    """A soft crushing ring (elliptical, 20 m span, 1.17 m thick, 9 voussoirs, E = 403 MPa, f_c = 1.167 MPa) under a
    Mohr-Coulomb fill 1 m deep, a 1.37 m patch at 0.19 of the span: its load-deflection curve creeps, the compressed
    zones of its crushed joints growing over large rotations, and the exponential through three nearby states read
    it flat at 303-304 kN, 4 % below the conic lower bound that the bridge with its fill is proved to carry
    (315.4 kN). That bound is the search's floor (bridgefem.search.step, *Flat curve*): the FE's bracket lies between
    the conic bounds."""
    sc = scene_from_dict({
        "scene": {"name": "creeping"},
        "arch": {"shape": "elliptical", "span": 20.022, "rise": 4.218, "thickness": 1.1672, "width": 1.0,
                 "voussoirs": 9, "joint_at_loads": True},
        "masonry": {"young": 403e6, "poisson": 0.2, "density": 2000.0, "compressive_strength": 1.167e6},
        "joints": {"friction": 0.766},
        "load": [{"kind": "patch", "position": 0.1935, "length": 1.374}],
        "fill": {"unit_weight": 18000.0, "young": 50e6, "depth": 1.001, "extension": 4.004,
                 "material": "mohr-coulomb", "cohesion": 5000.0}})
    an = run_analysis(sc, MPI.COMM_WORLD)
    bounds, s = an.fill_bounds, an.search
    assert s.status == Status.LIMIT and bounds["lower"] and bounds["upper"]
    assert bounds["lower"] * (1 - s.tolerance) <= s.lower * an.load_total
    assert s.upper * an.load_total <= bounds["upper"]
