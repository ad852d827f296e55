"""Abutments and support movement against independent values.

All cases use the reference arch of conftest (semicircle, intrados span 9 m, t = 1 m, 16 voussoirs, mu = 0.6,
E = 10 GPa, 2000 kg/m^3) with 2 elements through the thickness (coarse: the tests are about statics, and a hinge
is one node in contact either way); the reaction checks use 4, whose straight element edges on the curved faces
lose less than 0.1 % of the ring's area (2 elements: 0.16 %).
"""
from __future__ import annotations

import functools
import json
import re

import numpy as np
import pytest
from conftest import bridgefem, scene_dict, write_toml
from scipy.optimize import linprog

from bridgefem.analysis.mechanism import springing_reactions
from bridgefem.analysis.result import Analysis
from bridgefem.analysis.runner import run_analysis
from bridgefem.geometry.ring import ArchRing
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import scene_from_dict
from bridgefem.search.pathfollow import LIMIT_FOUND, STABLE, UNSTABLE

pytestmark = pytest.mark.slow  # end-to-end analyses

COARSE = {"elements_through_thickness": 2}
RHO_G = 2000.0 * 9.81  # N/m^3, the reference masonry
RING_WEIGHT = RHO_G * np.pi / 2 * (5.5 ** 2 - 4.5 ** 2)  # N, half annulus R = 4.5 .. 5.5 m, width 1 m
# Rigid-block LP against FE on the same joints: 1 % covers the bracket (default tolerance 1e-4), the mesh's chords
# against the LP's polygons and the FE's nodal contact on a hinge (as in test_extremes).
FE_LP_REL = 0.01
TALL = {"model": "elastic", "height": 2.0}  # 1 m long (the springing joint's reach), 2 m high: they overturn


@functools.cache
def analyse(abutments: str, live: bool = True, per_thickness: int = 2, friction: float = 0.6) -> Analysis:
    """FE analysis of the reference arch with an [abutments] section (a repr'd dict, so that runs are cached)."""
    d = scene_dict(mesh={"elements_through_thickness": per_thickness}, abutments=eval(abutments),
                   joints={"friction": friction})
    if not live:
        d.pop("load")
    return run_analysis(scene_from_dict(d))


def lp(abutments: dict):
    return collapse_load(scene_from_dict(scene_dict(mesh=COARSE, abutments=abutments)))


def min_thrust_of_ring(ring: ArchRing, unit_weight: float) -> float:
    """Least horizontal thrust H (N) of a symmetric ring under self-weight whose thrust line stays inside every
    joint of the left half: an LP in (H, H y_c), with y_c the height of the thrust at the crown joint.

    For joint j the voussoirs between it and the crown weigh W (N) with first moment S = sum w x (N m); the
    resultant (-H, -W) crosses the joint at a + s T (a: intrados end, T: unit tangent, 0 <= s <= t) where moment
    equilibrium about that point gives s (W T_x - H T_y) = H a_y - H y_c + S - W a_x. Written with
    q = s (W T_x - H T_y), which is <= 0 for compression, the constraints t (W T_x - H T_y) <= q <= 0 are linear.
    Independent of the FE and of bridgefem.limit.rigid_block (only the block areas and centroids are shared).
    """
    n = ring.n_voussoirs
    w = np.array([unit_weight * v.area for v in ring.voussoirs])
    x = np.array([v.centroid[0] for v in ring.voussoirs])
    rows, rhs = [], []
    for jt in ring.joints[:n // 2 + 1]:
        crown_side = slice(jt.id, n // 2)
        weight, moment = w[crown_side].sum(), (w[crown_side] * x[crown_side]).sum()
        a, tang = jt.intrados, jt.tangent
        q, q0 = np.array([a[1], -1.0]), moment - weight * a[0]  # q = q . (H, H y_c) + q0
        rn, rn0 = np.array([-tang[1], 0.0]), weight * tang[0]  # W T_x - H T_y
        rows += [q, jt.length * rn - q]
        rhs += [-q0, q0 - jt.length * rn0]
    res = linprog([1.0, 0.0], A_ub=np.array(rows), b_ub=np.array(rhs), bounds=[(0, None), (None, None)])
    assert res.status == 0
    return float(res.x[0])


def hinges(an: Analysis) -> dict[int, str]:
    return {j.id: j.hinge for j in an.joints if j.hinge}


def test_scene_keys_are_checked():
    """Named errors for elastic-only keys on rigid abutments, a missing height, a too short abutment and a
    movement without its springing; defaults from the masonry and the joints."""
    cases = [({"height": 1.0}, "only for model"), ({"model": "elastic"}, "height: missing"),
             ({"model": "elastic", "height": 1.0, "length": 0.5}, "springing joint's horizontal reach"),
             ({"movement_horizontal": 1e-3}, "movement_springing: missing"),
             ({"movement_springing": "middle"}, '"left" or "right" or "both"'), ({"model": "soft"}, "[abutments] model")]
    for given, text in cases:
        with pytest.raises(SceneError, match=re.escape(text)):
            scene_from_dict(scene_dict(abutments=given))
    ab = scene_from_dict(scene_dict(abutments={"model": "elastic", "height": 1.0})).abutments
    assert (ab.length, ab.young, ab.unit_weight, ab.friction) == (1.0, 10e9, RHO_G, 0.6)


def test_stiff_wide_abutments_give_the_rigid_springing_limit_load():
    """Abutments of the masonry's stiffness, 3 m long and 0.5 m high, resist the ring's thrust with a wide margin:
    the FE bracket overlaps the one on rigid springings (both contain the same limit load; only the elastic
    stiffness below the springings differs, so the search's secant predictions and last trials may differ; measured:
    the same [136.956, 136.964] kN, and [136.956, 136.968] before the mechanism verdicts checked admissibility) and the LP with the abutment blocks is the bare ring's."""
    wide = {"model": "elastic", "height": 0.5, "length": 3.0}
    rigid, elastic = analyse("{}"), analyse(repr(wide))
    assert rigid.search.status == elastic.search.status == LIMIT_FOUND
    assert max(rigid.search.lower, elastic.search.lower) <= min(rigid.search.upper, elastic.search.upper)
    assert lp(wide).load == pytest.approx(lp({}).load, rel=1e-9)


def test_tall_abutments_overturn_as_in_the_lp_with_abutment_blocks():
    """Abutments 1 m long and 2 m high overturn about their outer toe: the LP with the abutment blocks gives about
    a fifth of the ring's collapse load (29.6 against 137.1 kN), with the fourth hinge at the right abutment's base
    (joint 18, outer edge); the FE on elastic abutments brackets the same value (FE_LP_REL) with the same hinges."""
    an, ref = analyse(repr(TALL)), lp(TALL)
    assert ref.load < 0.3 * lp({}).load
    assert ref.hinge_positions == {2: "intrados", 7: "extrados", 13: "intrados", 18: "extrados"}
    assert an.search.status == LIMIT_FOUND
    assert an.search.lower <= ref.load * (1 + FE_LP_REL) and an.search.upper >= ref.load * (1 - FE_LP_REL)
    assert hinges(an) == ref.hinge_positions


def test_base_reactions_carry_ring_and_abutment_weight():
    """Under self-weight the ground's vertical reactions at the two abutment bases equal the ring's weight plus
    both abutments' (hand values: half annulus and 3 m x 0.5 m rectangles x unit weight); 0.1 %: the chord error
    of the ring's curved faces. The horizontal reactions balance."""
    an = analyse(repr({"model": "elastic", "height": 0.5, "length": 3.0, "unit_weight": 25000.0}), False, 4)
    reactions = springing_reactions(an.joints, an.ring)
    assert an.search.status == STABLE and len(reactions) == 2
    assert reactions[:, 1].sum() == pytest.approx(RING_WEIGHT + 2 * 3.0 * 0.5 * 25000.0, rel=1e-3)
    assert abs(reactions[:, 0].sum()) < 1e-9 * RING_WEIGHT


def test_spreading_opens_three_hinges_at_the_minimum_thrust():
    """A 5 mm spreading of the right springing (span / 1800) under self-weight: the crown cracks at the intrados
    (hinge at the extrados), the haunches at the extrados (hinges at the intrados), and the thrust falls from its
    elastic value to the least thrust of a thrust line inside the ring (min_thrust_of_ring on the same joints:
    47.21 kN). 0.2 %: the mesh's chords against the polygon areas; the hinges are single nodes at the faces."""
    before = analyse("{}", live=False)
    an = analyse(repr({"movement_springing": "right", "movement_horizontal": 5e-3}), live=False)
    h_min = min_thrust_of_ring(an.ring, RHO_G)
    assert an.search.status == STABLE and h_min == pytest.approx(47.21e3, rel=1e-3)
    assert hinges(an) == {3: "intrados", 8: "extrados", 13: "intrados"}
    h_before, h_after = (springing_reactions(a.joints, a.ring)[0, 0] for a in (before, an))
    assert h_before > 1.2 * h_min
    assert h_after == pytest.approx(h_min, rel=2e-3)


def test_small_spreading_lowers_the_thrust_but_not_the_limit_load():
    """1 mm of spreading (crown hinge formed, haunches not yet): the thrust drops, and the limit load is the
    unmoved one (the rigid-block collapse load does not depend on small support movements; 1e-6: the same
    bracket, the load steps differ). mu = 10 here and in the next test: no joint slides, so the load on joint 6
    stays shared by both faces (four hinges, 137.1 kN); with mu = 0.6 it goes on the right voussoir, which slides
    (129.6 kN), and after 5 mm of spreading the FE then fails (a wrong active set): a solver case of its own."""
    before = analyse("{}", friction=10.0)
    an = analyse(repr({"movement_springing": "right", "movement_horizontal": 1e-3}), friction=10.0)
    assert an.search.steps[0].movement == 0 and max(st.movement for st in an.search.steps) == 1.0
    assert an.search.status == LIMIT_FOUND
    assert an.search.lower == pytest.approx(before.search.lower, rel=1e-6)
    assert an.search.upper == pytest.approx(before.search.upper, rel=1e-6)
    quiet = analyse(repr({"movement_springing": "right", "movement_horizontal": 1e-3}), live=False)
    h_before, h_after = (springing_reactions(a.joints, a.ring)[0, 0] for a in (analyse("{}", live=False), quiet))
    assert h_after < 0.9 * h_before


def test_large_spreading_keeps_the_limit_load():
    """5 mm of spreading opens all three hinges (test_spreading_opens_three_hinges_at_the_minimum_thrust); under
    live load the three-hinge arch needs a finite motion to close a crack the movement opened. The active-set
    iteration meets singular systems on the way whose diverging modes push open pairs into each other; those are
    no mechanisms (bridgefem.solver.newton, Mechanism verdicts), and the limit load is the unmoved one (measured: the same
    bracket [136.956, 136.964] kN; it once stopped at 8.891 kN), with no mechanism reported below it."""
    before = analyse("{}", friction=10.0)
    an = analyse(repr({"movement_springing": "right", "movement_horizontal": 5e-3}), friction=10.0)
    assert max(st.movement for st in an.search.steps) == 1.0
    assert an.search.status == LIMIT_FOUND, an.search.failure
    assert an.search.lower == pytest.approx(before.search.lower, rel=1e-4)
    assert an.search.upper == pytest.approx(before.search.upper, rel=1e-4)
    ref = collapse_load(before.scene)  # rigid-block theory: a small support movement leaves it unchanged
    assert an.search.lower <= ref.load * (1 + FE_LP_REL) and an.search.upper >= ref.load * (1 - FE_LP_REL)
    early = [st.level for st in an.search.steps if st.mechanism and st.level < before.search.lower]
    assert not early, early


def test_settlement_of_one_springing_opens_three_hinges():
    """A 5 mm settlement of the right springing under self-weight: three hinges, one of them at the right
    springing; the vertical reactions still sum to the ring's weight (0.1 %, hand value) and the horizontal
    ones balance; the settled side carries less."""
    an = analyse(repr({"movement_springing": "right", "movement_vertical": -5e-3}), False, 4)
    reactions = springing_reactions(an.joints, an.ring)
    assert an.search.status == STABLE
    assert len(hinges(an)) == 3 and 16 in hinges(an)
    assert reactions[:, 1].sum() == pytest.approx(RING_WEIGHT, rel=1e-3)
    assert abs(reactions[:, 0].sum()) < 1e-9 * RING_WEIGHT
    assert reactions[1, 1] < reactions[0, 1]


def test_abutments_too_tall_to_stand():
    """4 m high, 1 m long abutments cannot stand under the ring's thrust: the FE and the LP agree."""
    tall = {**TALL, "height": 4.0}
    assert analyse(repr(tall)).search.status == UNSTABLE
    assert lp(tall).status == UNSTABLE


@pytest.mark.mpi
def test_two_ranks_give_the_same_bracket_with_abutments_and_movement(tmp_path):
    """Tall elastic abutments with 0.5 mm of spreading under the right one, on 2 MPI ranks through the command
    line: the same bracket (1e-6: the same active sets and steps, round-off only) and mechanism as in serial."""
    ab = {**TALL, "movement_springing": "right", "movement_horizontal": 5e-4}
    scene = write_toml(tmp_path / "abutments.toml", scene_dict(mesh=COARSE, abutments=ab))
    proc = bridgefem("run", scene, "--out", tmp_path / "out", "--quiet", ranks=2)
    assert proc.returncode == 0, proc.stderr
    data = json.loads((tmp_path / "out" / "results.json").read_text())
    serial = analyse(repr(ab))
    assert data["mpi_ranks"] == 2 and data["status"] == serial.search.status == LIMIT_FOUND
    assert data["limit_load"]["lower"] == pytest.approx(serial.search.lower, rel=1e-6)
    assert data["limit_load"]["upper"] == pytest.approx(serial.search.upper, rel=1e-6)
    assert data["mechanism"]["hinge_positions"] == {str(k): v for k, v in hinges(serial).items()}
