"""The model's size from the scene alone: close to the mesher's counts, a scene beyond the machine refused with the
numbers, a large run announced with its set-up phases."""
import numpy as np
import pytest
from conftest import scene_dict, write_toml

from bridgefem.io import cli
from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.grading import GRADING_TOLERANCES, graded_nodes
from bridgefem.structure.sizing import (
    GRADED_PAIRS,
    MAX_DOFS,
    _densify,
    check_size,
    estimate_size,
    graded_elements,
    most_graded_elements,
)


@pytest.mark.slow
@pytest.mark.parametrize("voussoirs,elements,degree", [(16, 4, 1), (64, 8, 2)])
def test_the_estimate_is_close_to_the_model_and_the_phases_are_announced(voussoirs, elements, degree):
    from bridgefem.analysis.runner import run_analysis

    scene = scene_from_dict(scene_dict(arch={"voussoirs": voussoirs}, solver={"max_steps": 1},
                                       mesh={"elements_through_thickness": elements, "degree": degree}))
    phases = []
    an = run_analysis(scene, phase=phases.append)
    size = estimate_size(scene)
    assert size.cells == pytest.approx(an.block_mesh.n_cells, rel=0.02)
    assert size.dofs == pytest.approx(an.n_dofs, rel=0.02)
    assert phases == ["meshing", "assembling", "pairing the joints", "setting up the solver (first factorisation)",
                      "limit search"]


@pytest.mark.slow
def test_the_estimate_counts_the_graded_joints():
    """A 1 MPa ring (its joints graded for the stress block, 16 voussoirs): the estimate with the run's graded
    joints within 2 % of the mesher's cells and the model's unknowns, and the estimate from the scene alone (the most
    the grading may give) no smaller."""
    from bridgefem.analysis.runner import run_analysis

    scene = scene_from_dict(scene_dict(masonry={"compressive_strength": 1e6}, solver={"max_steps": 1}))
    an = run_analysis(scene)
    nodes = an.block_mesh.joint_nodes
    assert nodes is not None and len(nodes) - 1 > scene.mesh.elements_through_thickness
    size = estimate_size(scene, nodes)
    assert size.cells == pytest.approx(an.block_mesh.n_cells, rel=0.02)
    assert size.dofs == pytest.approx(an.n_dofs, rel=0.02)
    assert estimate_size(scene).dofs >= size.dofs


def test_the_graded_joints_stay_within_the_pair_budget():
    """The most elements the grading may give a joint: (GRADED_PAIRS / joints - 1) / degree, counted by hand, and
    never fewer than the even elements; without a strength the estimate keeps the even joints, with one it counts the
    densest grading (hinge zones from none to the middle at the finest tolerance) within that bound."""
    def scene(voussoirs, degree=1, ett=4, fc=1e6, rings=None):
        arch = {"voussoirs": voussoirs, **({"rings": rings, "ring_bond": "aligned"} if rings else {})}
        return scene_from_dict(scene_dict(arch=arch, mesh={"elements_through_thickness": ett, "degree": degree},
                                          masonry={} if fc is None else {"compressive_strength": fc}))

    assert GRADED_PAIRS == 3000
    assert most_graded_elements(scene(199)) == 14  # 200 joints x 15 pairs
    assert most_graded_elements(scene(99, degree=2)) == 14  # 100 joints x 29 pairs
    assert most_graded_elements(scene(39, rings=2)) == 36  # 2 rings of 40 joints x 37 pairs
    assert most_graded_elements(scene(999)) == 4  # the even elements, however many joints
    densest = len(graded_nodes(4, GRADING_TOLERANCES[-1], (0.0, 0.5))) - 1
    assert all(len(graded_nodes(4, t, (z0, z1))) - 1 <= densest for t in GRADING_TOLERANCES
               for z0 in (0.0, 1e-3, 0.05) for z1 in (0.05, 0.25, 0.5))
    assert graded_elements(scene(16)) == densest and graded_elements(scene(199)) == 14
    assert graded_elements(scene(16, fc=None)) == 4 and graded_elements(scene(16), (0.0, 0.1, 0.5, 0.9, 1.0)) == 4
    assert estimate_size(scene(16, fc=None)).dofs < estimate_size(scene(16)).dofs


def test_a_scene_beyond_the_machine_is_refused_with_the_numbers():
    huge = scene_from_dict(scene_dict(arch={"voussoirs": 4096}, mesh={"elements_through_thickness": 64}))
    with pytest.raises(SceneError, match=r"voussoirs = 4096.*elements_through_thickness = 64.*unknowns"):
        check_size(huge)
    assert check_size(huge, max_dofs=float("inf")).dofs > MAX_DOFS  # --no-size-limit: only the memory limit
    with pytest.raises(SceneError, match=r"GB of memory .*allowed 80 % of this machine's 0.2 GB"):
        check_size(scene_from_dict(scene_dict()), memory=0.2e9)
    small = check_size(scene_from_dict(scene_dict()))
    assert 400 < small.cells < 600 and 0.1e9 < small.memory < 0.5e9


def test_a_fill_meshed_too_finely_is_refused_naming_the_fill():
    """The finest fill mesh the range allows (2e-3 x span) over the deepest and longest fill: the size check
    refuses it naming the fill's keys (not only the ring's)."""
    fill = {"unit_weight": 18000.0, "young": 1e8, "depth": 90.0, "extension": 90.0, "element_size": 0.018}
    with pytest.raises(SceneError, match=r"voussoirs = 16.*\[fill\] element_size = 0.018, depth = 90, extension = 90"
                                         r".*a coarser fill mesh or a smaller fill"):
        check_size(scene_from_dict(scene_dict(fill=fill)))


@pytest.mark.slow
def test_a_large_run_prints_its_estimate_and_phases(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli, "LARGE_DOFS", 0)
    scene = write_toml(tmp_path / "s.toml", scene_dict(mesh={"elements_through_thickness": 1},
                                                       solver={"tolerance": 0.01}))
    assert cli.main(["run", str(scene), "--out", str(tmp_path / "out")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("s: about ") and "unknowns" in lines[0]
    assert lines[1:6] == ["  meshing ...", "  assembling ...", "  pairing the joints ...",
                          "  setting up the solver (first factorisation) ...", "  limit search ..."]
    assert lines[6].startswith("load steps: ") and lines[7].startswith("step   0")


def test_a_densified_polyline_keeps_its_vertices_and_its_spacing():
    """The points the fill's size field measures distances to: every vertex in order, each segment cut into
    ceil(length / spacing) equal parts (one for a segment of no length), consecutive points at most the spacing
    apart and on the polyline."""
    rng = np.random.default_rng(3)
    line = np.cumsum(rng.normal(size=(12, 2)), axis=0)
    line[5] = line[4]  # a segment of no length
    spacing = 0.3
    points = _densify(line, spacing)
    lengths = np.linalg.norm(np.diff(line, axis=0), axis=1)
    parts = np.maximum(1, np.ceil(lengths / spacing)).astype(int)
    assert len(points) == 1 + parts.sum()
    ends = np.concatenate([[0], np.cumsum(parts)])
    assert np.allclose(points[ends], line, rtol=0, atol=1e-12)
    assert np.linalg.norm(np.diff(points, axis=0), axis=1).max() <= spacing * (1 + 1e-12)
    for i, (a, b) in enumerate(zip(ends[:-1], ends[1:])):  # segment i's points lie on it, equally spaced
        along = np.linalg.norm(points[a:b + 1] - line[i], axis=1)
        assert np.allclose(along, np.linspace(0.0, lengths[i], b - a + 1), rtol=0, atol=1e-12)
