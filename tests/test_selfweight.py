"""The self-weight state (bridgefem.search.selfweight) and the re-run of a failure without proof on a finer mesh
(bridgefem.analysis.refinement.refinement_reason), issue 12."""
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import campaign_scene
from mpi4py import MPI

from bridgefem.analysis.build import Clock, build_model
from bridgefem.analysis.evidence import AGREEMENT
from bridgefem.analysis.refinement import refinement_reason
from bridgefem.analysis.runner import run_analysis
from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.laws.crushing import CrushingJoints
from bridgefem.scene.reader import scene_from_dict
from bridgefem.search.selfweight import (
    FRICTION_RAISE,
    RAMP_RATIO,
    SELF_WEIGHT_RETRIES,
    carry_self_weight,
    self_weight_budget,
    tension_continuation,
)
from bridgefem.solver.newton import DEFAULT_SETTING, StepOutcome
from bridgefem.solver.settings import Setting
from bridgefem.status import Status

UNLOADED = "unloaded"

# campaign seed 1, scene 251 (benchmarks/campaign.py): 165 voussoirs of about 0.08 m, shorter than the 0.134 m
# element of 4 elements through the thickness; the LP's least thickness 0.5329 m, the ring 0.5347 m thick
SCENE_251 = campaign_scene(251, 0.5347)


class RingSolver:
    """A bare ring's solver as the self-weight sees it: one joint friction, its factor, the setting in use and the
    pair's clamp (its tension, N); its bonded state's tensile stress ``stress`` (N per m; 0: none in tension)."""

    material = None
    comm = MPI.COMM_SELF
    max_iterations = 60
    pairs = SimpleNamespace(joint=np.zeros(1, int), length=np.array([0.5]))  # one joint: the budget is max_iterations
    law = SimpleNamespace(crushes=False)

    def __init__(self, stress=0.0):
        self.friction, self.friction_factor, self.setting = np.array([0.5]), 1.0, DEFAULT_SETTING
        self.stress, self.tension = stress, None

    def set_friction_factor(self, factor):
        self.friction_factor = factor

    def set_tension(self, tension):
        self.tension = tension

    def bonded_tensile_stress(self):
        return np.array([self.stress])

    def use(self, setting):
        self.setting = setting

    def initial_iterate(self):
        return UNLOADED

    def converged_slip_reference(self, it):
        return it


def attempts(solver, converges):
    """An ``attempt`` that converges when ``converges(friction factor, setting)``, its state named by the factor, and
    the record of every attempt: (factor, setting, start)."""
    record = []

    def attempt(level, start):
        factor = solver.friction_factor
        record.append((factor, solver.setting, start))
        if converges(factor, solver.setting):
            return StepOutcome(True, "", 1, 0.0, 1, iterate=f"state at {factor:.6g}")
        return StepOutcome(False, "max iterations", 60, 1e-3, 60)

    return attempt, record


def test_a_retry_resumes_the_friction_continuation_from_its_last_converged_state():
    """The continuation converges down to a friction factor of 2 with the default setting, and everywhere with the
    first retry: the retry starts from the last converged state at the factor that failed (no new one step from the
    unloaded state), and ends converged at the scene's friction."""
    solver = RingSolver()
    retry = SELF_WEIGHT_RETRIES[0]
    attempt, record = attempts(solver, lambda factor, setting: setting == retry or factor >= 2.0)
    out = carry_self_weight(solver, attempt)
    assert out.converged and solver.friction_factor == 1.0 and record[-1][0] == 1.0
    default = [r for r in record if r[1] == DEFAULT_SETTING]
    assert default[0] == (1.0, DEFAULT_SETTING, UNLOADED) and default[1][0] == FRICTION_RAISE
    last_converged = [f for f, _, _ in default if f >= 2.0][-1]
    resumed = [r for r in record if r[1] == retry]
    assert resumed[0] == (default[-1][0], retry, f"state at {last_converged:.6g}") and default[-1][0] < 2.0


def test_a_retry_starts_again_when_no_continuation_step_converged():
    """Nothing converges with the default setting: the first retry solves the one step from the unloaded state."""
    solver = RingSolver()
    retry = SELF_WEIGHT_RETRIES[0]
    attempt, record = attempts(solver, lambda factor, setting: setting == retry)
    assert carry_self_weight(solver, attempt).converged
    resumed = [r for r in record if r[1] == retry]
    assert resumed == [(1.0, retry, UNLOADED)]


def test_a_friction_continuation_that_fails_gives_way_to_the_tension_continuation():
    """Nothing converges at the scene's tensile strength (none) unless reached through raised ones: the one step and
    the friction continuation fail; the tension continuation starts from the unloaded state at the bonded state's
    tensile stress (400 N per m over the pair's 0.5 m: a clamp of 200 N), lowers it by RAMP_RATIO at each step and
    ends converged with no clamp left."""
    solver = RingSolver(stress=400.0)
    clamps = []

    def attempt(level, start):
        clamps.append(None if solver.tension is None else float(solver.tension[0]))
        if solver.tension is not None:
            return StepOutcome(True, "", 1, 0.0, 1, iterate=f"state at {clamps[-1]:.6g}")
        if len(clamps) > 1 and clamps[-2] is not None:  # reached from a clamped state: the scene's
            return StepOutcome(True, "", 1, 0.0, 1, iterate="state unclamped")
        return StepOutcome(False, "max iterations", 60, 1e-3, 60)

    out = carry_self_weight(solver, attempt)
    assert out.converged and out.iterate == "state unclamped" and solver.tension is None
    raised = [c for c in clamps if c is not None]
    assert raised[0] == pytest.approx(200.0) and clamps.index(raised[0]) == 2  # after the one step, friction's
    assert all(b == pytest.approx(RAMP_RATIO * a) for a, b in zip(raised, raised[1:]))


def test_joints_that_crush_get_no_tension_continuation():
    """A clamp would lower a compressive strength by as much as it adds in tension (no stronger structure): with
    crushing joints the self-weight that the one step and the friction continuation miss stays a failure, no clamp
    tried; Coulomb's joints do not crush, the crushing law's do."""
    solver = RingSolver(stress=400.0)
    solver.law = SimpleNamespace(crushes=True)
    clamps = []

    def attempt(level, start):
        clamps.append(solver.tension)
        return StepOutcome(False, "max iterations", 60, 1e-3, 60)

    assert not carry_self_weight(solver, attempt).converged and all(c is None for c in clamps)
    law = CoulombJoints(np.zeros(1), np.ones(1), 0.0)
    assert not law.crushes and CrushingJoints.blocks(1e6, 1.0, 4).crushes


def analysis_like(*, mesh_dependent=False, converged=False, capped=False, proved=False, lp=Status.LIMIT,
                  shortest=0.08, fill=None, reason="active set cycling"):
    """The parts of an Analysis that refinement_reason reads: a failed run (4 elements, 0.134 m) that carried
    nothing, its self-weight ``converged`` or not, its live-load search ended by a failed trial or ``capped`` by the
    load steps."""
    return SimpleNamespace(
        load_total=1.0, verdict=SimpleNamespace(mesh_dependent=mesh_dependent), scene=SimpleNamespace(fill=fill),
        search=SimpleNamespace(status=Status.failure(reason), last="state" if converged else None,
                               settled="state" if converged else None, proved=proved, lower=0.0,
                               failure="" if capped else "diverged"),
        lp=SimpleNamespace(status=lp, load=343.0), shortest_voussoir=shortest,
        block_mesh=SimpleNamespace(element_size=0.134))


@pytest.mark.parametrize("case, re_run", [
    ({}, True),  # self-weight failed without proof, short voussoirs, the LP stands
    ({"lp": Status.UNBOUNDED}, True),
    ({"lp": Status.UNSTABLE}, False),  # the LP agrees the ring falls: a finer mesh cannot make it stand
    ({"proved": True}, False),  # a proved mechanism is a verdict, not a failure
    ({"converged": True}, True),  # the self-weight converged, the live load's search failed without proof
    ({"converged": True, "shortest": 0.2}, True),  # ... on voussoirs of any length
    ({"converged": True, "proved": True}, False),
    ({"converged": True, "lp": Status.UNSTABLE}, False),
    ({"converged": True, "capped": True}, False),  # the cap on the load steps ended it: the scene's setting
    ({"converged": True, "fill": "a fill"}, True),  # under a fill on voussoirs shorter than an element
    ({"converged": True, "fill": "a fill", "shortest": 0.2}, False),  # ... not on longer ones
    ({"shortest": 0.2}, True),  # a bare structure's self-weight failure on voussoirs longer than an element
    ({"shortest": 0.2, "fill": "a fill"}, False),  # ... not under a fill
    ({"shortest": 0.2, "reason": "linear solver failed: DIVERGED_PCSETUP_FAILED"}, False),  # not the mesh's
    ({"shortest": 0.2, "reason": "linear solver failed, MUMPS INFOG(1) = -13: out of memory"}, False),
    ({"mesh_dependent": True, "converged": True}, True)])
def test_which_failures_are_re_run_on_a_finer_mesh(case, re_run):
    """A failure is re-run only without proof and with the LP's ring standing: on a live-load trial of a bare ring,
    on voussoirs shorter than an element under live load with a fill or under self-weight, under self-weight on
    longer ones of a bare structure unless its linear solve failed; a mesh-dependent limit always."""
    reason = refinement_reason(analysis_like(**case), 4)
    assert bool(reason) == re_run
    if re_run and not case.get("mesh_dependent"):
        short = "" if case.get("shortest") else " on voussoirs shorter than an element"
        assert reason.startswith(f"the search failed without proof at 0 kN{short} (" if case.get("converged") else
                                 f"the self-weight failed without proof{short} (")


@pytest.mark.slow
def test_a_ring_near_its_least_thickness_stands():
    """Campaign scene 251, 0.3 % thicker than the LP's least thickness (computed here): it stands (with 4 elements
    through the thickness, or after a re-run with 8 where the self-weight fails without proof on 4, as it did before
    predicted steps could return to their start's active set) and brackets the LP's collapse load (computed
    independently) within 0.5 %."""
    from bridgefem.limit.collapse import collapse_load
    from bridgefem.limit.thickness import min_thickness

    scene = scene_from_dict(SCENE_251)
    assert 1.0 < scene.arch.thickness / min_thickness(scene).thickness < 1.005
    lp = collapse_load(scene).load
    an = run_analysis(scene)
    assert [r.elements_through_thickness for r in an.refinements] in ([], [4])
    assert an.scene.mesh.elements_through_thickness == 4 * 2 ** len(an.refinements)
    assert an.search.status == Status.LIMIT
    assert 0.995 * lp <= an.search.upper * an.load_total and an.search.lower * an.load_total <= 1.005 * lp


def test_a_ring_held_by_friction_at_both_springings_carries_its_weight():
    """Campaign seed 1 #297 (elliptical, 47 voussoirs, mu = 0.376; meshed as with its load at 0.786 of the span, the
    search stopped at 1 mN): under self-weight both springings slide outwards, so the symmetric ring's thrust is
    friction-limited, H = mu V = mu W / 2 at each (V = W / 2 exactly: the meshed voussoirs carry the exact blocks'
    weights, :func:`bridgefem.fe.model.block_weight_shape`, so neither springing is the lighter one that slides
    first). Both springings at their limit at once leave the ring free to translate; the self-weight converges (a
    friction continuation when the one step cycles) and the search goes on, with H within 1e-5 of mu W / 2 at both
    springings."""
    scene = scene_from_dict({**campaign_scene(297, 1.2278), "solver": {"max_load": 1e-3, "initial_step": 1e-3}})
    an = run_analysis(scene, max_refinements=0)
    assert next(s for s in an.search.steps if s.converged).level == 0.0
    assert any(s.converged and s.level > 0.0 for s in an.search.steps)
    _, lam, _ = an.solver.system.split(an.search.last.x)
    joints = an.pairs.joint
    for springing in (joints.min(), joints.max()):
        thrust = abs(lam[joints == springing, 1].sum())
        assert thrust == pytest.approx(0.376 * an.model.dead_weight / 2, rel=1e-5)


def mohr_coulomb_fill_model():
    """Campaign seed 20261241 #15 (pointed, 98 voussoirs, mu 8.54, a Mohr-Coulomb fill with c = 5 kPa under a
    patch; 2 elements through the thickness) as ``bridgefem run`` builds it: its self-weight needs the cohesion
    continuation."""
    scene = scene_from_dict(campaign_scene(15, 3.6474, seed=20261241))
    return build_model(scene, MPI.COMM_WORLD, None, lambda name: None, Clock(MPI.COMM_WORLD))


@pytest.mark.slow  # an end-to-end run of more than a second
def test_a_plastic_fill_step_whose_active_set_repeats_itself_converges():
    """Seed 20261241 #15's self-weight with the fill's cohesion raised to its overburden stress, from the unloaded
    state with the Alart-Curnier constants x 10 (the first retry): the line-searched iteration returns to the same
    active sets with the same merit (a ring joint's pair next to a hinge cycling, the fill in equilibrium within
    1e-4 of the largest nodal force); taken as a cycle and broken, the step converges within its budget (before: all
    99 iterations, the set still changing)."""
    solver = mohr_coulomb_fill_model().solver
    solver.max_iterations = self_weight_budget(solver)
    solver.material.set_cohesion(solver.material.overburden)
    solver.use(Setting(scale=10.0))
    out = solver.solve_step(0.0, solver.initial_iterate())
    assert out.converged, out.reason
    assert out.iterations < solver.max_iterations // 2


@pytest.mark.slow
def test_a_mohr_coulomb_fill_carries_its_self_weight_through_the_cohesion_continuation():
    """Seed 20261241 #15 carries its self-weight at the scene's cohesion (before: the cohesion continuation failed,
    every raised step from the unloaded state diverging or cycling with each setting); the steps tried lower the
    cohesion from the overburden stress to the scene's 5 kPa."""
    fe = mohr_coulomb_fill_model()
    solver, fill = fe.solver, fe.solver.material
    tried = []

    def attempt(level, start, **kwargs):
        tried.append(fill.material.cohesion)
        return solver.solve_step(level, start, **kwargs)

    out = carry_self_weight(solver, attempt)
    assert out.converged, out.reason
    assert fill.material.cohesion == 5000.0 and tried[-1] == 5000.0 and max(tried) == pytest.approx(fill.overburden)


# campaign spans seed 20261263 #66 with 16 voussoirs per span instead of 64: two elliptical spans on a 27.9 m pier of
# 8 courses; from the bonded start the one step proposes about 200 pairs opening at once and wanders
TALL_PIER = {"scene": {"name": "tall pier"},
             "span": [{"shape": "elliptical", "span": 5.013, "rise": 1.563, "thickness": 0.3846, "voussoirs": 16},
                      {"shape": "elliptical", "span": 19.632, "rise": 6.12, "thickness": 1.5062, "voussoirs": 16}],
             "pier": [{"width": 2.553, "height": 27.861, "batter": 0.073, "blocks": 8}],
             "masonry": {"young": 28.9e9, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 0.67},
             "load": [{"kind": "point", "x": 24.7637}]}


@pytest.mark.slow
def test_a_bridge_on_a_tall_pier_carries_its_weight_through_the_tension_continuation():
    """The bridge's limit is the rigid-block LP's on the same joints within the FE/LP agreement, whichever way the
    search carried the self-weight (with one machine's BLAS the one step and the friction continuation's first step
    cycle, with another's the one step converges); and on the same FE model the tension continuation, run from the
    unloaded state, lowers the joints' tensile strength from the bonded state's largest tensile stress through
    converged states, each weaker than the one before, down to none, where it ends converged."""
    an = run_analysis(scene_from_dict(TALL_PIER), max_refinements=0)
    assert an.search.status == Status.LIMIT and an.lp.status == Status.LIMIT
    assert (1 - AGREEMENT) * an.lp.level <= an.search.lower <= an.lp.level * (1 + 1e-9)
    solver, tensions, steps = an.solver, [], []
    set_tension = solver.set_tension

    def record(tension):
        tensions.append(0.0 if tension is None else float(np.max(tension)))
        set_tension(tension)

    def attempt(level, start):
        out = solver.solve_step(level, start)
        steps.append((tensions[-1], out.converged))
        return out

    solver.set_tension, solver.max_iterations = record, self_weight_budget(solver)
    out = tension_continuation(solver, attempt)
    assert out is not None and out.converged and steps[-1] == (0.0, True) and tensions[-1] == 0.0
    held = [tension for tension, converged in steps if converged]
    assert len(held) > 2 and held[0] == tensions[0] > 0 and all(b < a for a, b in zip(held, held[1:]))
