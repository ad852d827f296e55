"""The crushed joints in the results (issue 39): per joint the crushed fraction of its length, its compressed depth
(the closed pairs' length) and the stress-block depth N / (f_c w); results.json's mechanism lists the crushed joints
and the console names them with their compressed zones."""
import json

import pytest
from conftest import SMALL_RING
from mpi4py import MPI

from bridgefem.analysis.runner import run_analysis
from bridgefem.io.cli import _crushed_line
from bridgefem.io.results import summary
from bridgefem.scene.reader import scene_from_dict

FC = 0.7e6  # Pa: the limit falls from 8.01 kN (infinitely strong) to 4.34 kN (docs/validation.md)


def analysis(fc=None, elements=4):
    masonry = {**SMALL_RING["masonry"], **({} if fc is None else {"compressive_strength": fc})}
    ring = {**SMALL_RING, "scene": {"name": "crush"}, "mesh": {"elements_through_thickness": elements},
            "masonry": masonry}
    return run_analysis(scene_from_dict(ring), MPI.COMM_WORLD, max_refinements=0)


@pytest.fixture(scope="module")
def strong():
    return analysis()


@pytest.fixture(scope="module")
def weak():
    return analysis(FC)  # the joints graded for the stress block (bridgefem.analysis.stress_block)


def test_without_strength_no_joint_crushes(strong):
    """No strength: every joint has crushed_fraction 0 and no stress-block depth, the crushed list is empty; a
    closed joint's compressed depth is its whole length."""
    assert strong.search.status == "limit load found"
    assert strong.joints and all(j.crushed_fraction == 0 and j.stress_block_depth is None for j in strong.joints)
    for j in strong.joints:
        assert j.compressed_depth == pytest.approx((1 - j.open_fraction) * strong.ring.joints[j.id].length,
                                                   abs=1e-9)
    data = json.loads(json.dumps(summary(strong)))
    assert data["mechanism"]["crushed"] == []
    assert all(j["crushed_fraction"] == 0 and j["stress_block_depth"] is None for j in data["joints"])
    assert "crushed_fraction" in data["units"]["dimensionless"]
    assert "stress_block_depth" in data["units"]["length"]


@pytest.mark.slow  # a crushing FE run of its own (about 10 s)
def test_weak_masonry_crushes_its_hinges(weak):
    """f_c = 0.7 MPa, 16 elements: the four hinges at the last converged step are crushed; at each crushed hinge the
    stress block N / (f_c w) is as deep as the crushed length to within one element (the crushed pairs carry f_c w
    per metre, the rest of the compressed zone less), and the compressed zone is at least the crushed length."""
    assert weak.search.status == "limit load found"
    assert weak.search.lower * weak.load_total < 4.5e3
    h = weak.block_mesh.element_size
    hinges = [j for j in weak.joints if j.hinge]
    assert len(hinges) == 4
    for j in hinges:
        length = weak.ring.joints[j.id].length
        crushed = j.crushed_fraction * length
        assert crushed > 0, j
        assert j.stress_block_depth == pytest.approx(j.normal_force / (FC * weak.scene.arch.width))
        assert abs(j.stress_block_depth - crushed) <= h, j
        assert j.compressed_depth >= crushed - 1e-9 * length, j
    data = json.loads(json.dumps(summary(weak)))
    crushed_ids = [j.id for j in weak.joints if j.crushed_fraction > 0]
    assert data["mechanism"]["crushed"] == crushed_ids
    assert set(data["mechanism"]["hinges"]) <= set(crushed_ids)
    line = _crushed_line(data)
    assert line.startswith(f"crushed joints {crushed_ids} (compressed zones: ")
    assert all(f"{j.id}: {j.compressed_depth:.3f} m" in line for j in hinges)
