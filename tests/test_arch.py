"""The bare semicircular arch against independent values: Heyman's minimum thickness under self-weight, the
rigid-block collapse loads of the issue (147.4 kN and 137.1 kN), the LP's hinges, and equilibrium of the
springing reactions with the weight of the ring plus the live load."""
import numpy as np
import pytest
from conftest import scene_dict

from bridgefem.analysis.mechanism import springing_reactions
from bridgefem.analysis.runner import run_analysis
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.reader import scene_from_dict
from bridgefem.search.pathfollow import LIMIT_FOUND, STABLE, UNSTABLE

pytestmark = pytest.mark.slow  # end-to-end analyses

R_CENTRE = 5.0


@pytest.mark.parametrize("ratio,expected", [(0.115, STABLE), (0.100, UNSTABLE)])
def test_self_weight_equilibrium_around_the_classical_minimum_thickness(ratio, expected):
    """64 voussoirs, mu = 0.6: the classical minimum is t/R = 0.1075 (Milankovitch; Heyman), so a ring with
    t/R = 0.115 stands and one with t/R = 0.100 cannot stand."""
    t = ratio * R_CENTRE
    d = scene_dict(arch={"span": 2 * (R_CENTRE - t / 2), "rise": R_CENTRE - t / 2, "thickness": t,
                         "voussoirs": 64}, load=[])
    an = run_analysis(scene_from_dict(d))
    assert an.search.status == expected, an.search.failure


@pytest.mark.parametrize("friction,joint_at_loads,rigid_block_kN", [
    (0.6, False, 147.4),   # even 16-voussoir layout, the load on a voussoir
    (10.0, True, 137.1),   # a joint moved under the load, pure four-hinge mechanism
])
def test_collapse_load_matches_rigid_block_value(friction, joint_at_loads, rigid_block_kN):
    scene = scene_from_dict(scene_dict(arch={"joint_at_loads": joint_at_loads}, joints={"friction": friction}))
    an = run_analysis(scene)
    s = an.search
    assert s.status == LIMIT_FOUND, s.failure
    # within 1 % of the rigid-block value (the FE model with a stiff ring tends to it)
    assert s.lower / 1e3 == pytest.approx(rigid_block_kN, rel=0.01)
    assert s.upper / 1e3 == pytest.approx(rigid_block_kN, rel=0.01)
    assert (s.upper - s.lower) <= scene.solver.tolerance * s.lower
    lp = collapse_load(scene)
    assert [j.id for j in an.joints if j.hinge] == sorted(lp.hinges)
    # reactions = weight + load: exact ring area pi/2 (5.5^2 - 4.5^2); the mesh's straight chords change the
    # weight by about 1e-4, hence 1e-3
    weight = 2000.0 * 9.81 * np.pi / 2 * (5.5 ** 2 - 4.5 ** 2)
    reactions = springing_reactions(an.joints, an.ring).sum(axis=0)
    assert reactions[1] == pytest.approx(weight + s.lower, rel=1e-3)
    assert abs(reactions[0]) <= 1e-6 * weight  # no horizontal load
