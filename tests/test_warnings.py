"""The warnings of an analysis (bridgefem.analysis.result, *Warnings*), each on made-up results: a warning is a plain
function of what the run stored, one per class of doubtful bracket that the verdict's evidence does not catch."""
from types import SimpleNamespace

import pytest

from bridgefem.analysis.result import FILL_BOUND_TOL, LP_RATIO_RANGE, SMALL_DISPLACEMENT, user_warnings
from bridgefem.status import COLLAPSE_END

SPAN = 10.0  # m


def run(ratio=1.0, sliding=0, fill=None, bounds=None, lower=100e3, deflection=0.001, shortest=1.0, size=0.25,
        verdict=(), upper=None, slides=False, failure="", status="limit load found", settled=True):
    """The parts of an Analysis that the warnings read: one converged step with its ``deflection`` (m), the last
    converged live load ``lower`` and the bracket's ``upper`` end (N, one unit of load), the FE/LP ``ratio``, one joint ``sliding`` or not, the fill's
    conic ``bounds`` (N), the shortest voussoir and the element size (m), the verdict's own warnings and whether it
    confirmed a collapse state that ``slides``; the bracket's tolerance 1e-4, the search's ``failure`` reason, its
    ``status`` and whether it ``settled`` under self-weight."""
    return SimpleNamespace(search=SimpleNamespace(steps=[SimpleNamespace(converged=True, deflection=deflection)],
                                                  lower=lower, upper=upper, tolerance=1e-4, failure=failure,
                                                  status=status, settled=object() if settled else None),
                           scene=SimpleNamespace(arch=SimpleNamespace(span=SPAN), fill=fill), load_total=1.0,
                           shortest_voussoir=shortest, block_mesh=SimpleNamespace(element_size=size),
                           fe_lp_ratio=ratio, joints=[SimpleNamespace(sliding=sliding)], fill_bounds=bounds,
                           verdict=SimpleNamespace(warnings=verdict, slides=slides))


def test_a_sound_run_has_no_warning():
    assert user_warnings(run()) == []


def test_a_deflection_beyond_the_small_displacement_range_warns():
    assert user_warnings(run(deflection=0.99 * SMALL_DISPLACEMENT * SPAN)) == []
    (warning,) = user_warnings(run(deflection=-1.01 * SMALL_DISPLACEMENT * SPAN))
    assert "small-displacement model is outside its validity" in warning


def test_voussoirs_shorter_than_an_element_warn():
    (warning,) = user_warnings(run(shortest=0.2, size=0.25))
    assert "shorter than one element" in warning


@pytest.mark.parametrize("ratio, sliding, fill, warns", [
    (LP_RATIO_RANGE[0] * 0.999, 0, None, True), (LP_RATIO_RANGE[1] * 1.001, 0, None, True),
    (LP_RATIO_RANGE[0], 0, None, False), (LP_RATIO_RANGE[1], 0, None, False),
    (0.9, 1, None, False), (0.9, 0, "a fill", False), (None, 0, None, False)])
def test_an_fe_lp_ratio_outside_its_range_warns_only_on_a_bare_ring_without_sliding(ratio, sliding, fill, warns):
    """Elastic blocks stop a little below the rigid-block LP and never above it; sliding joints (non-associative
    friction) and a fill (the LP carries it as dead load only) may stop anywhere below."""
    warnings = user_warnings(run(ratio=ratio, sliding=sliding, fill=fill))
    assert any("FE/LP limit-load ratio" in w for w in warnings) == warns


def test_a_confirmed_collapse_state_that_slides_is_sliding_for_the_fe_lp_ratio():
    """A joint held at its Coulomb limit while a pair of it sticks does not count as sliding, but a verdict that
    confirmed a collapse state sliding there (evidence 3) is a sliding collapse: no ratio warning."""
    assert any("FE/LP limit-load ratio" in w for w in user_warnings(run(ratio=0.81)))
    assert not any("FE/LP limit-load ratio" in w for w in user_warnings(run(ratio=0.81, slides=True)))


@pytest.mark.parametrize("upper, warns", [(100e3 * (1 + 1e-4), False), (100e3 * 1.0015, True), (None, False)])
def test_a_bracket_wider_than_its_tolerance_warns(upper, warns):
    """A bracket that a collapse state ends at its rigid blocks' collapse level can be wider than the tolerance: the
    run says how wide (bridgefem.search.target, *Collapse state*, step 5)."""
    reason = f"active set cycling; the converged state below is a collapse state and {COLLAPSE_END}: ..."
    warnings = [w for w in user_warnings(run(upper=upper, failure=reason)) if "wider than the tolerance" in w]
    assert bool(warnings) == warns
    assert not warns or warnings[0].startswith("the bracket is 0.150% wide") and "no solver setting" in warnings[0]
    other = [w for w in user_warnings(run(upper=upper)) if "wider than the tolerance" in w]
    assert bool(other) == warns and not any("no solver setting" in w for w in other)


@pytest.mark.parametrize("upper, warns", [(100e3 / (1 + 1.01 * FILL_BOUND_TOL), True),
                                          (100e3 / (1 + 0.99 * FILL_BOUND_TOL), False), (None, False)])
def test_an_fe_limit_above_the_conic_upper_bound_of_its_fill_warns(upper, warns):
    """No equilibrium exists above the rigid-plastic upper bound of the bridge with its fill: an FE that carries more
    has a fill mesh that has not converged."""
    bounds = {"lower": None, "upper": upper, "unit": "N"}
    warnings = user_warnings(run(ratio=0.5, fill="a fill", bounds=bounds))
    assert any("above the conic upper bound" in w for w in warnings) == warns


@pytest.mark.parametrize("lower_bound, warns", [(100e3 / (1 - 1.01 * FILL_BOUND_TOL), True),
                                                (100e3 / (1 - 0.99 * FILL_BOUND_TOL), False), (None, False)])
def test_an_fe_limit_below_the_conic_lower_bound_of_its_fill_warns(lower_bound, warns):
    """The bridge with its fill carries at least its rigid-plastic lower bound: an FE bracket whose upper end lies
    below it stopped before the collapse, and the user reads the bracket with the bounds."""
    bounds = {"lower": lower_bound, "upper": None, "unit": "N"}
    warnings = user_warnings(run(ratio=0.5, fill="a fill", bounds=bounds, lower=99.9e3, upper=100e3))
    assert any("below the conic lower bound" in w for w in warnings) == warns


@pytest.mark.parametrize("value, decided, warns", [
    (100e3 / (1 - 1.01 * FILL_BOUND_TOL), False, True), (100e3 / (1 - 0.99 * FILL_BOUND_TOL), False, False),
    (None, False, False), (100e3 / (1 - 1.01 * FILL_BOUND_TOL), True, False)])
def test_an_fe_limit_below_an_undecided_lower_bound_warns_with_its_programmes_value(value, decided, warns):
    """A static programme that stopped short of full accuracy above the FE leaves the lower bound undecided (its
    value falls as the iterations go on): where that value lies more than the tolerance above the bracket, the run
    says so with the value and its status, as a value to read, not a bound; a decided bound warns as a bound."""
    static = {"status": "optimal (reduced accuracy)", "iterations": 260, "load": value, "level": value}
    bounds = {"lower": value if decided else None, "upper": None, "unit": "N", "programmes": {"lower": static}}
    warnings = user_warnings(run(ratio=0.5, fill="a fill", bounds=bounds, lower=99.9e3, upper=100e3))
    undecided = [w for w in warnings if "lower bound of the bridge with its fill is undecided" in w]
    assert bool(undecided) == warns
    assert not warns or "(optimal (reduced accuracy), 260 iterations)" in undecided[0] and "1.0% above" in undecided[0]
    assert any("below the conic lower bound" in w for w in warnings) == decided


@pytest.mark.parametrize("lower_bound, settled, warns", [(50e3, False, True), (None, False, False),
                                                        (50e3, True, False)])
def test_a_failed_self_weight_that_the_conic_lower_bound_shows_standing_warns(lower_bound, settled, warns):
    """A self-weight without an FE equilibrium under a fill whose static programme carries the dead load (and some
    live load): the bridge stands, so the failure is the solver's; the warning names the bound."""
    bounds = {"lower": lower_bound, "upper": None, "unit": "N"}
    warnings = user_warnings(run(fill="a fill", bounds=bounds, lower=0.0, settled=settled,
                                 status="solver failure: self-weight ... diverged"))
    standing = [w for w in warnings if "the bridge with its fill stands" in w]
    assert bool(standing) == warns
    assert not warns or "50 kN of live load" in standing[0]


def test_the_verdicts_warnings_come_last():
    assert user_warnings(run(shortest=0.2, verdict=("the LP says otherwise",)))[-1] == "the LP says otherwise"
