"""Step control of the limit search with a plastic fill (bridgefem.search.pathfollow, *Steps* and *Predictor*) on the
one-degree-of-freedom fake solver of test_bracket (displacement = load level, no equilibrium above LIMIT), made to
behave like a Mohr-Coulomb fill: every converged live-load step takes more Newton iterations than the self-weight
step did."""
import math
from dataclasses import replace
from types import SimpleNamespace

import pytest
from test_bracket import LIMIT, SETTINGS, WEIGHT, OneDof, assert_bracket, search

from bridgefem.search.step import plateau_reserve, plateau_through
from bridgefem.solver.newton import DEFAULT_SETTING, StepOutcome
from bridgefem.status import Status

FILL_ITERATIONS = 12  # Newton iterations of every converged live-load step (the self-weight takes 2)
STIFFNESS = 1e6  # N/m: the softening structure's initial stiffness
DROP = 0.02  # the default stiffness_drop
FLAT = (1.0 - DROP) * LIMIT  # N: where the softening structure's tangent stiffness falls to DROP x STIFFNESS
PLATEAU = LIMIT / (1.0 + SETTINGS.tolerance)  # N: from here on the plateau LIMIT lies within the tolerance above


class PlasticFillOneDof(OneDof):
    """``OneDof`` with a plastic fill: each converged live-load step takes ``FILL_ITERATIONS`` Newton iterations;
    records the displacement each trial starts from."""

    material = SimpleNamespace(cohesion=0.0, material=SimpleNamespace(cohesion=0.0))

    def __init__(self):
        super().__init__()
        self.starts = []  # (displacement the solver is given to start from, trial level, active set predicted)

    def solve_step(self, level, start, predictor=None, give_up=False, iterations=None):
        out = super().solve_step(level, start, predictor, give_up, iterations)
        self.starts.append((float(start.x.array[0]), level, predictor is not None))
        if out.converged and level > 0:
            return StepOutcome(True, "", FILL_ITERATIONS, 0.0, FILL_ITERATIONS, out.iterate, {})
        return out


def test_a_plastic_fill_whose_steps_all_need_many_iterations_still_doubles_its_steps():
    """A guess at 0.3 of the limit: after landing on it the step is the width (1e-4 of the load, 0.04 N), and the
    limit is 860 N further. Steps that never grow would need about 23 000 of them (the search stops at 200, a solver
    failure); doubled while no step takes more Newton iterations than the one before, the search brackets the limit
    (in about 15: benchmarks/solve_budgets.py)."""
    solver = PlasticFillOneDof()
    s = search(solver, guess=0.3 * LIMIT)
    assert_bracket(s)


def test_a_plastic_fill_trial_starts_from_the_secant_through_the_last_two_states():
    """On this path the displacement is the load level: the secant through the last two converged live-load states is
    exact, so every trial after the first two live-load steps begins at the trial's own solution, the trials that can
    close the bracket too; only the trials more than the width above their start are given a predicted active set."""
    solver = PlasticFillOneDof()
    s = search(solver)
    assert_bracket(s)
    later = solver.starts[3:]  # after the self-weight and the first two live-load steps
    assert all(abs(given - level) <= 1e-9 * level for given, level, _ in later)
    closing = [(given, level) for given, level, predicted in later if not predicted]
    assert closing, "no trial could close the bracket: the test proves nothing"
    assert s.steps[-1].level == closing[-1][1] and not solver.starts[-1][2]


class Softening(OneDof):
    """A structure whose load-deflection curve flattens towards LIMIT: P = LIMIT (1 - exp(-STIFFNESS delta /
    LIMIT)), its tangent stiffness STIFFNESS (1 - P / LIMIT) (N/m) at load level P (N); no equilibrium above LIMIT."""

    def _iterate(self, level):
        return super()._iterate(-LIMIT / STIFFNESS * math.log1p(-min(level, LIMIT) / LIMIT))

    def live_load_tangent(self, it):
        level = -LIMIT * math.expm1(-STIFFNESS * it.x.array[0] / LIMIT)
        return OneDof._iterate(self, 1.0 / (STIFFNESS * (1.0 - level / LIMIT)))


@pytest.mark.parametrize("guess", [None, 0.8 * LIMIT, LIMIT, 1.5 * LIMIT])
@pytest.mark.parametrize("initial_step", [0.5 * WEIGHT / 4, WEIGHT / 4, 2 * WEIGHT / 4])
def test_a_flattening_curve_is_bracketed_at_its_plateau_whatever_the_steps(guess, initial_step):
    """The curve's plateau is LIMIT; its tangent stiffness falls to DROP x the initial one already at FLAT = 0.98
    LIMIT, 2 % below it. The bracket holds the level PLATEAU from which LIMIT lies within the tolerance above, for
    every step schedule (the guess sets the approach, the initial step the first steps): the exponential through the
    path's last three converged states (or fitted to the first step's secant and end tangent) is this curve's own,
    so each flat step's reserve is exact. A secant over a
    converged step is above the tangent at its end on this concave curve: alone, a long step from below FLAT to above
    it converges and counts as steep."""
    s = search(Softening(), replace(SETTINGS, initial_step=initial_step, stiffness_drop=DROP), guess=guess)
    assert s.status == Status.LIMIT and s.failure.startswith("load-deflection curve flat"), s.failure
    assert FLAT < s.lower <= PLATEAU < s.upper <= LIMIT, (s.lower, s.upper)
    assert s.upper - s.lower <= SETTINGS.tolerance * s.lower * (1 + 1e-9)


class CountedSoftening(Softening):
    """``Softening`` that counts the steps it solves again with other settings (bridgefem.solver.newton.retried)."""

    def __init__(self):
        super().__init__()
        self.retries = 0

    def use(self, setting):
        self.retries += setting != DEFAULT_SETTING


def test_a_flat_curve_below_a_guess_far_above_it_is_not_solved_again():
    """A guess 1.5 x the plateau makes the flat steps near LIMIT suspect (far below the guess): a failure without a
    mechanism there would be solved again with the solver's other settings. A flat curve is read off a converged
    equilibrium, which those settings reach alike: it is bracketed without a retry."""
    solver = CountedSoftening()
    s = search(solver, replace(SETTINGS, stiffness_drop=DROP), guess=1.5 * LIMIT)
    assert s.status == Status.LIMIT and s.failure.startswith("load-deflection curve flat"), s.failure
    assert FLAT < s.lower <= PLATEAU < s.upper <= LIMIT
    assert solver.retries == 0


class Hardening(Softening):
    """``Softening`` with a residual stiffness of DROP / 2 x STIFFNESS in parallel (an elastic restraint that never
    yields): the tangent falls below DROP x STIFFNESS but the curve rises without a plateau; no equilibrium above
    its ``limit`` (N)."""

    def _iterate(self, level):
        # invert P = LIMIT (1 - exp(-K d / LIMIT)) + (DROP / 2) K d for the deflection d by Newton's method
        d = level / STIFFNESS
        for _ in range(100):
            e = math.exp(-STIFFNESS * d / LIMIT)
            d -= (LIMIT * (1 - e) + DROP / 2 * STIFFNESS * d - level) / (STIFFNESS * (e + DROP / 2))
        return OneDof._iterate(self, d)

    def live_load_tangent(self, it):
        e = math.exp(-STIFFNESS * it.x.array[0] / LIMIT)
        return OneDof._iterate(self, 1.0 / (STIFFNESS * (e + DROP / 2)))


def test_a_curve_that_keeps_rising_is_never_flat():
    """Below the threshold but without a plateau (the tangent not below the step's secant once the residual stiffness
    dominates, or a plateau far above): no step counts as flat; the search goes on to the structure's real end."""
    end = 3 * LIMIT
    s = search(Hardening(limit=end), replace(SETTINGS, stiffness_drop=DROP))
    assert s.status == Status.LIMIT and not s.failure.startswith("load-deflection curve flat"), s.failure
    assert s.lower <= end < s.upper


@pytest.mark.parametrize("start, end", [(0.0, 0.5), (0.5, 0.9), (0.9, 0.999), (0.99, 0.9901)])
def test_the_plateau_fitted_to_a_step_of_an_exponential_curve_is_its_own(start, end):
    """On P = P_inf (1 - exp(-delta)) the reserve fitted to a step's secant and end tangent is P_inf - P_end, for long
    and short steps, far from the plateau and close to it."""
    deflection = lambda p: -math.log1p(-p)  # noqa: E731  (P_inf = 1, c = 1)
    secant = (end - start) / (deflection(end) - deflection(start))
    assert plateau_reserve(end - start, secant, 1.0 - end) == pytest.approx(1.0 - end, rel=1e-6)


@pytest.mark.parametrize("levels", [(0.1, 0.5, 0.9), (0.5, 0.9, 0.91), (0.9, 0.95, 0.999), (0.99, 0.995, 0.9951)])
def test_the_plateau_through_three_points_of_an_exponential_curve_is_its_own(levels):
    """On P = P_inf - A exp(-delta / c) (P_inf = 2, A = 3, c = 0.5, deflections shifted) the plateau through three of
    its points lies P_inf - P above the third, for unequal steps, far from the plateau and close to it; a straight
    line has none."""
    points = [(2.0 - 3.0 * (1.0 - p), 0.7 - 0.5 * math.log1p(-p)) for p in levels]
    assert plateau_through(*points) == pytest.approx(2.0 - points[2][0], rel=1e-6)
    assert plateau_through((0.0, 0.0), (1.0, 1.0), (3.0, 3.0)) == math.inf


def test_a_step_that_does_not_soften_has_no_plateau_and_a_peak_has_no_reserve():
    assert plateau_reserve(10.0, 2e6, 2e6) == math.inf and plateau_reserve(10.0, 2e6, 3e6) == math.inf
    assert plateau_reserve(10.0, 2e6, 0.0) == 0.0


class Knee(OneDof):
    """A curve with a knee at KNEE: stiffness STIFFNESS below it, DROP / 4 x STIFFNESS above it up to LIMIT (no
    equilibrium above): the exponential through states on both sides of the knee puts a plateau just above every step
    that crosses it, where the curve goes on rising."""

    KNEE = 0.5 * LIMIT

    def _iterate(self, level):
        below, above = min(level, self.KNEE), max(level - self.KNEE, 0.0)
        return super()._iterate(below / STIFFNESS + above / (DROP / 4 * STIFFNESS))

    def live_load_tangent(self, it):
        soft = it.x.array[0] > self.KNEE / STIFFNESS
        return OneDof._iterate(self, 1.0 / (STIFFNESS * (DROP / 4 if soft else 1.0)))


def test_a_plateau_below_a_converged_state_is_no_plateau():
    """A step that crosses the knee converges with its stiffness below the threshold, and its fit across the knee
    puts the plateau just above it: it counts as flat. The shorter trials below it cross the knee too, and their fits
    put the plateau lower still; but an equilibrium exists at the flat step's level, so the plateau lies no lower:
    the search goes past the knee, where the curve keeps rising, to the structure's real end."""
    s = search(Knee(), replace(SETTINGS, stiffness_drop=DROP), guess=0.45 * LIMIT)
    assert s.status == Status.LIMIT and not s.failure.startswith("load-deflection curve flat"), s.failure
    assert_bracket(s)



COARSE = replace(SETTINGS, stiffness_drop=DROP, tolerance=5e-3)  # a crushing ring's default tolerance


class Creeping(OneDof):
    """A curve that approaches its plateau LIMIT algebraically, P = LIMIT (1 - (1 + STIFFNESS delta / (2 LIMIT))^-2),
    as an elastic-plastic section does its plastic moment: its tangent stiffness falls as (1 - P / LIMIT)^(3/2), more
    slowly towards the plateau than an exponential's, which the three-point fit assumes. No equilibrium above
    LIMIT."""

    def _iterate(self, level):
        return super()._iterate(2 * LIMIT / STIFFNESS * ((1.0 - min(level, LIMIT) / LIMIT) ** -0.5 - 1.0))

    def live_load_tangent(self, it):
        remaining = (1.0 + STIFFNESS * it.x.array[0] / (2 * LIMIT)) ** -3
        return OneDof._iterate(self, 1.0 / (STIFFNESS * remaining))


def test_a_creeping_curve_read_by_the_exponential_alone_stops_short_of_its_plateau():
    """What the floor guards against: without a proved level, the fitted plateau closes the bracket below 0.998 x
    the curve's own, under a level a lower bound could prove carried (0.999 x)."""
    s = search(Creeping(), COARSE)
    assert s.status == Status.LIMIT and s.failure.startswith("load-deflection curve flat"), s.failure
    assert s.upper < 0.998 * LIMIT


@pytest.mark.parametrize("proved", [0.999, 0.9999])
def test_a_flat_curve_below_a_proved_level_is_not_its_plateau(proved):
    """A level a lower bound proves carried (``floor``: a fill's conic lower bound) keeps the bracket from closing
    below it: the creeping curve is bracketed between that level and its plateau (by a flat step above that level,
    or by the lost equilibrium where the level is within the tolerance of the plateau); the floor is asked only
    where a step would otherwise read flat, with that step's level."""
    asked = []

    def floor(level):
        asked.append(level)
        return proved * LIMIT

    s = search(Creeping(), COARSE, floor=floor)
    assert s.status == Status.LIMIT, s.failure
    assert (1 - COARSE.tolerance) * proved * LIMIT <= s.lower <= LIMIT <= s.upper / (1 - COARSE.tolerance), s
    assert s.upper >= proved * LIMIT
    assert asked and all(level <= s.upper for level in asked)


def test_the_plateau_of_three_points_on_a_nearly_flat_curve_is_finite():
    """Three points whose exponential decays over far less than the last increment (the rate times that increment
    beyond a float's exponent) leave no reserve, without overflowing."""
    assert plateau_through((0.0, 0.0), (1.0, 1e-3), (1.0 + 1e-12, 1.0)) == 0.0
