"""The assessment's LP screen with a fill (issue 40): the axles dispersed through the fill onto the ring, checked
against the elasticity closed form, against LPs built by hand from the rules' own pressures, and by symmetry (the FE
at Prestwood's critical position against its own conic bounds is a study: benchmarks/assess_prestwood.py)."""
import dataclasses
import math

import numpy as np
import pytest
from conftest import ROOT
from scipy.integrate import quad

import bridgefem
from bridgefem.assess.dispersion import SPREAD, strip_stress
from bridgefem.assess.sweep import CONFIRM, _candidates, assess, lp_at
from bridgefem.assess.vehicle import place
from bridgefem.limit.rigid_block import generalised_loads, solve_blocks
from bridgefem.limit.ring_blocks import ring_model
from bridgefem.scene.vehicles import DISPERSIONS
from bridgefem.structure.ring import scene_ring

PRESTWOOD = ROOT / "demos" / "prestwood.toml"


ELASTIC = {"material": "elastic", "friction_angle": None, "cohesion": None, "tension_cutoff": None}


def _prestwood(fill=None, **vehicle):
    return bridgefem.edit(bridgefem.load_scene(PRESTWOOD), load=[], vehicle=vehicle, fill=fill or {})


def test_strip_stress_carries_the_load_and_matches_the_centreline_closed_form():
    """Flamant's strip: the vertical stress on a horizontal line at any depth integrates to the strip's load
    (vertical equilibrium), on the centreline it is q/pi (alpha + sin alpha) with alpha = 2 atan(c / 2z), and a
    narrow strip is Flamant's line load 2 P z^3 / (pi (x^2 + z^2)^2)."""
    q, c = 1e5, 0.4
    for z in (0.1, 0.7, 2.5):
        total = quad(lambda x: float(strip_stress(q, c, np.array(x), np.array(z))), -np.inf, np.inf, limit=400)[0]
        assert total == pytest.approx(q * c, rel=1e-7)
        alpha = 2 * math.atan(c / (2 * z))
        assert float(strip_stress(q, c, np.array(0.0), np.array(z))) == pytest.approx(
            q / math.pi * (alpha + math.sin(alpha)), rel=1e-12)
    p, tiny, x, z = 1e5, 1e-5, np.array([-0.8, 0.0, 0.3]), np.array(0.6)
    assert strip_stress(p / tiny, tiny, x, z) == pytest.approx(2 * p * z ** 3 / (np.pi * (x ** 2 + z ** 2) ** 2),
                                                               rel=1e-8)


def _hand_lp(scene, pressure_of_axle):
    """The LP of ``scene`` (a placed scene) with its fill as dead load and, per voussoir, the resultant of the
    vertical pressure ``pressure_of_axle(load, lo, hi, road, ring)`` -> (f(x) for arrays x, [a, b]) of each of its
    loads, integrated over the voussoir's part of [a, b] by a 24-point Gauss-Legendre rule between consecutive
    vertices of its extrados (the pressure is smooth there): the factor of the vehicle."""
    ring = scene_ring(scene)
    model = ring_model(scene, live=False)
    road = ring.crown_extrados + scene.fill.depth
    top = max(scene.vehicle.axles)
    nodes, weights = np.polynomial.legendre.leggauss(24)
    blocks, points, forces = [], [], []
    for ld in scene.loads:
        f, (a, b) = pressure_of_axle(ld.factor * top, *ld.x_range(scene.arch.span), road, ring)
        for v in ring.voussoirs:
            lo, hi = max(a, v.extrados[0, 0]), min(b, v.extrados[-1, 0])
            if hi <= lo:
                continue
            inner = v.extrados[:, 0]
            cuts = np.unique(np.concatenate([[lo, hi], inner[(inner > lo) & (inner < hi)]]))
            mid, half = (cuts[1:] + cuts[:-1])[:, None] / 2, np.diff(cuts)[:, None] / 2
            x = (mid + half * nodes).ravel()
            w = (half * weights).ravel()
            force, moment = float(np.sum(w * f(x))), float(np.sum(w * x * f(x)))
            if force > 0:
                blocks.append(v.id)
                points.append(ring.extrados_point(moment / force))
                forces.append((0.0, -force))
    live = generalised_loads(model.ref, np.array(blocks), np.array(points), np.array(forces))
    return solve_blocks(dataclasses.replace(model, live=live)).level


def _spread_pressure(rule):
    def pressure(load, lo, hi, road, ring):
        h = road - ring.extrados_point((lo + hi) / 2)[1]
        a, b = lo - h * SPREAD[rule], hi + h * SPREAD[rule]
        return (lambda x: np.full_like(x, load / (b - a))), (a, b)
    return pressure


def _boussinesq_pressure(load, lo, hi, road, ring):
    return (lambda x: strip_stress(load / (hi - lo), hi - lo, x - (lo + hi) / 2, road - ring.extrados_point(x)[1])
            ), (-np.inf, np.inf)


@pytest.mark.parametrize("x0", [-0.05, 1.9])  # the first axle half off the span; both axles on it
@pytest.mark.parametrize("rule", ["spread-2:1", "spread-30", "none", "boussinesq"])
def test_screen_equals_an_lp_built_by_hand_from_the_rule(rule, x0):
    """The screen's LP factor at a position is the LP of the same ring with the fill as dead load and, on each
    voussoir, the resultant of the rule's pressure integrated by quadrature: a spread rule's uniform pressure
    P / (c + 2 h tan(theta)) (c and P the part of the tyre patch on the span and its load), or Flamant's strip
    stress at each point's own depth. Exact for the spread rules (equal to the LP's precision); the screen's
    cells against quadrature for Boussinesq."""
    s = _prestwood(axles=[100e3, 80e3], spacing=[1.2], contact_length=0.3, dispersion=rule)
    pl = place(s, x0)
    pressure = _boussinesq_pressure if rule == "boussinesq" else _spread_pressure(rule)
    hand = _hand_lp(pl.scene, pressure)
    assert lp_at(s, x0).factor == pytest.approx(hand, rel=2e-4 if rule == "boussinesq" else 1e-7)


@pytest.mark.parametrize("rule", ["boussinesq", "spread-2:1", "none"])
def test_single_axle_on_a_symmetric_filled_arch_gives_a_symmetric_screen(rule):
    """One point axle on Prestwood (a symmetric segmental arch under a level fill; elastic, where point axles are
    allowed, so that the joint moved under the axle mirrors too): the screen's LP factor with the axle at x equals
    the factor at span - x, and the least is not at the crown."""
    s = _prestwood(axles=[100e3], contact_length=0.0, dispersion=rule, fill=ELASTIC)
    span = s.arch.span
    xs = np.linspace(0.4, span / 2 - 0.2, 7)
    left = np.array([lp_at(s, float(x)).factor for x in xs])
    right = np.array([lp_at(s, float(span - x)).factor for x in xs])
    assert np.allclose(left, right, rtol=1e-6)
    assert left.min() < lp_at(s, span / 2).factor


def test_point_axle_without_spreading_is_a_point_load_on_the_extrados():
    """A point axle with dispersion "none" over an elastic fill: the screen is the LP of the same axle as a point
    load on the extrados below it (the ring's own point-load rule), not a lost load."""
    s = _prestwood(axles=[100e3], contact_length=0.0, dispersion="none", fill=ELASTIC)
    x0 = 1.7
    pl = place(s, x0)
    model = ring_model(pl.scene)  # the axle, 1 N per unit level, on the extrados: half on each side at a joint
    assert lp_at(s, x0).factor == pytest.approx(solve_blocks(model).level / 100e3, rel=1e-7)


@pytest.mark.slow
def test_fill_screens_every_rule_and_the_fe_confirms_each_rules_least_position(monkeypatch):
    """With a fill each dispersion rule screens the roll: its least LP factor and position are those of the
    assessment whose scene has that rule, and every rule's least position is confirmed by the FE (within the
    finest refinement's spacing of a candidate), each candidate carrying the scene rule's LP factor there.

    An assessment's factor and critical position come from its own rule's screen alone (each screen is refined
    around its own minima), so the assessments of the other rules' scenes run that screen only (the first of
    ``_screens``, the scene's own rule); the scene's own rule is ``a`` itself."""
    from bridgefem.assess import sweep

    s = _prestwood(axles=[100e3, 100e3], spacing=[1.2], contact_length=0.3)
    [a] = assess([s], step=0.3, fe=False)
    assert set(a.dispersion_minima) == set(DISPERSIONS)
    screens = sweep._screens
    for rule, m in a.dispersion_minima.items():
        if rule == s.vehicle.dispersion:
            own = a
        else:
            with monkeypatch.context() as patch:
                patch.setattr(sweep, "_screens", lambda scene: screens(scene)[:1])
                [own] = assess([bridgefem.edit(s, vehicle={"dispersion": rule})], step=0.3, fe=False)
            assert set(own.dispersion_minima) == {rule}  # its own screen, with the scene's rule
        assert (m.factor, m.x0) == pytest.approx((own.lp_factor, own.lp_critical_x), rel=1e-12)
    candidates = _candidates(a, CONFIRM)
    for m in a.dispersion_minima.values():
        assert min(abs(m.x0 - c.x0) for c, _ in candidates) <= a.step * 2 / 8 ** 2
    for c, _ in candidates:
        assert c.factor == pytest.approx(lp_at(s, c.x0).factor, rel=1e-12)


@pytest.mark.parametrize("carried, stands", [(1.8, True), (1.5, False)])
def test_a_failed_confirmation_is_reported_with_what_it_carried(carried, stands):
    """An FE confirmation that ends in a solver failure is named in the warnings with the vehicle factor it had
    carried (its last converged load over the vehicle load), and whether the adequacy factor of the other
    confirmations stands (it does when the failed run had carried more)."""
    from bridgefem.assess.sweep import Assessment, Confirmation
    from bridgefem.io.assessment import assessment_data

    s = _prestwood(axles=[100e3], contact_length=0.3)
    load = 100e3

    def summary(lower, status):
        return {"status": status, "limit_load": {"lower": lower, "upper": None}, "evidence": "",
                "mechanism": {"hinges": [], "sliding": []}, "warnings": []}
    ok = Confirmation(2.0, load, "limit load found", (1.7, 1.71), 1.0, summary(1.7 * load, "limit load found"), 1.0)
    failed = Confirmation(4.0, load, "solver failure: test", None, 1.0, summary(carried * load, "solver failure"),
                          1.0, "none")
    a = Assessment(s, 0.1, [], 1.0, 2.0, [ok, failed], adequacy=(1.7, 1.71), critical_x=2.0,
                   status="adequacy factor found")
    [w] = [w for w in assessment_data(a)["warnings"] if "x = 4.000 m" in w]
    assert f"vehicle x {carried:.4f}" in w and ("stands" in w) == stands


def test_the_confirmations_start_with_the_least_factor_any_screen_gives():
    """The FE confirms the positions in the order of the factor their own screen gives them, least first (the
    likeliest critical position first, whose bracket then prunes the others): here the no-spreading screen's least
    position, then the 2:1 and 30-degree screens', then the scene's own (Boussinesq) two minima."""
    from bridgefem.assess.sweep import Assessment, PositionLP

    s = _prestwood(axles=[100e3, 100e3], spacing=[1.2], contact_length=0.3)
    xs, factors = [0.3, 0.76, 2.0, 4.59, 5.0], [1.2, 1.02, 1.3, 1.021, 1.2]
    positions = [PositionLP(x, f, "limit load found") for x, f in zip(xs, factors)]
    a = Assessment(s, 0.3, positions, 1.02, 0.76)
    a.dispersion_minima = {"boussinesq": positions[1], "spread-2:1": PositionLP(0.63, 0.92, "limit load found"),
                           "spread-30": PositionLP(4.71, 0.93, "limit load found"),
                           "none": PositionLP(4.76, 0.87, "limit load found")}
    order = [(c.x0, rule) for c, rule in _candidates(a, CONFIRM)]
    assert order == [(4.76, "none"), (0.63, "spread-2:1"), (4.71, "spread-30"), (0.76, None), (4.59, None)]
