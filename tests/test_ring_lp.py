"""The rigid-block LP and the conic bounds on barrels of several rings (#41) against independent values: the
monolithic ring, closed forms of one or two blocks, and the least thickness of one ring."""
import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import ROOT, assert_readme_lp, scene_dict

import bridgefem
from bridgefem.analysis.thrust import line_of_thrust
from bridgefem.assess.dispersion import dispersed_forces, dispersed_lp
from bridgefem.laws.crushing import CrushingJoints
from bridgefem.limit.bounds import collapse_bounds
from bridgefem.limit.collapse import collapse_load
from bridgefem.limit.rigid_block import BlockModel, dead_load_deficit, solve_blocks, standing_deficit
from bridgefem.limit.ring_blocks import ring_model
from bridgefem.limit.thickness import NoRingFriction, least_ring_friction, min_thickness
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.ring import scene_ring

N = 16  # voussoirs per ring of the reference arch


def barrel(rings=2, bond="aligned", ring_friction=None, ring_cohesion=0.0, thickness=1.0, **sections):
    """The reference arch of conftest (semicircle, span 9 m, 16 voussoirs, mu = 0.6) as a barrel of ``rings``."""
    joints = {"friction": 0.6, "ring_cohesion": ring_cohesion}
    if ring_friction is not None:
        joints["ring_friction"] = ring_friction
    d = scene_dict(**{"arch": {"thickness": thickness, "rings": rings, "ring_bond": bond}, "joints": joints,
                      **sections})
    return scene_from_dict(d)


def monolithic(thickness=1.0, **sections):
    return scene_from_dict(scene_dict(**{"arch": {"thickness": thickness}, **sections}))


@pytest.mark.parametrize("rings", [2, 3])
def test_aligned_rings_that_cannot_slide_are_the_monolithic_ring(rings):
    """Aligned rings whose interfaces cannot slide (friction 100, no cohesion) and never carry tension collapse as
    the one ring of the same thickness: its four-hinge mechanism is theirs, every ring hinging at the monolithic
    ring's joints (ring r's joint j is joint r (N + 1) + j), no interface moving."""
    mono = collapse_load(monolithic())
    res = collapse_load(barrel(rings, ring_friction=100.0))
    assert res.status == mono.status == "limit load found"
    assert res.load == pytest.approx(mono.load, rel=1e-7)
    by = res.by_joint
    assert by.hinges == sorted(r * (N + 1) + j for r in range(rings) for j in mono.by_joint.hinges)
    for r in range(rings):
        assert {j - r * (N + 1): w for j, w in by.hinge_positions.items()
                if r * (N + 1) <= j <= r * (N + 1) + N} == mono.by_joint.hinge_positions
    assert not by.separated
    assert set(by.sliding) == {r * (N + 1) + j for r in range(rings) for j in mono.by_joint.sliding}


def test_ring_cohesion_bonds_frictionless_rings():
    """Frictionless aligned rings fall apart under their own weight (each is thinner than the least thickness, 0.51
    m); a ring cohesion that no interface exhausts (10 MPa, the most a scene takes) makes them the monolithic ring again."""
    assert collapse_load(barrel(ring_friction=0.0)).status == "unstable under self-weight"
    res = collapse_load(barrel(ring_friction=0.0, ring_cohesion=1e7))
    assert res.load == pytest.approx(collapse_load(monolithic()).load, rel=1e-6)


def two_blocks(cohesion=0.0, interface=False, law=None):
    """A 2 m x 0.1 m block (0, weight 1 kN) on a 4 m x 0.1 m block (1, weight 2 kN) on the ground, the upper one
    pushed to the right by the live load at the interface's level (no overturning moment about it)."""
    return BlockModel(
        ref=np.array([[0.0, 0.15], [0.0, 0.05]]),
        dead=np.array([[0.0, -1e3, 0.0], [0.0, -2e3, 0.0]]),
        live=np.array([[1.0, 0.0, 0.05], [0.0, 0.0, 0.0]]),  # 1 N at (0, 0.1): moment -(0.1 - 0.15) x 1 about ref
        joint_a=np.array([[1.0, 0.1], [2.0, 0.0]]), joint_b=np.array([[-1.0, 0.1], [-2.0, 0.0]]),
        joint_left=np.array([1, -1]), joint_right=np.array([0, 1]), friction=np.array([0.3, 10.0]),
        interface=np.array([interface, False]), cohesion=np.array([cohesion, 0.0]),
        **({} if law is None else {"law": law}))


@pytest.mark.parametrize("cohesion", [0.0, 250.0, 4e3])
def test_cohesion_is_the_shear_capacity_at_no_normal_force(cohesion):
    """The upper block slides off at P = mu W + c (closed form: 0.3 x 1 kN + c); its mechanism slides joint 0."""
    res = solve_blocks(two_blocks(cohesion))
    assert res.level == pytest.approx(0.3e3 + cohesion, rel=1e-8)
    assert res.by_joint.sliding == [0] and not res.by_joint.hinges


def test_an_interface_never_crushes():
    """Pressed down (the live load turned vertical; f_c = 1e5 Pa, w = 1 m), the 2 m joint 0 crushes at f_c w t = 2e5 N
    less the upper block's weight (closed form of the crushing law's rows at no moment); made an interface piece it
    does not, and the 4 m ground joint crushes at 4e5 N less both blocks' weight."""
    law = CrushingJoints.blocks(1e5, 1.0)
    down = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 0.0]])
    masonry = solve_blocks(dataclasses.replace(two_blocks(law=law), live=down))
    assert masonry.level == pytest.approx(2e5 - 1e3, rel=1e-8)
    interface = solve_blocks(dataclasses.replace(two_blocks(law=law, interface=True), live=down))
    assert interface.level == pytest.approx(4e5 - 3e3, rel=1e-8)


def test_a_ring_interface_separates_or_slides_and_is_never_a_hinge():
    """Staggered rings with ring friction 0.6: the LP's chords map back to the ring's joints, the interface chords
    marked as such (no crushing) with the ring cohesion over their length; the interfaces that move are reported as
    separated or sliding, the hinges are voussoir joints and springings."""
    scene = barrel(2, "staggered")
    ring = scene_ring(scene)
    model = ring_model(scene)
    assert model.n_joints > len(ring.joints)  # the interfaces are their chords
    assert sorted(set(model.joint_ids.tolist())) == [j.id for j in ring.joints]
    kind = {j.id: j.kind for j in ring.joints}
    assert model.interface.tolist() == [kind[j] == "ring" for j in model.joint_ids]
    bonded = ring_model(barrel(2, "staggered", ring_cohesion=3e3))  # 3 kPa over each chord's length, 1 m wide
    chords = np.linalg.norm(bonded.joint_b - bonded.joint_a, axis=1)
    assert bonded.cohesion == pytest.approx(np.where(bonded.interface, 3e3 * chords, 0.0))
    res = collapse_load(scene)
    by = res.by_joint
    assert res.status == "limit load found"
    assert by.hinges and all(kind[j] in ("voussoir", "springing") for j in by.hinges)
    assert by.separated and all(kind[j] == "ring" for j in by.separated)
    assert res.load < collapse_load(monolithic()).load  # rings that separate carry less than one ring


@pytest.mark.slow  # an end-to-end run of more than a second
def test_min_thickness_scales_every_ring():
    """Aligned rings that cannot slide stand down to the monolithic ring's least thickness (Heyman's 0.51 m here):
    the search scales the barrel, every ring with it."""
    mono = min_thickness(monolithic())
    res = min_thickness(barrel(2, ring_friction=100.0))
    assert res.thickness == pytest.approx(mono.thickness, rel=2e-4)
    ring = scene_ring(barrel(2, ring_friction=100.0), res.thickness)
    assert ring.ring_thicknesses == pytest.approx((res.thickness / 2,) * 2)


STAGGERED = {"rings": 2, "bond": "staggered", "thickness": 0.9}
"""Two staggered rings of 0.45 m: each 12 % thinner than the least thickness of one ring (0.51 m)."""


@pytest.mark.slow  # conic or LP programmes of several seconds
def test_least_ring_friction_for_rings_thinner_than_the_least_thickness():
    """Each ring of 0.45 m alone falls (its least thickness is 0.51 m, an independent search on one ring); the
    barrel stands only above a ring friction, found by bisection; the deficit programme that lets the joints also
    carry tension (:func:`standing_deficit`, another programme) agrees on both sides of it."""
    one = min_thickness(monolithic(0.45))
    assert one.thickness > 0.45 * 1.1
    res = least_ring_friction(barrel(**STAGGERED), atol=1e-4)
    lo, hi = res.bracket
    assert hi - lo <= 1e-4 and res.friction == hi
    assert 0.0 < res.friction < 0.6
    assert res.mechanism.status == "unstable under self-weight" and res.mechanism.by_joint.sliding
    standing = ring_model(barrel(**STAGGERED, ring_friction=hi), live=False)
    weight = np.abs(standing.dead[:, :2]).sum()  # the LP's scale: HiGHS's feasibility tolerance 1e-7 is relative to it
    assert abs(standing_deficit(standing)) <= 1e-7 * weight
    assert standing_deficit(ring_model(barrel(**STAGGERED, ring_friction=lo), live=False)) > 0.0
    # a ring cohesion lowers it
    assert least_ring_friction(barrel(**STAGGERED, ring_cohesion=2e3), atol=1e-3).friction < res.friction - 1e-3


def test_dead_load_of_aligned_rings_that_cannot_slide_stands_as_one_ring():
    """Below the least thickness the aligned barrel falls as the monolithic ring does, above it stands."""
    for t, status in ((0.49, "unstable under self-weight"), (0.53, "stable under self-weight")):
        assert dead_load_deficit(ring_model(monolithic(t), live=False))[1].status == status
        assert dead_load_deficit(ring_model(barrel(2, ring_friction=100.0, thickness=t), live=False))[1].status \
            == status


FILL = {"fill": {"unit_weight": 18000.0, "young": 50e6, "depth": 0.3, "extension": 2.0, "material": "mohr-coulomb",
                 "friction_angle": 30.0, "cohesion": 5000.0, "interface_friction": 0.5},
        "load": [{"kind": "patch", "position": 0.25, "length": 0.5}]}


@pytest.mark.slow  # conic or LP programmes of several seconds
def test_bounds_with_a_fill_on_the_outer_ring():
    """With a fill, aligned rings that cannot slide have the monolithic ring's conic bounds (the fill on the outer
    ring's extrados, the barrel's)."""
    mono = collapse_bounds(monolithic(**FILL))
    rings = collapse_bounds(barrel(2, ring_friction=100.0, **FILL))
    assert rings.lower.load == pytest.approx(mono.lower.load, rel=1e-4)
    assert rings.upper.load == pytest.approx(mono.upper.load, rel=1e-4)


WHEEL = {"fill": FILL["fill"], "load": [], "vehicle": {"axles": [1e4], "contact_length": 0.3}}


def test_dispersed_wheel_loads_act_on_the_outer_ring():
    """A wheel dispersed through the fill loads the outer ring's voussoirs only, and on aligned rings that cannot
    slide gives the monolithic ring's LP factor."""
    scene = barrel(2, ring_friction=100.0, **WHEEL)
    ring = scene_ring(scene)
    blocks, _, forces = dispersed_forces(scene, ring, [(1e4, -1.0, -1.0)], "spread-2:1")
    assert set(blocks.tolist()) <= {v.id for v in ring.outer_voussoirs} and forces[:, 1].sum() == pytest.approx(-1e4)
    assert dispersed_lp(scene, [(1e4, -1.0, -1.0)], "spread-2:1").level == pytest.approx(
        dispersed_lp(monolithic(**WHEEL), [(1e4, -1.0, -1.0)], "spread-2:1").level, rel=1e-6)


def test_the_barrel_line_of_thrust_is_the_monolithic_rings_at_collapse():
    """At collapse (a four-hinge mechanism: statically determinate) aligned rings that cannot slide carry the
    monolithic ring's thrust: the barrel's line of thrust (each section's resultant over every ring, read from the
    rings' own LP joint forces) crosses every outer-ring joint where the monolithic ring's LP thrust crosses its
    joint, touching the faces at its hinges."""
    mono, rings = collapse_load(monolithic()), collapse_load(barrel(2, ring_friction=100.0))
    mono_line = line_of_thrust(lp_states(mono, N + 1), scene_ring(monolithic()))
    line = line_of_thrust(lp_states(rings, 2 * (N + 1)), scene_ring(barrel(2, ring_friction=100.0)))
    assert [p.joint for p in line] == [N + 1 + p.joint for p in mono_line]
    for p, q in zip(line, mono_line):
        assert (p.x, p.y) == pytest.approx((q.x, q.y), abs=1e-6)
        assert p.normal_force == pytest.approx(q.normal_force, rel=1e-6)
    touching = {p.joint - (N + 1): p.touches for p in line if p.touches}
    assert touching == {q.joint: q.touches for q in mono_line if q.touches}
    assert mono.by_joint.hinge_positions.items() <= touching.items()


def lp_states(res, n_joints):
    """The LP's forces on the first ``n_joints`` joints (the rings' joints: one piece each) as joint states."""
    f = res.joint_forces
    return [SimpleNamespace(id=j, normal_force=f["n"][j], shear_force=f["s"][j],
                            eccentricity=f["m"][j] / f["n"][j] if f["n"][j] > 0 else 0.0) for j in range(n_joints)]


@pytest.mark.slow  # an end-to-end run of more than a second
def test_the_readme_rings_example_prints_what_the_readme_shows(capsys):
    """README, *Rings*: ``bridgefem lp demos/multi_ring.toml`` prints what the README shows (but the seconds), and the
    monolithic ring and the bonded rings it quotes are the LP's."""
    section = assert_readme_lp(capsys, "## Rings", "## Several spans", "multi_ring.toml")
    scene = bridgefem.load_scene(ROOT / "demos" / "multi_ring.toml")
    mono = collapse_load(bridgefem.edit(scene, arch={"rings": 1})).load
    bonded = collapse_load(bridgefem.edit(scene, joints={"ring_cohesion": 20e3})).load
    assert f"({mono / 1e3:.3f} kN, `rings = 1`)" in section
    assert f"`ring_cohesion = 20e3` Pa between them raises it to {bonded / 1e3:.3f} kN" in section


@pytest.mark.slow  # an end-to-end run of more than a second
def test_aligned_rings_that_cannot_slide_crush_as_the_monolithic_ring():
    """With a compressive strength (2 MPa: the hinges' stress blocks a few cm deep) aligned rings that cannot slide
    collapse as the monolithic ring: a stress block deeper than the outer ring's joint crushes it whole and goes on
    in the inner one, as in the monolithic joint (up to the tangent polygon, 1/128^2 of the largest moment)."""
    strength = {"masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0, "compressive_strength": 2e6}}
    mono = collapse_load(monolithic(**strength))
    res = collapse_load(barrel(2, ring_friction=100.0, **strength))
    assert mono.load < 0.99 * collapse_load(monolithic()).load  # the strength matters here
    assert res.load == pytest.approx(mono.load, rel=1e-3)


def test_a_point_along_a_ring_interface_is_on_the_chord_that_holds_it():
    """The midpoint of every chord, given by its distance along its ring interface's curve (the FE pairs'
    ``position``), is found on that chord, half its length from its start."""
    model = ring_model(barrel(3, "staggered"))
    t = np.linalg.norm(model.joint_b - model.joint_a, axis=1)
    ids = model.joint_ids
    before = np.array([t[:k][ids[:k] == ids[k]].sum() for k in range(model.n_joints)])  # chords before, same joint
    piece, along = model.pieces_at(ids, before + t / 2)
    assert piece.tolist() == list(range(model.n_joints))
    assert along == pytest.approx(t / 2)


def test_no_least_ring_friction_where_friction_does_not_decide():
    """Rings of 0.75 m each (above the least thickness, 0.51 m) stand without friction between them, and the thin
    staggered rings do not stand with a ring friction of 0.1 (below their least ring friction, about 0.35): neither
    has a least ring friction in the range searched."""
    with pytest.raises(NoRingFriction, match="frictionless"):
        least_ring_friction(barrel(2, "staggered", thickness=1.5))
    with pytest.raises(NoRingFriction, match="ring friction 0.1"):
        least_ring_friction(barrel(**STAGGERED), highest=0.1)
