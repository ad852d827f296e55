"""Bridges of several spans on piers (issue #42): the scene keys, the geometry, the rigid-block LP against the spans
alone, the FE against the LP, and the same answer under mpirun -n 2."""
from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ROOT, assert_readme_lp, assert_two_ranks_give, readme_section, write_toml
from mpi4py import MPI

import bridgefem
from bridgefem.analysis.build import Clock, build_model
from bridgefem.analysis.runner import run_analysis
from bridgefem.analysis.thrust import _line
from bridgefem.assess.sweep import assess, lp_at
from bridgefem.geometry.ring import polygon_area_centroid
from bridgefem.limit.bounds import fill_bounds
from bridgefem.limit.collapse import collapse_load
from bridgefem.limit.rigid_block import dead_load_deficit
from bridgefem.limit.ring_blocks import block_weights, ring_model
from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import resolved_toml, scene_from_dict
from bridgefem.status import Status
from bridgefem.structure.materials import block_materials
from bridgefem.structure.ring import scene_ring

AGREEMENT = 0.005  # the FE/LP agreement of the campaign's judge where no joint slides

SPAN = {"shape": "segmental", "span": 8.0, "rise": 2.0, "thickness": 0.4, "voussoirs": 16}
STOCKY = {"width": 3.0, "height": 1.0, "blocks": 1}
SLENDER = {"width": 0.7, "height": 12.0, "blocks": 6}


def bridge(piers: list[dict], loads: list[dict], spans: int = 3, **sections) -> dict:
    """``spans`` equal segmental spans on ``piers`` (one table for every pier, or one each) under ``loads``."""
    piers = piers * (spans - 1) if len(piers) == 1 else piers
    return {"span": [dict(SPAN) for _ in range(spans)], "pier": [dict(p) for p in piers],
            "masonry": {"young": 1e10, "density": 2000.0}, "joints": {"friction": 0.6}, "load": loads,
            "mesh": {"elements_through_thickness": 2}, **sections}


def one_span(loads: list[dict]) -> dict:
    return {"arch": dict(SPAN), "masonry": {"young": 1e10, "density": 2000.0}, "joints": {"friction": 0.6},
            "load": loads}


def point(x: float) -> list[dict]:
    return [{"kind": "point", "x": x}]


# ------------------------------------------------------------------------------------------------------ scene keys
@pytest.mark.parametrize("change,message", [
    (lambda d: d.update(arch=dict(SPAN)), "[arch] and [[span]]: give one"),
    (lambda d: d["pier"].pop(), "[[pier]] = "),
    (lambda d: d["span"][1].update(width=2.0), "[[span]] #2 width = 2.0: allowed is the bridge's width"),
    (lambda d: d["span"][2].update(rise=5.0), "[[span]] #3 rise = 5.0: for shape = \"segmental\""),
    (lambda d: d["pier"][0].update(height=-1.0), "[[pier]] #1 height = -1.0"),
    (lambda d: d["pier"][1].update(colour="red"), "[[pier]] #2: unknown key 'colour'"),
    (lambda d: d.update(load=point(31.0)), "[[load]] #1 x = 31.0"),
    (lambda d: d.update(span=d["span"][:1], pier=[]), "expected 2 to 20 [[span]] tables"),
])
def test_bad_bridges_are_refused_with_the_key_the_value_and_what_is_allowed(change, message):
    d = bridge([STOCKY], point(2.0))
    change(d)
    with pytest.raises(SceneError, match=None) as err:
        scene_from_dict(d)
    assert message in str(err.value), str(err.value)


def test_piers_need_spans():
    d = one_span(point(2.0))
    d["pier"] = [dict(STOCKY)]
    with pytest.raises(SceneError, match=r"\[\[pier\]\]: piers stand between spans"):
        scene_from_dict(d)


def test_a_pier_too_narrow_for_its_springings_is_refused_with_the_least_width():
    scene = scene_from_dict(bridge([{"width": 0.5, "height": 4.0}], point(2.0)))
    with pytest.raises(SceneError, match=r"\[\[pier\]\] #1 width = 0.5 m: .* allowed is a width > 0.64 m"):
        scene_ring(scene)


def test_the_resolved_bridge_reads_back_as_the_same_scene():
    scene = scene_from_dict(bridge([SLENDER], point(2.0)))
    import tomllib
    assert scene_from_dict(tomllib.loads(resolved_toml(scene)), scene.name) == scene


# --------------------------------------------------------------------------------------------------------- geometry
def test_elastic_abutments_stand_at_the_bridges_ends():
    """Elastic abutments under a bridge of several spans: blocks after the pier courses, under the first span's left
    springing and the last span's right one; their bases belong to no span, and the line of thrust draws each base on
    its end span's line."""
    d = bridge([STOCKY], point(2.0), abutments={"model": "elastic", "height": 2.0})
    ring = scene_ring(scene_from_dict(d))
    left, right = ring.abutments
    assert left.id == ring.n_voussoirs + len(ring.piers) and right.id == left.id + 1
    assert left.polygon[:, 0].max() == pytest.approx(-SPAN["span"] / 2)  # the first span's left springing
    assert right.polygon[:, 0].min() == pytest.approx(2 * 11.0 + SPAN["span"] / 2)  # the third span's right one
    assert [j.span for j in ring.bases] == [None, None]
    assert [_line(j, ring) for j in ring.bases] == [0, 2]


def test_the_blocks_tile_the_bridge_and_every_joint_bears_on_its_blocks():
    """The spans and pier courses in one frame: the piers' area is width x height (+ batter), every springing on a
    pier names the pier's top course, every bed joint lies on its two courses' outlines."""
    pier = {"width": 1.5, "height": 4.0, "batter": 0.05, "blocks": 3}
    ring = scene_ring(scene_from_dict(bridge([pier], point(2.0))))
    assert [len(b.voussoirs) for b in ring.barrels] == [16, 16, 16]
    assert len(ring.piers) == 6 and len(ring.springings("left")) == len(ring.springings("right")) == 1
    courses = [b for b in ring.piers if b.pier == 0]
    below_springings = sum(polygon_area_centroid(b.polygon)[0] for b in courses[1:])
    h = 4.0 / 3
    assert below_springings == pytest.approx(sum(h * (1.5 + 2 * 0.05 * (k + 0.5) * h) for k in (1, 2)))
    top = courses[0]
    on_pier = [j for j in ring.joints if j.kind == "springing" and top.id in (j.left, j.right)]
    assert len(on_pier) == 2
    for j in ring.joints:
        if j.kind == "pier":
            for b in (j.left, j.right):
                if b is not None:
                    poly = ring.blocks[b].polygon
                    for end in (j.intrados, j.extrados):
                        assert np.min(np.linalg.norm(poly - end, axis=1)) < 1e-12


def test_a_pier_of_its_own_material_weighs_and_stiffens_as_given():
    """``[[pier]] density`` and ``young``: the pier's courses weigh density x g x area x width in the LP, the other
    pier and the voussoirs stay the masonry's, and a heavier pier carries more (it rocks later)."""
    own = dict(SLENDER, density=2600.0, young=5e9)
    scene = scene_from_dict(bridge([own, SLENDER], point(3.6)))
    ring = scene_ring(scene)
    materials = block_materials(scene, ring)
    weights = block_weights(scene, ring)
    for b in ring.blocks:
        area = polygon_area_centroid(b.polygon)[0]
        density = 2600.0 if getattr(b, "pier", None) == 0 else 2000.0
        assert weights[b.id] == pytest.approx(density * 9.81 * area)
        assert materials.young[b.id] == (5e9 if getattr(b, "pier", None) == 0 else 1e10)
    assert materials.own(scene) == [b.id for b in ring.piers if b.pier == 0]
    plain = collapse_load(scene_from_dict(bridge([SLENDER], point(3.6)))).load
    assert collapse_load(scene).load > 1.01 * plain


# ---------------------------------------------------------------------------------------------- rigid-block LP
@pytest.mark.parametrize("x", [2.0, 9.5 + 2.5, 2 * 11.0 + 5.0])
def test_a_wide_short_pier_gives_each_span_alone_on_rigid_springings(x):
    """Issue #42 item 3: a very wide, short pier reproduces each span alone (the same load on the same span)."""
    alone = collapse_load(scene_from_dict(one_span(point(x % 11.0)))).load
    assert collapse_load(scene_from_dict(bridge([STOCKY], point(x)))).load == pytest.approx(alone, rel=1e-7)


@pytest.mark.slow  # an end-to-end run of more than a second
def test_a_slender_pier_lowers_the_collapse_load_and_moves_the_critical_position():
    """A point load swept over the first span: on slender piers the least collapse load is lower than on stocky
    ones, a pier's bed joint and the second span hinge in its mechanism, and the critical position moves from near
    the quarter span towards the crown."""
    xs = np.linspace(0.4, 7.6, 19)

    def sweep(pier):
        return [collapse_load(scene_from_dict(bridge([pier], point(float(x))))) for x in xs]

    stocky, slender = (np.array([r.load for r in sweep(p)]) for p in (STOCKY, SLENDER))
    critical_stocky = xs[stocky <= stocky.min() * (1 + 1e-9)]  # the span alone: two, mirrored about midspan
    k = int(np.argmin(slender))
    assert slender[k] < 0.8 * stocky.min()
    lp = collapse_load(scene_from_dict(bridge([SLENDER], point(float(xs[k])))))
    ring = scene_ring(scene_from_dict(bridge([SLENDER], point(float(xs[k])))))
    assert any(ring.joints[j].kind == "pier" for j in lp.by_joint.hinges)
    assert np.abs(critical_stocky - xs[k]).min() >= 1.0
    # Melbourne, Gilbert & Wagstaff 1997 (three model multispan bridges): the critical position is not at the quarter
    # span but closer to the crown, and the adjacent span takes part in the mechanism
    crown = SPAN["span"] / 2
    assert abs(xs[k] - crown) < np.abs(critical_stocky - crown).min()
    assert any(ring.joints[j].span == 1 for j in lp.by_joint.hinges)


@pytest.mark.slow  # an end-to-end run of more than a second
def test_pier_joints_crush():
    """A compressive strength weakens the piers' bed joints too (the masonry law): the slender-pier bridge's LP
    collapse load falls with it, and a pier's foundation hinge is in its mechanism."""
    strong = collapse_load(scene_from_dict(bridge([SLENDER], point(3.6))))
    weak = scene_from_dict(bridge([SLENDER], point(3.6), masonry={"young": 1e10, "density": 2000.0,
                                                                   "compressive_strength": 2e6}))
    crushing = collapse_load(weak)
    ring = scene_ring(weak)
    assert crushing.load < 0.95 * strong.load
    assert any(ring.joints[j].kind == "pier" for j in crushing.by_joint.hinges)


def test_the_fe_law_crushes_the_piers_bed_joints():
    """The FE model's joint law gives the pairs of a pier's bed joints and foundation their crushing force
    f_c w l, as every masonry joint's."""
    d = bridge([{"width": 1.0, "height": 3.0, "blocks": 2}], point(3.6), spans=2,
               masonry={"young": 1e10, "density": 2000.0, "compressive_strength": 2e6})
    d["span"] = [dict(SPAN, voussoirs=8), dict(SPAN, voussoirs=8)]
    model = build_model(scene_from_dict(d), MPI.COMM_WORLD, None, lambda name: None, Clock(MPI.COMM_WORLD))
    law, pairs = model.solver.law, model.pairs
    pier = pairs.kind == "pier"
    assert pier.any() and np.allclose(law.capacity[pier], 2e6 * pairs.length[pier])


def test_a_symmetric_bridge_gives_symmetric_answers():
    length = 3 * 8.0 + 2 * 0.7
    for x in (1.3, 3.0, 6.1):
        left = collapse_load(scene_from_dict(bridge([SLENDER], point(x)))).load
        right = collapse_load(scene_from_dict(bridge([SLENDER], point(length - x)))).load
        assert right == pytest.approx(left, rel=1e-9)


@pytest.mark.slow
def test_a_load_on_a_piers_top_that_cannot_collapse_anything_is_locked():
    """A point load on a stocky pier's top: the LP finds no mechanism, and neither does the FE (locked)."""
    d = bridge([STOCKY], point(8.0 + 1.5))
    assert collapse_load(scene_from_dict(d)).status == "no collapse (unbounded)"
    an = run_analysis(scene_from_dict(d), MPI.COMM_WORLD)
    assert an.search.status is Status.LOCKED, an.search.status


def test_a_live_load_cannot_steady_blocks_that_fall_under_their_own_weight():
    """A light span on a slender pier beside a heavy one: the pier leans under the heavy span's thrust and the bridge
    falls under its own weight, though a load on that pier's top would steady it (the load programme alone is
    feasible above some load level). The live load follows the self-weight: the LP says "unstable under
    self-weight", as its dead-load programme does."""
    span = {"shape": "parabolic", "voussoirs": 6, "joint_at_loads": False}
    d = {"span": [{**span, "span": 13.814, "rise": 2.664, "thickness": 0.585},
                  {**span, "span": 12.008, "rise": 2.316, "thickness": 0.5086},
                  {**span, "span": 3.419, "rise": 0.659, "thickness": 0.1447}],
         "pier": [{"width": 3.729, "height": 12.666, "batter": 0.052, "blocks": 3},
                  {"width": 1.424, "height": 2.8, "blocks": 3}],
         "masonry": {"young": 3e10, "density": 2000.0}, "joints": {"friction": 4.116},
         "load": point(17.3164)}  # over the first pier's top
    tau, dead = dead_load_deficit(ring_model(scene_from_dict(d)))
    assert dead.status == "unstable under self-weight" and tau > 1e3
    assert collapse_load(scene_from_dict(d)).status == "unstable under self-weight"


@pytest.mark.slow
def test_a_vehicle_rolled_across_a_symmetric_bridge():
    """One axle rolled over three spans on slender piers (``assess``'s LP screen): the factors mirror about the
    bridge's middle, the axle on a pier's top cannot collapse anything (infinite factor), and the screen's critical
    factor is within 1 % of the least on a grid twice as fine (over the first half: the mirror of each of its
    points in the second half is one of its points in the first)."""
    d = bridge([SLENDER], [], vehicle={"axles": [100e3]})
    scene = scene_from_dict(d)
    length = 3 * 8.0 + 2 * 0.7
    xs = np.linspace(0.2, length - 0.2, 53)
    f = np.array([lp_at(scene, float(x)).factor for x in xs])
    assert np.allclose(f, f[::-1], rtol=1e-6)
    assert lp_at(scene, 8.35).factor == math.inf  # on the first pier's top
    a = assess([scene], MPI.COMM_SELF, fe=False)[0]
    fine = np.arange(0.05, length, a.step / 2)
    assert np.allclose(length - fine, fine[::-1])  # the grid is its own mirror
    least = min(lp_at(scene, float(x)).factor for x in fine[fine <= length / 2 + a.step / 2])
    assert a.lp_factor == pytest.approx(least, rel=0.01)


# ----------------------------------------------------------------------------------------------------------- the FE
@pytest.mark.slow
def test_the_fe_on_slender_piers_agrees_with_the_lp_and_hinges_a_pier():
    """Three spans on slender piers, a point load at 0.45 of the first span: the FE's bracket within the FE/LP
    agreement of the LP on the same blocks, the mechanism through the first pier's bed joints."""
    an = run_analysis(scene_from_dict(bridge([SLENDER], point(3.6))), MPI.COMM_WORLD)
    assert an.search.upper is not None, an.search.status
    total = an.load_total
    assert an.search.lower * total == pytest.approx(an.lp.load, rel=AGREEMENT)
    assert an.search.upper * total == pytest.approx(an.lp.load, rel=AGREEMENT)
    assert any(an.ring.joints[j].kind == "pier" for j in an.lp.by_joint.hinges)


def test_the_readme_example_prints_what_the_readme_shows(capsys):
    """README, *Several spans*: ``bridgefem lp demos/three_span.toml`` prints what the README shows (but the seconds),
    and the span on rigid springings it quotes is the LP's."""
    section = assert_readme_lp(capsys, "## Several spans", "## A bridge with its fill", "three_span.toml")
    scene = bridgefem.load_scene(ROOT / "demos" / "three_span.toml")
    rigid = bridgefem.edit(scene, pier=[{"width": 6.0, "height": 0.5}] * 2)
    assert f"carries {collapse_load(rigid).load / 1e3:.3f} kN" in section


@pytest.mark.slow
def test_the_readme_fe_bracket_is_the_runs():
    an = run_analysis(bridgefem.load_scene(ROOT / "demos" / "three_span.toml"), MPI.COMM_WORLD)
    lower, upper = (v * an.load_total / 1e3 for v in (an.search.lower, an.search.upper))
    assert f"in [{lower:.3f}, {upper:.3f}] kN" in readme_section("## Several spans", "## A bridge with its fill")


@pytest.mark.slow
def test_a_fill_over_two_spans_stays_within_its_conic_bounds():
    """A Mohr-Coulomb fill over two spans and their pier, a patch at 3 m: the FE's bracket between the conic lower and
    upper bounds of the same bridge with its fill (the campaign's judge)."""
    d = bridge([{"width": 1.0, "height": 6.0, "blocks": 3}], [{"kind": "patch", "x": 3.0, "length": 0.5}], spans=2,
               fill={"unit_weight": 18e3, "young": 5e7, "depth": 0.3, "extension": 2.0, "material": "mohr-coulomb",
                     "friction_angle": 35.0, "cohesion": 5e3})
    scene = scene_from_dict(d)
    an = run_analysis(scene, MPI.COMM_WORLD)
    bounds = fill_bounds(scene, an.search.upper * an.load_total)
    assert an.search.upper is not None, an.search.status
    assert bounds["lower"] * (1 - AGREEMENT) <= an.search.lower * an.load_total
    assert an.search.upper * an.load_total <= bounds["upper"] * (1 + AGREEMENT)


@pytest.mark.mpi
@pytest.mark.slow
def test_two_ranks_give_the_serial_bracket(tmp_path):
    """mpirun -n 2 on three spans on slender piers: every rank has the serial bracket."""
    d = bridge([SLENDER], point(3.6))
    path = write_toml(tmp_path / "bridge.toml", d)
    assert_two_ranks_give(path, run_analysis(scene_from_dict(d), MPI.COMM_WORLD))
