"""Richardson extrapolation of the mesh study (bridgefem.analysis.convergence) on sequences with a known limit."""
import pytest
from conftest import scene_dict

from bridgefem.analysis.convergence import MeshLimit, richardson, study
from bridgefem.scene.reader import scene_from_dict


@pytest.mark.parametrize("order", [0.5, 1.0, 1.75, 2.0])
def test_richardson_recovers_limit_and_order_of_a_power_law(order):
    """L(h) = L* + C h^p on h = 1, 1/2, 1/4: the order and L* are exact; U = 1.25 |L* - L3|."""
    exact, c = 205e3, 40e3
    limits = [exact + c * h ** order for h in (1.0, 0.5, 0.25)]
    ex = richardson(limits)
    assert ex.order == pytest.approx(order, rel=1e-12)
    assert ex.value == pytest.approx(exact, rel=1e-12)
    assert ex.uncertainty == pytest.approx(1.25 * c * 0.25 ** order, rel=1e-9)


def test_richardson_uses_the_three_finest_and_adds_the_bracket_widths():
    ex = richardson([1e9, 300.0, 250.0, 225.0], half_widths=[0.0, 1.0, 2.0, 0.5])
    assert ex.order == pytest.approx(1.0) and ex.value == pytest.approx(200.0)
    assert ex.uncertainty == pytest.approx(1.25 * 25.0 + 2.0)


@pytest.mark.parametrize("limits,spread", [([230.0, 220.0, 226.0], 10.0), ([244.0, 240.0, 228.0], 16.0),
                                           ([230.0, 220.0, 210.0], 20.0)],
                         ids=["oscillating", "growing differences", "constant differences"])
def test_limits_outside_the_asymptotic_range_have_no_order(limits, spread):
    """Differences of opposite sign, growing or not shrinking: no extrapolation, the finest value with the largest
    difference as U."""
    ex = richardson(limits)
    assert ex.order is None and ex.value == limits[-1] and ex.uncertainty == pytest.approx(spread)


def test_study_needs_three_meshes_refined_by_two():
    scene = scene_from_dict(scene_dict())
    for levels in ([2, 4], [2, 4, 6], [2, 3, 4]):
        with pytest.raises(ValueError, match="levels"):
            study(scene, levels)


def test_a_mesh_without_a_bracket_leaves_the_study_without_extrapolation(monkeypatch):
    """A solver failure's last converged load is no limit: a study whose finest mesh failed does not extrapolate,
    and its table says which mesh (the small bridge of docs/bounds.md once gave 'L* = 75.3 +- 57.0 kN' from one)."""
    from bridgefem.analysis import convergence

    meshes = iter([MeshLimit(2, 151.7, 151.8, "limit load found", 1, 1, 1, 1.0),
                   MeshLimit(4, 134.2, 134.4, "limit load found", 1, 1, 1, 1.0),
                   MeshLimit(8, 120.8, None, "solver failure: x", 1, 1, 1, 1.0)])
    monkeypatch.setattr(convergence, "solve_mesh", lambda scene, comm: next(meshes))
    scene = scene_from_dict(scene_dict())
    found, ex = study(scene, [2, 4, 8])
    assert ex is None and len(found) == 3
    assert "no extrapolation: t/8 ended without a bracket" in convergence.table(scene, found, ex)


def test_mesh_limit_is_the_bracket_midpoint():
    assert MeshLimit(4, 100.0, 102.0, "limit load found", 10, 5, 5, 1.0).limit == 101.0
    assert MeshLimit(4, 100.0, None, "solver failure", 10, 5, 5, 1.0).limit == 100.0


def test_converge_command_rejects_bad_levels(tmp_scene):
    from conftest import bridgefem
    proc = bridgefem("converge", tmp_scene(scene_dict()), "--levels", "2,4,6")
    assert proc.returncode == 2 and "--levels '2,4,6'" in proc.stderr and "2 x the previous" in proc.stderr


@pytest.mark.slow
def test_converge_command_on_a_bare_arch_extrapolates_to_the_rigid_block_limit(tmp_scene, tmp_path):
    """The reference arch (no fill) on t/1, t/2, t/4: every mesh closes its bracket and the extrapolated limit is
    the rigid-block LP's collapse load (the FE converges to it as the elastic voussoirs stiffen) within 1 %."""
    import json

    from conftest import bridgefem

    from bridgefem.limit.collapse import collapse_load
    d = scene_dict()
    proc = bridgefem("converge", tmp_scene(d), "--levels", "1,2,4", "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    data = json.loads((tmp_path / "out/convergence.json").read_text())
    assert [m["elements_through_thickness"] for m in data["meshes"]] == [1, 2, 4]
    lp = collapse_load(scene_from_dict(d)).load
    assert data["extrapolation"]["value"] == pytest.approx(lp, rel=0.01)
    assert "extrapolated limit" in proc.stdout
