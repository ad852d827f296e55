"""Scene features the user guide documents, each against an independent value: the rigid-block LP on the same joints
(an FE bracket of a stiff ring tends to it), scale invariance (width, load factor), hand areas and the lower-bound
theorem. End-to-end analyses: marked slow."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import scene_dict

from bridgefem.analysis.runner import run_analysis
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.reader import scene_from_dict
from bridgefem.search.pathfollow import LIMIT_FOUND, LOCKED, STABLE

pytestmark = pytest.mark.slow

FE_LP_REL = 0.01  # FE bracket against the LP on the same joints (as in test_extremes: bracket, chords, nodal hinge)


def fe_and_lp(**sections):
    scene = scene_from_dict(scene_dict(**sections))
    return run_analysis(scene), collapse_load(scene)


def assert_fe_brackets_lp(an, lp, rel=FE_LP_REL):
    s = an.search
    assert s.status == LIMIT_FOUND, s.failure
    assert lp.status == LIMIT_FOUND
    live = an.load_total
    assert s.lower * live <= lp.load * (1 + rel) and s.upper * live >= lp.load * (1 - rel), (s.lower, s.upper, lp.load)


def overlap(a, b, scale=1.0):
    """Two searches' brackets (b scaled) share a point: both contain the same limit load."""
    return a.lower <= scale * b.upper and a.upper >= scale * b.lower


@pytest.mark.parametrize("shape,rise,thickness", [
    ("pointed", 6.0, 0.8), ("elliptical", 3.0, 1.0), ("parabolic", 3.0, 0.8), ("elliptical", 3.0, 0.8),
])
def test_other_shapes_match_the_lp(shape, rise, thickness):
    """Odd voussoir counts (15): the FE limit of pointed, elliptical and parabolic rings brackets their LP."""
    an, lp = fe_and_lp(arch={"shape": shape, "rise": rise, "thickness": thickness, "voussoirs": 15})
    assert_fe_brackets_lp(an, lp)


def test_width_scales_loads_and_limit():
    """Everything is per width: a 2 m wide ring carries twice the 1 m ring's limit load (the same bracket x 2)."""
    one, lp1 = fe_and_lp()
    two, lp2 = fe_and_lp(arch={"width": 2.0})
    assert lp2.load == pytest.approx(2 * lp1.load, rel=1e-9)
    assert two.model.dead_weight == pytest.approx(2 * one.model.dead_weight, rel=1e-12)
    assert overlap(two.search, one.search, 2.0), (two.search.lower, two.search.upper, one.search.lower)
    assert_fe_brackets_lp(two, lp2)


def test_plane_stress_is_softer_with_the_same_limit():
    """Plane stress: the same rigid-block limit (LP) and a larger self-weight deflection than plane strain (its
    moduli are below plane strain's: E against E / (1 - nu^2)); by about 1 / (1 - nu^2) = 1.04, 10 % allowing for the
    joints' contact state."""
    strain, _ = fe_and_lp()
    stress, lp = fe_and_lp(model={"plane": "stress"})
    assert_fe_brackets_lp(stress, lp)
    d_strain, d_stress = (a.search.steps[0].deflection for a in (strain, stress))
    assert 1.0 < d_stress / d_strain < 1.1


def test_patch_and_several_loads_with_factors():
    """A patch load and a point load with factor 0.5: the FE brackets the LP of the same pattern."""
    loads = [{"kind": "patch", "position": 0.3, "length": 1.0}, {"kind": "point", "position": 0.7, "factor": 0.5}]
    an, lp = fe_and_lp(load=loads)
    assert an.load_total == 1.5
    assert_fe_brackets_lp(an, lp)


def test_load_factor_scales_the_level_not_the_load():
    """factor = 2 on the only load halves the load level; the limit load (N) is the factor-1 one."""
    one, _ = fe_and_lp()
    two, _ = fe_and_lp(load=[{"kind": "point", "position": 0.22222, "factor": 2.0}])
    assert two.load_total == 2.0
    assert overlap(two.search, one.search, 0.5)


@pytest.mark.parametrize("preset,elements,tolerance", [("fast", 2, 5e-4), ("accurate", 8, 1e-4)])
def test_presets(preset, elements, tolerance):
    """The presets set the mesh and the bracket tolerance; both bracket the LP."""
    an, lp = fe_and_lp(solver={"preset": preset})
    assert an.scene.mesh.elements_through_thickness == elements and an.search.tolerance == tolerance
    assert an.search.upper - an.search.lower <= tolerance * an.search.lower * (1 + 1e-12)
    assert_fe_brackets_lp(an, lp)


def test_locked_below_the_maximum_load():
    """max_load below the LP's collapse load: no collapse up to it ("locked"), lower bound at max_load."""
    an, lp = fe_and_lp(solver={"max_load": 50e3})
    assert lp.load > 50e3
    assert an.search.status == LOCKED and an.search.upper is None
    assert an.search.lower == pytest.approx(50e3, rel=1e-12)


FILL = {"material": "elastic", "unit_weight": 18000.0, "young": 50e6, "depth": 0.5, "extension": 2.0}


def fill_weight_by_hand(scene) -> float:
    """Unit weight x (the fill's box minus the half disc under the extrados), N for a width of 1 m."""
    r_out, f = 5.5, scene.fill
    return f.unit_weight * (2 * (r_out + f.extension) * (r_out + f.depth) - np.pi / 2 * r_out ** 2)


def test_fill_element_size_refines_and_keeps_the_weight():
    """[fill] element_size sets the fill mesh (0, the default: twice the ring's element size); at every size the
    fill weighs its hand value (1e-3: the chords of the curved extrados)."""
    cells = {}
    for size in (0.0, 0.2, 0.6):
        an = run_analysis(scene_from_dict(scene_dict(load=[], fill={**FILL, "element_size": size})))
        assert an.model.fill_weight == pytest.approx(fill_weight_by_hand(an.scene), rel=1e-3)
        cells[size] = an.block_mesh.n_cells
    assert cells[0.2] > 1.5 * cells[0.6] and cells[0.2] > cells[0.0]


def test_tension_cutoff_fill_carries_its_weight():
    """A Mohr-Coulomb fill with a 5 kPa tension cut-off stands under self-weight with the ring (a soil column in
    compression never reaches the cut-off) and weighs its hand value (P1 t/4: the extrados' chords of 0.25 m keep
    the weight within 1e-3; with the fill preset's t/2 chords of 0.5 m the fill is 1.8e-3 heavy)."""
    fill = {**FILL, "material": "mohr-coulomb", "friction_angle": 30.0, "cohesion": 2000.0, "tension_cutoff": 5000.0}
    mesh = {"degree": 1, "elements_through_thickness": 4}
    an = run_analysis(scene_from_dict(scene_dict(load=[], fill=fill, mesh=mesh)))
    assert an.search.status == STABLE, an.search.failure
    assert an.model.fill_weight == pytest.approx(fill_weight_by_hand(an.scene), rel=1e-3)
