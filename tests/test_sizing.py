"""The model's size from the scene alone: close to the mesher's counts, a scene beyond the machine refused with the
numbers, a large run announced with its set-up phases."""
import pytest
from conftest import scene_dict, write_toml

from bridgefem.io import cli
from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.sizing import MAX_DOFS, check_size, estimate_size


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
