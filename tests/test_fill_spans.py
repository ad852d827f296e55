"""A fill over spans of different rings is meshed at each span's scale: along each extrados and at each load the
size of the span under it, graded away from the rings to the bridge's far size (twice the coarsest span's outer ring
element size), each pier's course with as many elements across as a ring has through its thickness; the size
estimate follows that mesh."""
import numpy as np
import pytest
from mpi4py import MPI

from bridgefem.fe.mesh import LOAD_REFINEMENT, ROAD_TAG, _gmsh_bridge, build_block_mesh, joint_face_tag
from bridgefem.geometry.ring import fill_outline
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.ring import scene_ring
from bridgefem.structure.sizing import (
    TRIANGLES_PER_AREA,
    estimate_size,
    extrados_element_size,
    fill_far_size,
)

THIN = {"shape": "segmental", "span": 6.0, "rise": 1.5, "thickness": 0.15, "voussoirs": 12}
THICK = {"shape": "segmental", "span": 8.0, "rise": 2.0, "thickness": 0.6, "voussoirs": 12}
PIER = {"width": 1.5, "height": 3.0, "blocks": 2}
ETT = 2  # elements through each ring: thin 0.075 m, thick 0.3 m
DEPTH = 0.5  # m of fill over the highest crown


def bridge(spans: list[dict], load_x: float | None = None, fill: bool = True):
    """The scene of ``spans`` on equal piers, a point load at ``load_x`` (m; default: the first span's crown), under
    an elastic fill ``DEPTH`` deep (or none), and its ring."""
    x = spans[0]["span"] / 2 if load_x is None else load_x
    d = {"span": [dict(s) for s in spans], "pier": [dict(PIER) for _ in spans[1:]],
         "masonry": {"young": 1e10, "density": 2000.0}, "joints": {"friction": 0.6},
         "load": [{"kind": "point", "x": x}], "mesh": {"elements_through_thickness": ETT, "degree": 1},
         **({"fill": {"unit_weight": 18e3, "young": 5e7, "depth": DEPTH, "extension": 1.0}} if fill else {})}
    scene = scene_from_dict(d)
    return scene, scene_ring(scene)


def fill_mesh(scene, ring):
    """The mesher's block mesh of the scene's bridge and fill (the fill's far size its default)."""
    outline = fill_outline(ring, scene.fill.depth, scene.fill.extension, scene.load_edges_x())
    return build_block_mesh(ring, ETT, MPI.COMM_SELF, outline, scene.fill.element_size)


def block_triangles(bm, block: int) -> np.ndarray:
    """The triangles (k, 3, 2) of the cells tagged ``block``."""
    cells = bm.cell_tags.indices[bm.cell_tags.values == block]
    dofs = bm.mesh.geometry.dofmap.array.reshape(-1, 3)[cells]
    return bm.mesh.geometry.x[dofs][:, :, :2]


def areas(tri: np.ndarray) -> np.ndarray:
    a, b = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    return 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])


def test_the_fill_is_meshed_alike_whichever_span_comes_first():
    """A thin span beside a thick one, and the same bridge mirrored (the thick span first): the fill's triangles
    within 5 % of each other in number (the far size twice the thick ring's element size, 0.6 m, not the thin one's,
    0.15 m, wherever the thin span stands); the load over the thin span's crown."""
    counts = []
    thin_second = THICK["span"] + PIER["width"] + THIN["span"] / 2
    for spans, x in (([THIN, THICK], THIN["span"] / 2), ([THICK, THIN], thin_second)):
        scene, ring = bridge(spans, load_x=x)  # the load over the thin span's crown
        bm = fill_mesh(scene, ring)
        counts.append(len(block_triangles(bm, bm.fill_block)))
    assert counts[0] == pytest.approx(counts[1], rel=0.05), counts


def test_each_pier_course_is_meshed_with_as_many_elements_across_as_a_ring_through_its_thickness():
    """Thin, thick, thick on piers 1.5 m wide of two courses 1.5 m high: every course at 1.5 m / ETT = 0.75 m
    whatever the rings it carries (above twice the thick ring's element size, 0.6 m, and far above the thin ring's
    0.15 m): ``TRIANGLES_PER_AREA`` x its triangles' mean area / 0.75^2 within a factor 2 of 1 (at 0.15 m it would be
    1/25), Gmsh grading it from the springings' finer nodes; a bed joint has as many pairs as a ring joint."""
    scene, ring = bridge([THIN, THICK, THICK], fill=False)
    bm = build_block_mesh(ring, ETT, MPI.COMM_SELF)
    size = PIER["width"] / ETT
    for k in (0, 1):
        mean = np.mean(areas(np.concatenate([block_triangles(bm, b.id) for b in ring.piers if b.pier == k])))
        assert 0.5 < TRIANGLES_PER_AREA * mean / size ** 2 < 2.0, (k, mean)
    bed = [j for j in ring.joints if j.kind == "pier"]
    faces = [int(np.sum(bm.facet_tags.values == joint_face_tag(j.id, 0))) for j in bed]
    assert bed and faces == [ETT] * len(bed), faces


def test_a_load_over_a_thick_span_is_refined_at_that_spans_scale():
    """A point load over the thick span's crown of a thin-thick bridge: the road's segments that end at the load
    are ``LOAD_REFINEMENT`` x the thick span's extrados size (0.25 m x 0.5) within 30 %, not the thin span's
    (0.075 m x 0.5)."""
    x = THIN["span"] + PIER["width"] + THICK["span"] / 2
    scene, ring = bridge([THIN, THICK], load_x=x)
    outline = fill_outline(ring, DEPTH, scene.fill.extension, scene.load_edges_x())
    raw = _gmsh_bridge(ring, ETT, outline, fill_far_size(ring, ETT))
    frame_x = x - THIN["span"] / 2  # the frame's origin is the first span's midspan
    road = raw.x[raw.fill[ROAD_TAG]]
    at_load = np.any(np.abs(road[:, :, 0] - frame_x) < 1e-9, axis=1)
    lengths = np.linalg.norm(road[at_load, 1] - road[at_load, 0], axis=1)
    assert len(lengths) == 2
    expected = LOAD_REFINEMENT * extrados_element_size(THICK["thickness"], ETT, DEPTH)
    assert lengths == pytest.approx([expected, expected], rel=0.3), lengths


@pytest.mark.parametrize("spans", [[THIN, THICK], [THICK, THIN], [THIN, THICK, THIN]])
def test_the_size_estimate_follows_the_fill_mesh_over_different_spans(spans):
    """The estimate from the scene (no mesh) against the mesher's cells, whichever span is thin: never below 0.7 x
    (it guards the machine's memory: a low estimate lets a model too large for it run), at most 1.6 x (the
    estimate's field has no load refinement and Gmsh meshes the band along the extrados coarser than its field)."""
    scene, ring = bridge(spans)
    bm = fill_mesh(scene, ring)
    assert 0.7 <= estimate_size(scene).cells / bm.n_cells <= 1.6, (estimate_size(scene).cells, bm.n_cells)


def test_the_fills_far_size_is_the_one_given_else_twice_the_coarsest_outer_ring():
    """``[fill] element_size`` sets the far size; without it twice the coarsest span's outer ring element size, on
    either side of the bridge."""
    for spans in ([THIN, THICK], [THICK, THIN]):
        _, ring = bridge(spans)
        assert fill_far_size(ring, ETT, 0.4) == 0.4
        assert fill_far_size(ring, ETT) == pytest.approx(2 * THICK["thickness"] / ETT)
