"""The verdict rules on small made-up cases (milliseconds): the mechanism verdict on a diverging mode
(bridgefem.solver.mechanism), the evidence rule against the rigid-block LP (bridgefem.analysis.evidence) and the status vocabulary."""
import numpy as np
import pytest

from bridgefem.analysis.evidence import SlipCheck, confirm, coulomb_limited, needs_slip_check
from bridgefem.laws.coulomb import ContactState, CoulombJoints
from bridgefem.solver.mechanism import Mode, judge
from bridgefem.status import Status

OPEN, STICK, SLIP = CoulombJoints.OPEN, CoulombJoints.STICK, CoulombJoints.SLIP


def mode(d, state, sign=None, mu=0.6, works=(1.0, 1.0), scales=(1.0, 1.0)):
    d = np.asarray(d, dtype=float)
    n = len(d)
    active = ContactState(np.asarray(state, dtype=np.int8),
                          np.zeros(n, np.int8) if sign is None else np.asarray(sign, np.int8))
    rules = CoulombJoints.for_pairs(d, mu, np.ones(n), 0.0).mode_rules(active)
    return Mode(d, rules, np.arange(n), works, scales)


def test_a_hinge_that_opens_under_positive_work_proves_collapse():
    """Two pairs open, two closed (d_n = 0, d_t = 0): a rigid-block hinge mode; the load does positive work."""
    v = judge(mode([[1.0, 0.0], [0.5, 0.0], [0.0, 0.0], [0.0, 0.0]], [OPEN, OPEN, STICK, STICK]))
    assert v.flaw is None and v.proof


def test_the_sense_follows_the_load_work():
    """The same hinge with the load pushing the other way closes the open pairs into their partners."""
    v = judge(mode([[1.0, 0.0], [0.6, 0.0], [0.0, 0.0]], [OPEN, OPEN, STICK], works=(-1.0, -1.0)))
    assert v.flaw.startswith("interpenetration") and not v.proof
    assert v.repair.tolist() == [True, True, False]  # both beyond REPAIR of the worst (1.0 and 0.6)


def test_a_mode_without_load_work_is_no_mechanism():
    v = judge(mode([[1.0, 0.0], [0.0, 0.0]], [OPEN, STICK], works=(1e-9, 1e-9)))
    assert v.flaw.startswith("the live load does no work") and not v.proof


def test_a_slide_along_its_friction_law_is_a_mechanism_without_proof():
    """Both sliding pairs (sign s = +1: friction pushes +, slip d_t < 0) slide the way their law assumes in one sense:
    admissible, but a slip mode is never a proof (non-associative friction)."""
    v = judge(mode([[0.0, -1.0], [0.0, -1.0], [0.0, 0.0]], [SLIP, SLIP, STICK], sign=[1, 1, 0]))
    assert v.flaw is None and not v.proof


def test_pairs_sliding_against_each_others_law_are_a_wrong_active_set():
    """Two pairs assumed to slide the same way but moving in opposite senses: whichever sense the mode is taken
    in, one of them slips against its friction force; the repair sticks that one."""
    v = judge(mode([[0.0, -1.0], [0.0, 0.5]], [SLIP, SLIP], sign=[1, 1]))
    assert v.flaw.startswith("a slip against the friction force") and not v.proof
    assert v.repair.tolist() == [False, True]


def test_friction_free_pairs_may_slip_in_a_proof():
    v = judge(mode([[1.0, 0.3], [0.0, 0.3]], [OPEN, SLIP], sign=[0, -1], mu=0.0))
    assert v.flaw is None and v.proof


def test_no_proof_for_a_yielding_fill():
    v = judge(mode([[1.0, 0.0], [0.0, 0.0]], [OPEN, STICK]), provable=False)
    assert v.flaw is None and not v.proof


# ------------------------------------------------------------------------------------ evidence rule (LP: 100 N)
LP = (Status.LIMIT, 100.0)


def test_a_proved_limit_stands_and_one_far_above_the_lp_warns():
    assert confirm(Status.LIMIT, 99.9, 100.0, True, *LP).status == Status.LIMIT
    high = confirm(Status.LIMIT, 120.0, 120.1, True, *LP)
    assert high.status == Status.LIMIT and "above the rigid-block LP" in high.warnings[0]


@pytest.mark.parametrize("lower,upper,agrees", [(99.9, 100.0, True), (100.4, 100.45, True), (99.4, 99.6, True),
                                                (90.0, 90.1, False), (101.0, 101.1, False)])
def test_an_unproven_limit_needs_the_lp_within_half_a_percent(lower, upper, agrees):
    v = confirm(Status.LIMIT, lower, upper, False, *LP)
    if agrees:
        assert v.status == Status.LIMIT and v.evidence.startswith("agreement") and v.upper == upper
    else:
        assert Status.of(v.status) is Status.FAILURE and "unproven mechanism" in v.status and v.upper is None


def test_unstable_needs_the_lp_to_agree_even_with_a_proof():
    assert confirm(Status.UNSTABLE, 0.0, 0.0, False, Status.UNSTABLE, None).status == Status.UNSTABLE
    for proved in (True, False):
        v = confirm(Status.UNSTABLE, 0.0, 0.0, proved, *LP)
        assert Status.of(v.status) is Status.FAILURE and v.upper is None
        assert Status.of(v.status).exit_code == 1


def test_without_an_lp_answer_only_a_proof_counts():
    assert Status.of(confirm(Status.LIMIT, 99.0, 99.1, False, "LP failed: x", None).status) is Status.FAILURE
    assert confirm(Status.LIMIT, 99.0, 99.1, True, "LP failed: x", None).status == Status.LIMIT


def test_an_equilibrium_is_its_own_evidence_and_a_contradicting_lp_warns():
    v = confirm(Status.STABLE, 0.0, None, False, Status.UNSTABLE, None)
    assert v.status == Status.STABLE and v.warnings
    assert confirm(Status.LOCKED, 500.0, None, False, Status.UNBOUNDED, None).warnings == ()


def test_status_texts_read_back():
    assert Status.of("solver failure: anything") is Status.FAILURE
    assert Status.of(Status.failure("x")) is Status.FAILURE and Status.failure("x") == "solver failure: x"
    assert Status.of("limit load found") is Status.LIMIT and Status.LIMIT.exit_code == 0
    assert Status.of("no collapse (unbounded)").no_collapse and Status.LOCKED.no_collapse
    with pytest.raises(ValueError):
        Status.of("collapsed")


# ------------------------------------------------- evidence rule 3: a sliding limit below the associative LP
def slip(level=90.05, converged=True, sliding=(3,), fe_sliding=(3,), frozen=90.02, frozen_sliding=(3,),
         limited=(3,), exact=90.03):
    return SlipCheck(fe_sliding, frozen, frozen_sliding, (1, 5), limited, exact, converged, level, sliding, (1, 5),
                     12)


def test_a_sliding_limit_below_the_lp_needs_the_fe_state_to_be_a_collapse_state():
    """FE [90.0, 90.1] N, associative LP 100 N: agreement only when the rigid blocks with the FE's loads and frozen
    friction capacities collapse within 0.5 % of the bracket (the FE's forces are then an optimal state of that
    LP), with a mechanism that slides only at joints where the FE's forces are at their Coulomb limit, and the
    exact voussoirs' weights keep that LP within 0.5 %; the fixed point is not needed (the FE's state is one);
    otherwise a failure that names the check's answer."""
    for good in (slip(), slip(level=100.0), slip(converged=False), slip(level=None)):
        ok = confirm(Status.LIMIT, 90.0, 90.1, False, *LP, slip=good)
        assert ok.status == Status.LIMIT and ok.upper == 90.1
        assert ok.evidence.startswith("agreement: the non-associative rigid-block check")
        assert "with its friction capacities" in ok.evidence
    for bad in (slip(frozen=92.0), slip(frozen=None), slip(frozen_sliding=(3, 7)), slip(limited=()),
                slip(frozen_sliding=(), limited=()), slip(exact=88.0), slip(exact=None)):
        v = confirm(Status.LIMIT, 90.0, 90.1, False, *LP, slip=bad)
        assert Status.of(v.status) is Status.FAILURE and v.upper is None
        assert "unproven mechanism" in v.status and "non-associative" in v.status
        assert ("a reserve of 2.1% at its own friction capacities" in v.status) == (bad.frozen_level == 92.0)


def test_a_collapse_state_above_the_associative_lp_is_no_evidence():
    """The associative LP is an upper bound on any non-associative collapse (Radenkovic's first theorem): a
    collapse state more than 0.5 % above it confirms nothing."""
    assert slip(frozen=100.4, exact=100.4).agrees(100.4, 100.45, 100.0)
    assert not slip(frozen=101.0, exact=101.0).agrees(101.0, 101.05, 100.0)


def test_a_closing_failure_is_settled_only_by_a_collapse_state_within_the_width():
    """A closing trial at 90.009 N failed without proof from the FE's state at 90.0 N (tolerance 1e-4: width 0.009
    N): decisive only when that state is the collapse state that confirms [90.0, 90.009] (evidence 3) with its frozen
    LP at most one width above 90.0 N; a frozen level 0.5 % off still agrees with the bracket, but settles nothing."""
    assert slip(frozen=90.005).settles(90.0, 90.009, 100.0, 1e-4)
    assert slip(frozen=90.0).settles(90.0, 90.009, 100.0, 1e-4)
    assert slip(frozen=90.4).agrees(90.0, 90.009, 100.0)
    assert not slip(frozen=90.4).settles(90.0, 90.009, 100.0, 1e-4)  # a reserve beyond the width: retry
    assert not slip(frozen=90.005, limited=()).settles(90.0, 90.009, 100.0, 1e-4)  # no collapse state
    assert not slip(frozen=90.005, exact=95.0).settles(90.0, 90.009, 100.0, 1e-4)  # the mesh moves it
    assert not slip(frozen=None).settles(90.0, 90.009, 100.0, 1e-4)


def test_a_closing_failure_of_every_setting_ends_the_bracket_at_the_collapse_state_level():
    """Every solver setting failed the closing trial at 90.009 N from the FE's state at 90.0 N: a collapse state
    that confirms [90.0, 90.009] (evidence 3: its frozen LP within 0.5 %) ends the bracket at its frozen level, at
    least the trial; a state with a reserve beyond 0.5 %, or that is no collapse state, ends nothing, and the final
    verdict confirms the bracket it set by the same evidence."""
    assert slip(frozen=90.4).upper_end(90.0, 90.009, 100.0) == 90.4
    assert slip(frozen=90.005).upper_end(90.0, 90.009, 100.0) == 90.009
    v = confirm(Status.LIMIT, 90.0, 90.4, False, *LP, slip=slip(frozen=90.4))
    assert v.status == Status.LIMIT and v.upper == 90.4 and v.evidence.startswith("agreement: the non-associative")
    for bad in (slip(frozen=91.0), slip(frozen=90.4, limited=()), slip(frozen=90.4, exact=95.0), slip(frozen=None),
                slip(frozen=90.4, frozen_sliding=())):
        assert bad.upper_end(90.0, 90.009, 100.0) is None
    assert slip(frozen=101.0, exact=101.0).upper_end(101.0, 101.01, 100.0) is None  # above the associative LP


def test_coulomb_limited_joints_resist_the_slip_at_mu_n():
    """Joints whose shear is at mu n against the slip (shear on the right block, slip of the right block relative
    to the left one: opposite signs), within 0.5 %; not a joint below its limit, nor one sheared the other way."""
    normal = np.array([10.0, 10.0, 10.0, 10.0])
    shear = np.array([-5.0, 4.98, 4.0, 5.0])
    slip_ = np.array([1.0, -2.0, -1.0, 1.0])
    assert coulomb_limited(normal, shear, np.full(4, 0.5), slip_, [0, 1, 2, 3]) == (0, 1)
    assert coulomb_limited(normal, shear, np.full(4, 0.5), slip_, [1]) == (1,)


def test_the_slip_check_runs_only_where_nothing_else_confirms():
    """Only an unproven limit of a bare ring with FE sliding that the associative LP does not confirm."""
    assert needs_slip_check(Status.LIMIT, 90.0, 90.1, False, *LP, fill=False, sliding=True)
    assert not needs_slip_check(Status.LIMIT, 99.9, 100.0, False, *LP, fill=False, sliding=True)  # LP agrees
    assert not needs_slip_check(Status.LIMIT, 90.0, 90.1, True, *LP, fill=False, sliding=True)  # proved
    assert not needs_slip_check(Status.LIMIT, 90.0, 90.1, False, *LP, fill=True, sliding=True)
    assert not needs_slip_check(Status.LIMIT, 90.0, 90.1, False, *LP, fill=False, sliding=False)
    assert not needs_slip_check(Status.UNSTABLE, 0.0, 0.0, False, *LP, fill=False, sliding=True)


def test_a_limit_the_mesh_moves_suggests_a_finer_mesh():
    """The FE below the LP with the LP's own mechanism (the fixed point at the associative level with the FE's
    sliding joints, and the FE's state no collapse state), or a collapse state that the exact voussoirs' weights
    move by more than 0.5 %: a failure that says the load depends on the mesh; not for another mechanism."""
    for dependent in (slip(level=100.0, frozen=98.0, exact=98.0), slip(exact=95.0)):
        lower = 97.0 if dependent.level == 100.0 else 90.0
        back = confirm(Status.LIMIT, lower, lower + 0.01, False, *LP, slip=dependent)
        assert Status.of(back.status) is Status.FAILURE and "elements_through_thickness" in back.status
        assert back.mesh_dependent
    elsewhere = slip(level=100.0, frozen=98.0, exact=98.0, sliding=(0, 3))
    other = confirm(Status.LIMIT, 97.0, 97.01, False, *LP, slip=elsewhere)
    assert Status.of(other.status) is Status.FAILURE and "elements_through_thickness" not in other.status
    assert not other.mesh_dependent


def test_only_a_limit_back_at_the_associative_state_is_mesh_dependent():
    """Only the failures of the test above, and a confirmed collapse state more than 0.5 % below the associative LP
    (its level moves with the mesh's normal forces; the confirmed run stands if the finer one fails), ask for a
    re-run on a finer mesh (``Verdict.mesh_dependent``): not a limit that agrees with the LP, not another unproven
    mechanism (no slip check, a fixed point elsewhere or not reached, an LP that failed), not a refused
    instability."""
    back = slip(level=100.0, frozen=98.0, exact=98.0)
    assert confirm(Status.LIMIT, 97.0, 97.01, False, *LP, slip=back).mesh_dependent
    below = confirm(Status.LIMIT, 90.0, 90.1, False, *LP, slip=slip())  # the FE's state is a collapse state
    assert below.status == Status.LIMIT and below.mesh_dependent
    for v in (confirm(Status.LIMIT, 99.9, 100.0, False, *LP),  # agreement with the LP
              confirm(Status.LIMIT, 97.0, 97.01, False, *LP),  # no slip check
              confirm(Status.LIMIT, 97.0, 97.01, False, *LP, slip=slip(level=92.0, frozen=98.0, exact=98.0)),
              confirm(Status.LIMIT, 97.0, 97.01, False, *LP, slip=slip(level=100.0, frozen=98.0, exact=98.0,
                                                                        converged=False)),
              confirm(Status.LIMIT, 97.0, 97.01, False, "LP failed: x", None, slip=slip(level=100.0)),
              confirm(Status.UNSTABLE, 0.0, None, False, *LP)):
        assert not v.mesh_dependent, v.status
