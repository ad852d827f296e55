"""The fast unit layer (milliseconds each): hinge marking, labelled outputs and plots from plain data, the
console's wording, the rigid-block LP on a tiny arch. No FE analysis runs here."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import scene_dict

from bridgefem.analysis.mechanism import JointState, _mark_hinges, springing_reactions
from bridgefem.geometry.ring import build_ring
from bridgefem.io.cli import _collapse
from bridgefem.io.plots import bracket_decimals, format_bracket, plot_load_deflection, plot_mechanism
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.reader import scene_from_dict


def ring4():
    return build_ring("semicircular", 9.0, 4.5, 1.0, 4, [], joint_at_loads=False)


def state(jid, ecc, open_fraction=0.0, opening=0.0):
    return JointState(jid, 1e4, 0.0, ecc, open_fraction, opening, 0)


def test_a_run_of_cracked_joints_has_one_hinge_at_its_largest_eccentricity():
    """Joints 1 and 2 cracked towards the extrados (adjacent: they share voussoir 1): one hinge, at the larger |e|;
    joint 4 cracked towards the intrados on its own: a hinge at the intrados; uncracked joints none."""
    ring = ring4()
    t = ring.joints[0].length
    states = [state(0, 0.1 * t), state(1, 0.495 * t), state(2, 0.499 * t), state(3, 0.0), state(4, -0.499 * t)]
    _mark_hinges(states, ring)
    assert [s.hinge for s in states] == ["", "", "extrados", "", "intrados"]


def test_springing_reactions_balance_the_joint_resultants():
    """The ground pushes the ring with +resultant where it is the left block (joint 0) and -resultant at the right
    springing: two vertical joints with equal compression give equal upward reactions."""
    ring = ring4()
    states = [state(j, 0.0) for j in range(5)]
    reactions = springing_reactions(states, ring)
    assert reactions.shape == (2, 2)
    assert reactions[:, 1] == pytest.approx([1e4, 1e4])  # springing joints are horizontal, compression -> up


@pytest.mark.parametrize("width,decimals", [(0.0137, 3), (0.137, 2), (1e-5, 6), (0.0, 2)])
def test_bracket_decimals_show_the_bracket(width, decimals):
    assert bracket_decimals(width) == decimals


def test_format_bracket_at_the_readme_tolerance():
    assert format_bracket(137056.1, 137064.2, 1e-4) == "[137.056, 137.064] kN"
    assert format_bracket(5e4, None, 1e-4) == "[50.0000, none] kN"  # a width of 5 N needs 4 decimals in kN


def test_a_proven_collapse_reads_as_a_mechanism_not_a_divergence():
    text = _collapse("diverged: displacement 9.02e+04 m exceeds the cap 185 m (no equilibrium: mechanism)")
    assert text == "no equilibrium: the voussoirs move as a mechanism" and "9.02e+04" not in text
    assert "flat" in _collapse("load-deflection curve flat: secant stiffness 3 N/m below 0.02 x the initial")
    assert "static theorem" in _collapse("no trial above the bracket: its upper end is the static theorem's bound")
    rings = _collapse("the converged state is a collapse state: the rings under the loads the fill transmits "
                      "(rigid-block LP, associative friction) collapse at 6091.51 kN, 1.0000385 x the load")
    assert "the rings move as a mechanism" in rings and "no equilibrium" not in rings  # evidence 5: no such claim


def results_dict():
    """A minimal results.json as plots read it (loads in N, deflections in m)."""
    return {"scene": "a scene with a rather long name that needs more than one line of title to fit the figure",
            "status": "limit load found",
            "limit_load": {"lower": 137056.1, "upper": 137064.2, "unit": "N", "tolerance": 1e-4, "width": 1.0},
            "history": [{"load": 0.0, "deflection": 1e-4, "converged": True},
                        {"load": 1e5, "deflection": 8e-4, "converged": True},
                        {"load": 137056.1, "deflection": 2e-3, "converged": True},
                        {"load": 137064.2, "deflection": None, "converged": False}],
            "mechanism": {"hinges": [0, 2], "hinge_positions": {"0": "intrados", "2": "extrados"}, "sliding": [3]},
            "lp": {"load": 137095.0, "model": "bare ring",
                   "mechanism": {"hinges": [0, 2], "hinge_positions": {"0": "intrados", "2": "extrados"},
                                 "sliding": []}},
            "loads": [{"x": -2.5}]}


def test_plots_from_a_results_dict(tmp_path):
    ring = ring4()
    data = results_dict()
    plot_load_deflection(data, tmp_path / "ld.png")
    mode = np.zeros((4, 3))
    mode[2:, 2] = 1e-3  # two voussoirs turn
    fill = np.array([[-8, 0], [-8, 6], [8, 6], [8, 0], [5.5, 0], [-5.5, 0]], float)
    plot_mechanism(ring, data, mode, tmp_path / "m.png", fill)
    for name in ("ld.png", "m.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_load_deflection_plot_without_a_converged_step_has_no_empty_legend(tmp_path, caplog):
    """A ring unstable under self-weight, whose LP has no load either, has nothing to draw in the legend: the plot
    says so in its axes and matplotlib logs no warning (it did: "No artists with labels found")."""
    data = {**results_dict(), "status": "unstable under self-weight", "lp": {"load": None, "model": "bare ring"},
            "history": [{"load": 0.0, "deflection": None, "converged": False}]}
    with caplog.at_level("WARNING"):
        plot_load_deflection(data, tmp_path / "ld.png")
    assert (tmp_path / "ld.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [r for r in caplog.records if "legend" in r.getMessage()]


def test_lp_of_a_three_voussoir_arch_is_a_four_hinge_mechanism():
    """Three voussoirs have four joints: without sliding (mu = 10) a collapse needs all four as hinges, alternating
    intrados/extrados."""
    lp = collapse_load(scene_from_dict(scene_dict(arch={"voussoirs": 3}, joints={"friction": 10.0})))
    assert lp.status == "limit load found" and sorted(lp.hinges) == [0, 1, 2, 3]
    sides = [lp.hinge_positions[j] for j in sorted(lp.hinges)]
    assert all(a != b for a, b in zip(sides, sides[1:]))
