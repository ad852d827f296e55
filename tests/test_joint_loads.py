"""A point load exactly on a joint: which voussoir carries it (geometry.point_load_blocks), the LP's least
favourable allocation (collapse.collapse_load) and the FE load vector that follows it (model.py), checked
against the closed-form push-through load of a keystone wedged between two voussoirs that slide on the ground."""
import numpy as np
import pytest
from conftest import scene_dict

from bridgefem.geometry.ring import joint_under, point_load_blocks
from bridgefem.limit.collapse import collapse_load
from bridgefem.limit.rigid_block import BlockModel, generalised_loads, solve_blocks
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.ring import scene_ring

R, DENSITY, G = 5.0, 2000.0, 9.81


def three_voussoirs(thickness, friction, **extra):
    """A semicircle of three equal voussoirs (joints at 60 and 120 degrees), centreline radius R, point load on
    the extrados corner of joint 1 (between the left voussoir and the keystone)."""
    ri, re = R - thickness / 2, R + thickness / 2
    x = -re / 2  # extrados corner of the radial joint at 60 degrees
    return scene_from_dict({
        "arch": {"shape": "semicircular", "span": 2 * ri, "rise": ri, "thickness": thickness, "width": 1.0,
                 "voussoirs": 3},
        "masonry": {"young": 10e9, "poisson": 0.2, "density": DENSITY}, "joints": {"friction": friction},
        "load": [{"kind": "point", "position": (x + ri) / (2 * ri)}], **extra})


def push_through(thickness, friction):
    """Closed-form load (N) that pushes the keystone down between the two other voussoirs, which slide outwards
    on the horizontal springings; every joint at the Coulomb limit, tan(phi) = friction.

    Keystone faces inclined at delta = 30 degrees to the vertical. Face force on the keystone N (cos d - mu sin d,
    sin d + mu cos d) from each side, so P + W = 2 N (sin d + mu cos d). A side voussoir slides when
    N (cos d - mu sin d) = mu (W + N (sin d + mu cos d)), so N = W sin(2 phi) / (2 cos(2 phi + d)), and
    P = 2 W sin(phi) sin(phi + d) / cos(2 phi + d) - W (valid for 2 phi + d < 90 degrees). Each voussoir weighs
    W = density g (pi / 6) (re^2 - ri^2) (exact circular sectors).
    """
    ri, re = R - thickness / 2, R + thickness / 2
    w = DENSITY * G * np.pi / 6 * (re ** 2 - ri ** 2)
    phi, d = np.arctan(friction), np.pi / 6
    return 2 * w * np.sin(phi) * np.sin(phi + d) / np.cos(2 * phi + d) - w


# 1e-3: the voussoirs' polygonal edges (17 points per 60-degree edge) hold 0.9993 of the sectors' area and weight,
# and the push-through load scales with the weight.
@pytest.mark.parametrize("friction_model", ["associative", "non-associative"])
@pytest.mark.parametrize("thickness, friction", [(2.0, 0.33), (2.0, 0.36), (2.5, 0.35)])
def test_keystone_push_through_is_the_least_favourable_allocation(thickness, friction, friction_model):
    sc = three_voussoirs(thickness, friction)
    res = collapse_load(sc, friction_model)
    assert res.load_sides == ["right"]  # on the keystone
    assert res.load == pytest.approx(push_through(thickness, friction), rel=1e-3)
    assert res.hinges == [] and len(res.sliding) == 3  # the keystone and one side voussoir slide
    left = collapse_load(sc, friction_model, load_at_joint="left")
    split = collapse_load(sc, friction_model, load_at_joint="split")
    assert left.load > 2 * res.load and split.load > 1.5 * res.load  # half the load on the keystone: twice P


def test_wedge_between_fixed_neighbours_locks():
    """With both neighbours fixed (ground) a keystone narrowing downwards can take any load (any clamping force is
    admissible): no collapse, whatever the friction, even without friction."""
    d = np.radians(30)
    a = [[-1 + 0.0, 0.0], [1.0, 0.0]]  # intrados corners
    b = [[-1 - 2 * np.sin(d), 2 * np.cos(d)], [1 + 2 * np.sin(d), 2 * np.cos(d)]]  # extrados corners
    ref = np.array([[0.0, 1.0]])
    for mu in (0.0, 0.3):
        model = BlockModel(ref=ref, dead=generalised_loads(ref, [0], ref, [[0.0, -1.0]]),
                           live=generalised_loads(ref, [0], ref, [[0.0, -1.0]]),
                           joint_a=np.array(a), joint_b=np.array(b), joint_left=np.array([-1, 0]),
                           joint_right=np.array([0, -1]), friction=np.full(2, mu))
        assert solve_blocks(model).status == "no collapse (unbounded)"


def test_default_demo_least_favourable():
    """The reference arch (mu = 0.6, joint moved under the load): the load on the right voussoir of joint 6 makes
    it slide, 129.6 kN against 137.1 kN for the split or left allocation (the issue's values)."""
    sc = scene_from_dict(scene_dict())
    res = collapse_load(sc)
    assert res.load_sides == ["right"] and 6 in res.sliding
    assert res.load / 1e3 == pytest.approx(129.6, abs=0.05)
    assert collapse_load(sc, load_at_joint="split").load / 1e3 == pytest.approx(137.1, abs=0.05)


@pytest.mark.slow  # an end-to-end run of more than a second
def test_split_is_never_least_favourable():
    """Convexity (collapse._least_favourable): the split allocation is never below both single-block ones."""
    rng = np.random.default_rng(12)
    for _ in range(8):
        t = rng.uniform(0.6, 1.5)
        d = scene_dict(arch={"thickness": t, "voussoirs": int(rng.integers(6, 40))},
                       joints={"friction": rng.uniform(0.35, 0.8)},
                       load=[{"kind": "point", "position": rng.uniform(0.05, 0.95)}])
        sc = scene_from_dict(d)
        loads = {side: collapse_load(sc, load_at_joint=side).level for side in ("left", "right", "split")}
        if None in loads.values():
            continue
        assert loads["split"] >= min(loads["left"], loads["right"]) * (1 - 1e-7)
        assert collapse_load(sc).level == pytest.approx(min(loads.values()), rel=1e-12)


def test_point_load_blocks():
    ring = scene_ring(scene_from_dict(scene_dict()))
    j = joint_under(ring, ring.joints[6].extrados[0])
    assert j == 6
    x = ring.joints[6].extrados[0]
    assert point_load_blocks(ring, x, "left") == (5,) and point_load_blocks(ring, x, "right") == (6,)
    assert point_load_blocks(ring, x, "split") == (5, 6)
    mid = 0.5 * (ring.joints[3].extrados[0] + ring.joints[4].extrados[0])
    assert joint_under(ring, mid) is None and point_load_blocks(ring, mid, "left") == (3,)
    assert joint_under(ring, ring.joints[0].extrados[0]) is None  # a springing corner: the end voussoir only
    with pytest.raises(ValueError, match="allowed are"):
        point_load_blocks(ring, x, "both")


@pytest.mark.slow
def test_fe_load_vector_follows_the_allocation():
    """The FE live-load vector puts the whole load on the nodes of the chosen block (the LP's least favourable one
    by default), at the joint's extrados corner."""
    from mpi4py import MPI

    from bridgefem.fe.mesh import build_block_mesh
    from bridgefem.fe.model import build_elastic_model, node_blocks

    sc = scene_from_dict(scene_dict(mesh={"elements_through_thickness": 1}))
    ring = scene_ring(sc)
    bm = build_block_mesh(ring, 1)
    corner = ring.joints[6].extrados
    for sides, block in ((["left"], 5), (["right"], 6), (None, 6)):
        model = build_elastic_model(bm, ring, sc, sides)
        fy = model.f_live.array[1::2]
        loaded = np.flatnonzero(fy)
        xy = model.V.tabulate_dof_coordinates()[:len(fy), :2]
        assert MPI.COMM_WORLD.allreduce(fy.sum()) == pytest.approx(-1.0)
        assert np.all(node_blocks(model.V, bm)[loaded] == block)
        assert np.allclose(xy[loaded], corner, atol=1e-6)


@pytest.mark.slow
def test_fe_keystone_push_through():
    """The FE (elastic voussoirs, two elements through the thickness) with the LP's allocation reaches the
    closed-form push-through load within 1 % (elastic blocks, finite E)."""
    from bridgefem.analysis.runner import run_analysis
    from bridgefem.search.pathfollow import LIMIT_FOUND

    sc = three_voussoirs(2.0, 0.35, mesh={"elements_through_thickness": 2})
    s = run_analysis(sc).search
    assert s.status == LIMIT_FOUND, s.failure
    assert s.lower == pytest.approx(push_through(2.0, 0.35), rel=1e-2)
