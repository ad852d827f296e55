"""Meshes of rings whose voussoir edges split into curves of very different lengths: every transfinite curve
gets a segment (Gmsh aborts on one without), e.g. a patch with both edges on a thick pointed arch's crown cap."""
import numpy as np
import pytest

from bridgefem.fe.mesh import _segment_counts, build_block_mesh
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.ring import scene_ring

# campaign seed 1, scene 182: t = 7.04 m on a 25 m pointed arch; the crown voussoir's extrados is a 6.1 m cap
# (the offsets of the two arcs, closed by chords to the apex) over a 0.26 m intrados, the patch's edges on the cap
POINTED_CAP = {
    "arch": {"shape": "pointed", "span": 25.085, "rise": 19.284, "thickness": 7.0401, "voussoirs": 171,
             "joint_at_loads": False},
    "masonry": {"young": 8.97e8, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 0.325},
    "load": [{"kind": "patch", "position": 0.5564, "length": 2.218}]}


def test_segment_counts_give_every_curve_a_segment():
    """The counts sum to the total (at least one per curve) and none is zero, whatever the lengths; the cap of
    scene 182 (a 2.86 m chord beside 0.31, 2.27 and 0.34 m curves, 4 segments) gave its chord none."""
    assert _segment_counts([2.856, 0.31, 2.27, 0.34], 4) == [1, 1, 1, 1]
    rng = np.random.default_rng(3)
    for _ in range(500):
        lengths = np.exp(rng.uniform(-8, 2, rng.integers(1, 7)))
        total = int(rng.integers(len(lengths), 3 * len(lengths) + 3))
        counts = _segment_counts(list(lengths), total)
        assert sum(counts) == total and min(counts) >= 1


def test_patch_on_a_pointed_crown_cap_meshes():
    scene = scene_from_dict(POINTED_CAP)
    ring = scene_ring(scene)
    crown = ring.voussoirs[ring.n_voussoirs // 2]
    cap, intrados = np.ptp(crown.extrados[:, 0]), np.ptp(crown.intrados[:, 0])
    assert cap > 5.0 and intrados < 0.3  # the geometry of the case
    bm = build_block_mesh(ring, scene.mesh.elements_through_thickness)
    assert bm.n_cells > 0
    assert np.unique(bm.cell_tags.values).size == ring.n_voussoirs


# thick pointed rings with patches on or across the crown cap (joint_at_loads false) on which Gmsh aborted, found
# by meshing 600 random such rings each in a child process (7 aborts before, none after; 2000 more: none):
# span, rise, thickness (m), voussoirs, elements through the thickness, patch edges x (m)
CAP_ABORTS = [
    (17.3065, 10.0025, 3.81857, 5, 1, [-0.645772, 0.739258]),
    (19.1032, 13.0038, 4.05302, 7, 1, [0.041428, 2.941916]),
    (4.60268, 4.20803, 1.07052, 11, 4, [0.068131, 0.655169]),
    (28.7991, 17.3776, 2.77921, 23, 1, [-0.048436, 0.080553]),
    (29.7096, 25.1680, 5.13930, 7, 2, [-0.640087, 1.344678]),
    (21.7762, 12.1828, 1.56650, 7, 1, [-0.122601, 0.034106]),
    (10.6827, 9.11752, 0.541559, 27, 1, [-0.061421, 0.034968]),
]


@pytest.mark.parametrize("span, rise, thickness, voussoirs, per, edges", CAP_ABORTS)
def test_patches_on_pointed_caps_mesh(span, rise, thickness, voussoirs, per, edges):
    from bridgefem.geometry.ring import build_ring

    ring = build_ring("pointed", span, rise, thickness, voussoirs, edges, joint_at_loads=False)
    assert build_block_mesh(ring, per).n_cells > 0
