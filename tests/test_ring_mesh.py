"""Joints are evenly spaced along the centreline, rings the geometry cannot mesh are clear errors, and loads next to
joints make no sliver edges (which made Gmsh hang or abort). The full probe over shapes, voussoir counts and loads is
benchmarks/mesh_probe.py."""
import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT, scene_dict

from bridgefem.fe.model import POINT_RTOL
from bridgefem.geometry.ring import AT_JOINT_TOL, build_ring
from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.ring import scene_ring


def edge_steps(v):
    return np.linalg.norm(np.diff(v.extrados, axis=0), axis=1)


@pytest.mark.parametrize("offset", [1e-9, 1e-7, 1e-5])
def test_load_next_to_a_joint_is_on_the_joint(offset):
    """joint_at_loads = false, a point load offset x span from a joint's extrados corner: no edge point of its own
    (the load acts at the corner), and no edge step shorter than a quarter of the regular one."""
    ring = build_ring("semicircular", 10.0, 5.0, 0.8, 7)
    x = ring.joints[3].extrados[0] + offset * 10.0
    near = build_ring("semicircular", 10.0, 5.0, 0.8, 7, [x], joint_at_loads=False)
    for v, v0 in zip(near.voussoirs, ring.voussoirs):
        assert v.extrados_splits == () and len(v.extrados) == len(v0.extrados)
        assert edge_steps(v).min() > 0.25 * edge_steps(v0).min()


def test_load_apart_from_joints_gets_its_own_edge_point():
    ring = build_ring("semicircular", 10.0, 5.0, 0.8, 7)
    x = ring.joints[3].extrados[0] + 3 * AT_JOINT_TOL * 10.0
    near = build_ring("semicircular", 10.0, 5.0, 0.8, 7, [x], joint_at_loads=False)
    v = near.voussoirs[3]
    assert len(v.extrados_splits) == 1  # within the FE's node tolerance (model.POINT_RTOL x span) of the load
    assert v.extrados[v.extrados_splits[0], 0] == pytest.approx(x, abs=POINT_RTOL * 10.0)


@pytest.mark.parametrize("joint_at_loads", [True, False])
def test_loads_closer_than_the_tolerance_are_a_scene_error(joint_at_loads):
    d = scene_dict(arch={"joint_at_loads": joint_at_loads},
                   load=[{"kind": "point", "position": 0.3}, {"kind": "point", "position": 0.3 + 1e-8}])
    with pytest.raises(SceneError, match="closer than"):
        scene_ring(scene_from_dict(d))
    d["load"][1]["position"] = 0.3  # the same position twice is one load point
    assert scene_ring(scene_from_dict(d)).n_voussoirs == 16


@pytest.mark.slow
def test_meshes_that_aborted_gmsh():
    """Cases that made Gmsh abort (SIGABRT) or run out of memory: loads 1e-7 voussoir lengths from a joint, and
    voussoirs shorter than one element with an edge split at a load. Meshed in a child process, so that an abort
    fails this test instead of killing the test run."""
    cases = [("semicircular", 10.0, 5.0, 7, 4, 1e-7), ("semicircular", 10.0, 5.0, 64, 1, 0.3),
             ("semicircular", 10.0, 5.0, 256, 1, 0.3), ("pointed", 10.0, 8.66, 8, 2, 0.3)]
    code = f"""
import json
from bridgefem.geometry.ring import build_ring
from bridgefem.fe.mesh import _gmsh_bridge
out = []
for shape, span, rise, n, per, offset in {cases!r}:
    ring = build_ring(shape, span, rise, 0.8, n)
    a, b = (ring.joints[k].extrados[0] for k in (n // 3, n // 3 + 1))
    x = a + offset * (b - a)
    out.append(len(_gmsh_bridge(build_ring(shape, span, rise, 0.8, n, [x], False), per, None, 0.0).cells))
print(json.dumps(out))
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-2000:]
    cells = json.loads(run.stdout.splitlines()[-1])
    assert all(c > 0 for c in cells)


@pytest.mark.parametrize("shape,span,rise,thickness,voussoirs", [
    ("pointed", 24.967, 24.404, 5.4763, 233),  # campaign seed 1 #235: a 3.2 m jump at the crown, 12 joints on it
    ("pointed", 3.755, 2.882, 0.9225, 109),    # seed 1 #75
    ("pointed", 6.0, 6.0 * np.sqrt(3) / 2, 0.6, 28),  # equilateral, a joint at the apex
    ("pointed", 6.0, 6.0 * np.sqrt(3) / 2, 0.6, 27),  # ... a keystone across it
    ("semicircular", 10.0, 5.0, 1.0, 36),
    ("segmental", 10.0, 2.5, 0.5, 15),
])
def test_joints_are_evenly_spaced_along_each_arcs_centreline(shape, span, rise, thickness, voussoirs):
    """On a circular arc the centreline's length grows with the angle, and the shapes' parameter p is proportional
    to it on each arc (the pointed arch's two arcs meet at p = 0.5), so joints evenly spaced along the centreline are
    at p = j / n exactly. At the pointed crown the centreline jumps between the offsets of its two arcs: counted as
    length, that jump drew every joint that fell on it to the apex (#235: 12 joints within 5e-4 of it, voussoirs of
    2.6 mm)."""
    ring = build_ring(shape, span, rise, thickness, voussoirs)
    assert np.allclose(ring.params, np.linspace(0.0, 1.0, voussoirs + 1), rtol=0, atol=1e-9)
