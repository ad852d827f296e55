"""Joint geometry and node pairing: joints perpendicular to the centreline, coincident pairs, tributary lengths
summing to the joint length, loads on joints."""
import numpy as np
import pytest
from conftest import scene_dict

from bridgefem.fe.mesh import build_block_mesh
from bridgefem.fe.model import build_elastic_model
from bridgefem.fe.pairs import GROUND, build_pairs
from bridgefem.geometry.ring import build_ring
from bridgefem.geometry.shapes import make_shape
from bridgefem.scene.reader import scene_from_dict


@pytest.mark.parametrize("shape,rise", [("semicircular", 4.5), ("segmental", 2.25), ("pointed", 6.0),
                                        ("elliptical", 3.0), ("parabolic", 3.0)])
def test_joints_are_normal_to_the_centreline(shape, rise):
    t = 0.8
    ring = build_ring(shape, 9.0, rise, t, 12, [-2.5])
    curve = make_shape(shape, 9.0, rise)
    eps = 1e-6
    for p, jt in zip(ring.params, ring.joints):
        if any(abs(p - k) < 2 * eps for k in curve.kinks):
            continue
        q = np.clip([p - eps, p + eps], 0, 1)
        centre = curve.point(q) + t / 2 * curve.normal(q)
        direction = (centre[1] - centre[0]) / np.linalg.norm(centre[1] - centre[0])
        assert abs(direction @ jt.tangent) < 1e-5  # finite-difference tangent of the exact centreline
    # a band between offset curves has area thickness x centreline length (Steiner); the pointed crown is
    # rounded by a chord, and the polygons are sampled polylines, hence 1e-3
    p = np.linspace(0, 1, 20001)
    centre = curve.point(p) + t / 2 * curve.normal(p)
    centre_length = np.linalg.norm(np.diff(centre, axis=0), axis=1).sum()
    assert sum(v.area for v in ring.voussoirs) == pytest.approx(t * centre_length, rel=1e-3)
    # a joint was moved under the load: its extrados end is at x = -2.5 m
    assert min(abs(jt.extrados[0] + 2.5) for jt in ring.joints) < 1e-6


def test_semicircular_joints_are_radial_and_evenly_spaced():
    ring = build_ring("semicircular", 9.0, 4.5, 1.0, 16, [], joint_at_loads=False)
    for jt in ring.joints:
        assert abs(np.cross(jt.intrados, jt.tangent)) < 1e-12  # the joint line passes through the centre
    angles = np.array([np.arctan2(j.centre[1], j.centre[0]) for j in ring.joints])
    assert np.allclose(np.diff(angles), -np.pi / 16, atol=1e-9)


@pytest.mark.parametrize("degree,per_thickness", [(1, 1), (1, 4), (2, 3)])
def test_pairs_coincide_and_tributary_lengths_sum_to_joint_length(degree, per_thickness):
    scene = scene_from_dict(scene_dict(mesh={"degree": degree, "elements_through_thickness": per_thickness}))
    a = scene.arch
    ring = build_ring(a.shape, a.span, a.rise, a.thickness, a.voussoirs, scene.load_edges_x())
    bm = build_block_mesh(ring, per_thickness)
    model = build_elastic_model(bm, ring, scene)
    pairs = build_pairs(model.V, bm, ring, 1e-9)
    assert pairs.total == len(ring.joints) * (degree * per_thickness + 1)
    for jt in ring.joints:
        sel = pairs.joint == jt.id
        assert pairs.length[sel].sum() == pytest.approx(jt.length, rel=1e-12)
        assert np.allclose(pairs.normal[sel], jt.normal)
        ground = (pairs.left[sel] == GROUND) | (pairs.right[sel] == GROUND)
        assert ground.all() == (jt.id in (0, len(ring.joints) - 1))
    # the self-weight vector carries exactly the mesh weight, the live-load vector exactly the unit load
    assert -model.f_dead.sum() == pytest.approx(model.dead_weight, rel=1e-12)
    assert model.live_per_level == pytest.approx(1.0, rel=1e-12)
