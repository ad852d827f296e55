"""A load step solved again with other solver settings (bridgefem.solver.newton.retried, the module's *Retries*) on
the real contact solver of the elastic block of tests/test_block.py (mu = 0.6 pushed at h = 1 m: it tips at 0.5 W).
A retry changes the solver: ``Setting(scale=10)`` multiplies the law's Alart-Curnier constants by 10 and the system's
law rows with them. After ``retried``, whether the retry converged, every retry failed or one raised, the solver is
the one it was: its setting and its constants, checked directly (to rounding: they are scaled by ratios of settings,
so a round of retries may leave them an ulp away), and its next step is the step of a solver never retried. (The
constants only weigh forces against displacements in the classification and scale the law rows, which changes no
solution of a fixed active set: on this block the next step would be the same with them left at 10 x, hence the
direct check.) tests/test_campaign_cases.py checks the order in which the settings are tried, on a scripted
stand-in."""
import numpy as np
import pytest
from test_block import W, block_solver

from bridgefem.solver.newton import DEFAULT_SETTING, RETRIES, Setting, retried

LEVEL = 0.45 * W  # the base opens on the way: with one Newton iteration the step fails without proof
NEXT = 0.49 * W


def settled():
    """The block's solver at its self-weight state, and that state."""
    solver, _ = block_solver(0.6, 1.0, elements=4)
    out = solver.solve_step(0.0, solver.initial_iterate())
    assert out.converged, out.reason
    return solver, solver.converged_slip_reference(out.iterate)


def failed_step():
    """The block's solver at its self-weight state, that state, its law's constants, and its step to LEVEL ended
    after one Newton iteration: a failure without proof, as ``retried`` takes it."""
    solver, start = settled()
    failed = solver.solve_step(LEVEL, start, iterations=1)
    assert not failed.converged and not failed.proved, failed.reason
    return solver, start, solver.law.c.copy(), failed


def assert_as_never_retried(solver, start, constants):
    """``solver`` has the default setting and its ``constants`` (to rounding), and its next step from ``start``
    is the step of a solver that was never retried: the same Newton iterations, active set and state."""
    assert solver.setting == DEFAULT_SETTING
    np.testing.assert_allclose(solver.law.c, constants, rtol=4 * np.finfo(float).eps)
    reference, reference_start = settled()
    out, expected = solver.solve_step(NEXT, start), reference.solve_step(NEXT, reference_start)
    assert out.converged and expected.converged and out.iterations == expected.iterations
    assert np.array_equal(out.iterate.active.state, expected.iterate.active.state)
    x, x_ref = out.iterate.x.array, expected.iterate.x.array
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-9 * np.abs(x_ref).max())


def test_a_retry_that_converges_with_scaled_constants_leaves_the_solver_as_it_was():
    solver, start, constants, failed = failed_step()
    seen = []

    def solve():
        seen.append((solver.setting, solver.law.c.copy()))
        return solver.solve_step(LEVEL, start)

    out = retried(solver, solve, failed, (Setting(scale=10.0),))
    assert out.converged, out.reason
    (setting, during), = seen
    assert setting == Setting(scale=10.0)
    np.testing.assert_allclose(during, 10 * constants, rtol=1e-15)  # the retry really ran on changed constants
    assert_as_never_retried(solver, start, constants)


def test_every_retry_failing_leaves_the_solver_as_it_was():
    """Each of the settings is tried (one Newton iteration each: all fail) and the failure stays a failure."""
    solver, start, constants, failed = failed_step()
    seen = []

    def solve():
        seen.append(solver.setting)
        return solver.solve_step(LEVEL, start, iterations=1)

    out = retried(solver, solve, failed)
    assert not out.converged and seen == list(RETRIES)
    assert_as_never_retried(solver, start, constants)


def test_a_retry_that_raises_leaves_the_solver_as_it_was():
    """An error inside a retried solve (e.g. PETSc's) reaches the caller, and the solver is restored first."""
    solver, start, constants, failed = failed_step()
    seen = []

    def solve():
        seen.append(solver.law.c.copy())
        raise RuntimeError("injected failure inside the retried solve")

    with pytest.raises(RuntimeError, match="injected"):
        retried(solver, solve, failed, (Setting(scale=10.0),))
    np.testing.assert_allclose(seen[0], 10 * constants, rtol=1e-15)
    assert_as_never_retried(solver, start, constants)
