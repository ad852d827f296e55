"""A cycle is condensed with the pairs that churned in the step (bridgefem/solver/newton.py, *Cycles*), and reversed slips
pass through stick (*Reversed slips*): campaign scenes whose live-load trials failed far below their limit."""
import pytest
from conftest import run_campaign_scene


@pytest.mark.slow
def test_a_springing_friction_cycle_is_solved_and_reaches_the_lp(tmp_path):
    """Campaign seed 1 #270 (parabolic, 18 voussoirs, t = 0.0908 m, mu = 0.349): three pairs of the loaded
    springing cycled between friction states, each return changing only one of them; frozen to stick, they violated
    the friction law by more the larger the load step, and trials failed from half the limit on (391 solves). It
    reaches the LP's limit (the 150 solves per limit that issue 12 allows: benchmarks/solve_budgets.py)."""
    run_campaign_scene(tmp_path, 270, 0.0908)


@pytest.mark.slow
def test_a_pointed_ring_whose_trials_reversed_slips_reaches_the_lp(tmp_path):
    """Campaign seed 1 #235 (pointed, 233 voussoirs, mu = 0.334, t = 5.4763 m): a thick ring of slices whose
    collapse slides at the crown, where proposals that reverse slips at once made trials diverge (a solver failure
    10 % below the LP). A limit within 0.5 % of the LP (the evidence rule's agreement)."""
    run_campaign_scene(tmp_path, 235, 5.4763)


@pytest.mark.slow
def test_a_condensed_cycle_that_leaps_is_followed_to_the_lp(tmp_path):
    """Campaign seed 2 #41 (elliptical, 76 voussoirs, mu = 8.248, t = 1.5501 m): a cycle of four crack-tip pairs at
    188 kN whose condensed state moved the ring far (a leap) was damped back into the cycle, bonded in tension and
    failed three times (170 solves). It reaches the LP's limit (the 150 solves per limit that issue 12 allows:
    benchmarks/solve_budgets.py)."""
    run_campaign_scene(tmp_path, 41, 1.5501, seed=2)
