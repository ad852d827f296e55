"""The limit search's bracket logic (bridgefem.search.pathfollow) on a one-degree-of-freedom fake solver whose limit is
known exactly (milliseconds): equilibrium exists up to LIMIT and not above; the fake Newton method may also fail,
without proof, on steps longer than ``reach`` (as the active-set method does on large steps)."""
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.search.pathfollow import find_limit_load
from bridgefem.search.records import CollapseCheck, SearchGuides, SearchSettings, StaticCap
from bridgefem.solver.newton import DEFAULT_SETTING, RETRIES, Iterate, StepOutcome
from bridgefem.status import Status

LIMIT = 1234.5  # N per unit load factor
WEIGHT = 1000.0  # N: the initial step is a quarter of it, as in bridgefem.analysis.runner
SETTINGS = SearchSettings(tolerance=1e-4, initial_step=WEIGHT / 4, max_load=100 * WEIGHT, max_steps=200)


class OneDof:
    """A structure with one displacement equal to its load level; no equilibrium above ``limit``."""

    comm = MPI.COMM_SELF
    material = None
    movement = 0.0
    friction_factor = 1.0
    friction = np.zeros(0)  # no joints to raise the friction of, nor in tension: no continuation
    max_iterations = 60
    pairs = SimpleNamespace(joint=np.zeros(0, int))  # no joints: the self-weight's budget is max_iterations
    law = SimpleNamespace(crushes=False)

    def __init__(self, limit=LIMIT, reach=math.inf, proves=True, stalls_at=math.inf):
        self.limit, self.reach, self.proves, self.stalls_at = limit, reach, proves, stalls_at
        self.solves = 0

    def _iterate(self, level):
        x = PETSc.Vec().createSeq(1, comm=PETSc.COMM_SELF)
        x.array[0] = level
        return Iterate(x, CoulombJoints.bonded(0), np.zeros(0))

    def initial_iterate(self):
        return self._iterate(0.0)

    def converged_slip_reference(self, it):
        return it

    def use(self, setting):  # one algorithm here: a retry solves the same step alike
        pass

    def bonded_tensile_stress(self):  # no joints in tension: no tension continuation
        return np.zeros(0)

    def solve_step(self, level, start, predictor=None, give_up=False, iterations=None):
        self.solves += 1
        if level > self.limit:
            return StepOutcome(False, "no equilibrium", 3, 0.0, 1, mechanism=True, proved=self.proves)
        if level - start.x.array[0] > self.reach or level > self.stalls_at:
            return StepOutcome(False, "no convergence", 9, 0.0, 1)
        return StepOutcome(True, "", 2, 0.0, 1, self._iterate(level), {})


def search(solver, settings=SETTINGS, **guides):
    """The search on a one-degree-of-freedom ``solver`` (its deflection is its displacement), steered by the
    ``guides`` (the fields of SearchGuides)."""
    return find_limit_load(solver, lambda it: float(it.x.array[0]), settings, guides=SearchGuides(**guides))


class Predicted(OneDof):
    """The fake Newton method reaches any level below the limit from a predicted state when ``helps``."""

    def __init__(self, helps, **kw):
        super().__init__(**kw)
        self.helps = helps

    def solve_step(self, level, start, predictor=None, give_up=False, iterations=None):
        if self.helps and predictor is PREDICTED and level <= self.limit:
            self.solves += 1
            return StepOutcome(True, "", 2, 0.0, 1, self._iterate(level), {})
        return super().solve_step(level, start, predictor, give_up, iterations)


PREDICTED = PETSc.Vec().createSeq(1, comm=PETSc.COMM_SELF)  # the predicted state the fake recognises


def static_cap(level, admissible=True, falls=False):
    """A static bound at ``level`` whose admissibility check answers ``admissible``; records the levels checked."""
    checked = []

    def check(step, it):
        checked.append(step.level)
        return admissible, "made up"

    return StaticCap(level, falls, check), checked


def assert_bracket(s, tolerance=SETTINGS.tolerance):
    assert s.status == Status.LIMIT, s.status
    assert s.lower <= LIMIT < s.upper and s.upper - s.lower <= tolerance * s.lower * (1 + 1e-9)


@pytest.mark.parametrize("guess", [None, LIMIT, 0.7 * LIMIT, 1.4 * LIMIT, 10 * LIMIT])
def test_the_bracket_holds_the_limit_whatever_the_guess(guess):
    solver = OneDof()
    s = search(solver, guess=guess)
    assert_bracket(s)
    assert s.proved and len(s.steps) == solver.solves


@pytest.mark.parametrize("reach", [LIMIT / 3, LIMIT / 40])
def test_failures_without_proof_on_long_steps_never_close_the_bracket(reach):
    """The fake Newton method fails (no proof) on steps longer than ``reach``: the search shortens its steps and
    still brackets the true limit."""
    s = search(OneDof(reach=reach), guess=1.3 * LIMIT)
    assert_bracket(s)


def test_an_unproven_mechanism_is_reported_as_such():
    s = search(OneDof(proves=False))
    assert_bracket(s)
    assert not s.proved  # the verdict then needs the LP (bridgefem.analysis.evidence)


def test_a_newton_method_that_stalls_below_the_limit_is_a_solver_failure():
    s = search(OneDof(stalls_at=0.8 * LIMIT), guess=LIMIT)
    assert Status.of(s.status) is Status.FAILURE and s.upper is None
    assert s.lower <= 0.8 * LIMIT


def test_no_collapse_up_to_the_maximum_load_is_locked():
    s = search(OneDof(), replace(SETTINGS, max_load=0.5 * LIMIT))
    assert s.status == Status.LOCKED and s.lower == 0.5 * LIMIT and s.upper is None


def trials(s):
    return [st.level for st in s.steps]


@pytest.mark.parametrize("guess", [None, 0.7 * LIMIT, LIMIT])
@pytest.mark.parametrize("reach", [math.inf, LIMIT / 40])
def test_a_static_bound_at_the_limit_closes_the_bracket_on_it(guess, reach):
    """The static theorem's bound is the limit itself (a ring whose FE reaches the LP): no trial goes above it,
    and the search ends on the first converged step within the width of it, with the bracket [lower, bound]."""
    bound, checked = static_cap(LIMIT)
    solver = OneDof(reach=reach)
    s = search(solver, guess=guess, bound=bound)
    assert s.status == Status.LIMIT and s.static and not s.proved
    assert s.upper == LIMIT and LIMIT - s.lower <= 1e-4 * s.lower
    assert max(trials(s)) <= LIMIT and not any(st.mechanism for st in s.steps)  # no failure above it needed
    assert checked == [s.lower]


def test_a_limit_below_the_static_bound_still_needs_its_failing_step():
    """Elastic blocks that slide stop below the LP: the bound only removes trials above it, the bracket closes on a
    failure as without it."""
    s = search(OneDof(), bound=static_cap(1.01 * LIMIT)[0])
    assert_bracket(s)
    assert not s.static and s.proved and max(trials(s)) <= 1.01 * LIMIT


def test_a_state_that_fails_the_admissibility_check_voids_the_bound():
    """A converged state outside the theorem's premises cannot end the search: it goes on without the bound, and
    its bracket comes from a failed step (above the bound, since the bound was wrong)."""
    bound, checked = static_cap(0.999 * LIMIT, admissible=False)
    s = search(OneDof(), guess=LIMIT, bound=bound)
    assert_bracket(s)
    assert not s.static and len(checked) == 1 and max(trials(s)) > 0.999 * LIMIT


def test_a_self_weight_that_cannot_stand_is_unstable_only_with_the_static_proof():
    """With the static theorem showing that no equilibrium under self-weight exists, the failed self-weight step is
    the answer (a mechanism, "unstable"); without it, the failure stays a solver failure, whatever its retries (their
    solves: benchmarks/solve_budgets.py)."""
    s = search(OneDof(stalls_at=-1.0), bound=static_cap(None, falls=True)[0])
    assert s.status == Status.UNSTABLE and s.static
    s = search(OneDof(stalls_at=-1.0))
    assert Status.of(s.status) is Status.FAILURE and not s.static


class Unprovable(OneDof):
    """No equilibrium above ``limit``, where its Newton method fails without showing a mechanism; counts the steps
    it solves again with other settings (bridgefem.solver.newton.retried)."""

    def __init__(self, **kw):
        super().__init__(**kw)
        self.retries = 0

    def use(self, setting):
        self.retries += setting != DEFAULT_SETTING

    def solve_step(self, level, start, predictor=None, give_up=False, iterations=None):
        out = super().solve_step(level, start, predictor, give_up, iterations)
        return out if out.converged else StepOutcome(False, "no convergence", 9, 0.0, 1)


def collapse_state(settles):
    """A collapse check (bridgefem.analysis.checks.collapse_check) that answers ``settles``; records (lower, trial)."""
    asked = []

    def collapsed(lower, trial, state):
        asked.append((lower, trial))
        return settles, "made up"

    return collapsed, asked


def test_a_collapse_state_below_a_closing_failure_settles_it_without_retries():
    """A closing trial that fails without proof is solved again with every other setting, and still unproven it
    is a solver failure; when the converged state below it is a collapse state that settles the bracket, the
    failure is the mechanism at once: the bracket holds the exact limit, no retries."""
    for settles in (False, True):
        collapsed, asked = collapse_state(settles)
        solver = Unprovable()
        s = search(solver, guess=LIMIT, collapse=CollapseCheck(lambda it: None, collapsed))
        (lower, trial), = asked
        assert lower <= LIMIT < trial and trial - lower <= 1e-4 * lower
        if settles:
            assert_bracket(s)
            assert s.upper == trial and not s.proved and solver.retries == 0 and "collapse state" in s.failure
        else:
            assert Status.of(s.status) is Status.FAILURE and s.lower == lower
            assert solver.retries == len(RETRIES)


def test_a_collapse_state_below_a_closing_failure_of_every_setting_ends_the_bracket_at_its_level():
    """A closing trial that fails without proof and does not settle is solved again with every other setting; when
    all fail, a converged state below that is a collapse state ends the bracket at its collapse level (0.1 % above
    the state here, beyond the width), the search's failure saying so; without one the search is a solver
    failure."""
    for end in (None, 1.001):
        asked = []

        def upper_end(lower, trial, state):
            asked.append((lower, trial))
            return (end * lower if end else None), "made up"

        solver = Unprovable()
        s = search(solver, guess=LIMIT, collapse=CollapseCheck(lambda it: None, lambda lower, trial, it: (False, ""),
                                                               upper_end))
        (lower, trial), = asked
        assert lower <= LIMIT < trial and trial - lower <= 1e-4 * lower and solver.retries == len(RETRIES)
        if end:
            assert s.status == Status.LIMIT and s.lower == lower and s.upper == pytest.approx(1.001 * lower)
            assert not s.proved and "collapse state and the bracket's upper end is" in s.failure
        else:
            assert Status.of(s.status) is Status.FAILURE and s.upper is None


@pytest.mark.parametrize("reach", [math.inf, LIMIT / 40])
def test_a_state_at_collapse_by_itself_counts_as_failed_and_the_bracket_closes_on_the_first_one(reach):
    """Evidence 5 (bridgefem.analysis.evidence; bridgefem.search.step, *Collapse state*): a converged state that is
    a collapse state by itself (the rings at collapse under an elastic fill's loads; here every state from 0.9 LIMIT
    on, though equilibrium exists up to LIMIT) counts as failed with a mechanism, so the bracket closes on 0.9
    LIMIT within the tolerance, also where the fake fails every step longer than LIMIT / 40 without proof; each
    reading gets the settled state (live load 0). A reading that never finds one leaves the search as it is: the
    same trials."""
    first = 0.9 * LIMIT

    def at_collapse(level, state, settled):
        assert settled.x.array[0] == 0.0 and state.x.array[0] == level
        return level >= first, "made up"

    s = search(OneDof(reach=reach), guess=1.3 * LIMIT, collapse=CollapseCheck(at_collapse=at_collapse))
    assert s.status == Status.LIMIT and s.lower < first <= s.upper and s.upper - s.lower <= 1e-4 * s.lower
    assert s.failure.startswith("the converged state is a collapse state: made up") and not s.proved
    plain = search(OneDof(reach=reach), guess=1.3 * LIMIT)
    never = search(OneDof(reach=reach), guess=1.3 * LIMIT,
                   collapse=CollapseCheck(at_collapse=lambda level, state, settled: (False, "none")))
    assert trials(never) == trials(plain) and never.upper == plain.upper


@pytest.mark.parametrize("estimate", [LIMIT, 0.9 * LIMIT, 0.999 * LIMIT, "rising", "falling"])
def test_a_collapse_states_estimate_sets_the_path_never_the_bracket(estimate):
    """Unproven failures 30 % below the static bound (suspect): with the exact limit as every converged state's
    estimate the search lands half a width below it and closes on the next trial; a wrong estimate (10 % or 0.1 %
    low) still leaves the bracket on the exact limit, and one that keeps rising with the load (0.2 % above every
    state, never settled) leaves the search as it is without an estimate: the same trials. One that falls towards
    the limit as the load rises (LIMIT + (LIMIT - level) / 2) is extrapolated to where it meets the load: the limit,
    as the exact one. (How many solves each saves: benchmarks/solve_budgets.py.)"""
    plain, estimated = OneDof(proves=False), OneDof(proves=False)
    bound = static_cap(1.3 * LIMIT)[0]
    without = search(plain, guess=1.3 * LIMIT, bound=bound)
    assert_bracket(without)
    level = {"rising": lambda it: 1.002 * it.x.array[0],
             "falling": lambda it: LIMIT + 0.5 * (LIMIT - it.x.array[0])}.get(estimate, lambda it: estimate)
    s = search(estimated, guess=1.3 * LIMIT, bound=bound,
               collapse=CollapseCheck(level, lambda lower, trial, it: (False, "no collapse state")))
    assert_bracket(s)
    if estimate in (LIMIT, "falling"):
        assert s.lower == pytest.approx(LIMIT / (1 + 0.5e-4), rel=1e-12)
    if estimate == "rising":
        assert trials(s) == trials(without)


@pytest.mark.parametrize("helps", [True, False])
def test_a_predicted_state_retries_a_failed_long_step_and_the_bracket_holds_either_way(helps):
    """A trial that failed without proof on a long step is solved once more from the predicted state: whether that
    reaches it or never helps, the bracket holds the limit. (The steps it saves, and the FUTILE_PREDICTIONS predicted
    trials in a row after which the search stops asking: benchmarks/solve_budgets.py.)"""
    calls = []

    def predicted(level, start):
        calls.append(level)
        return PREDICTED

    plain = search(OneDof(reach=0.05 * LIMIT), guess=1.3 * LIMIT)
    solver = Predicted(helps, reach=0.05 * LIMIT)
    s = search(solver, guess=1.3 * LIMIT, predicted=predicted)
    assert_bracket(s)
    assert_bracket(plain)
    assert calls, "no predicted state was asked for: the test proves nothing"
