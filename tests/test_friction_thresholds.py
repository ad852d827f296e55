"""Friction thresholds of a complete semicircular arch with radial joints under self-weight, rigid-block LP
(bridgefem.limit.rigid_block) against published values.

Cocchetti & Rizzi (2020, Frattura ed Integrita Strutturale 51:356, Table 3), continuous radial joints: sliding
first appears at mu_rm = 0.395832 (below it the least thickness grows above Heyman's t/R = 0.107426, with sliding
at the springings); no thickness stands below mu_ms = 0.309215 (at mu_ms the least thickness is t/R = 0.200637).
Gilbert, Casapulla & Ahmed (2006, Computers & Structures 84:873), 27 voussoirs, centreline radius 10 m, mu = 0.35:
the ring stands with t = 1.56 m and falls with t = 1.46 m.

Which friction model: both publications state equilibrium with the Coulomb limit |s| <= mu n (a static
condition, no flow rule); their collapse states (hinges plus sliding joints, one degree of freedom) are
statically determinate, so they hold for associative and non-associative (no dilatancy) friction alike: "falls"
means no admissible equilibrium exists, which fails either model; Gilbert et al.'s values are from their
non-associative LP. The tests run both models; the non-associative runs, whose fixed point takes its 200 LPs at
every thickness that falls (about 1 s each), are slow: the fast layer checks that fixed point on the same ring in
tests/test_rigid_block.py (Gilbert's mu = 0.375 on its 0.01 grid).
"""
import pytest
from conftest import bridgefem

from bridgefem.limit.rigid_block import dead_load_deficit, dead_load_margin
from bridgefem.limit.ring_blocks import ring_model
from bridgefem.limit.thickness import _THICKNESS_RANGE, NoStableThickness, min_thickness
from bridgefem.scene.reader import scene_from_dict

MU_RM, MU_MS, ETA_MS = 0.395832, 0.309215, 0.200637
FRICTION_MODELS = ["associative", pytest.param("non-associative", marks=pytest.mark.slow)]


def semicircle(voussoirs, friction, ratio, radius=10.0):
    """Semicircle of centreline radius ``radius`` (m) and thickness ``ratio`` x radius, self-weight only."""
    t = ratio * radius
    return scene_from_dict({
        "arch": {"shape": "semicircular", "span": 2 * (radius - t / 2), "rise": radius - t / 2, "thickness": t,
                 "voussoirs": voussoirs, "joint_at_loads": False},
        "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": friction},
        "load": []})


def stands(voussoirs, friction, ratio, friction_model="associative", radius=10.0):
    model = ring_model(semicircle(voussoirs, friction, ratio, radius), live=False)
    return dead_load_deficit(model, friction_model)[1].status == "stable under self-weight"


@pytest.mark.parametrize("friction_model", FRICTION_MODELS)
def test_gilbert_27_voussoirs_mu_035(friction_model):
    assert stands(27, 0.35, 0.156, friction_model)  # t = 1.56 m for R = 10 m
    assert not stands(27, 0.35, 0.146, friction_model)  # t = 1.46 m


def test_onset_of_sliding():
    """Just above mu_rm the least thickness is Heyman's (27 voussoirs: 0.1068), purely rotational; just below, it
    is larger and the mechanism slides at a springing. (The 27 joints shift the threshold to 0.3946, hence the
    1 % margins; the LP with 100+ joints gives 0.39525: test_thresholds_many_joints.)"""
    above = min_thickness(semicircle(27, MU_RM * 1.01, 0.15), rtol=1e-4)
    below = min_thickness(semicircle(27, MU_RM * 0.99, 0.15), rtol=1e-4)
    assert above.ratio == pytest.approx(0.1068, rel=1e-3) and above.mechanism.sliding == []
    assert below.ratio > 1.01 * above.ratio
    assert set(below.mechanism.sliding) & {0, 27}


def test_least_thickness_across_a_change_of_mechanism():
    """Just below mu_rm a ring well below its least thickness falls by four hinges, one just below it by three
    hinges and a slip at a springing: the value Brent's method interpolates (the deficit where the ring falls, the
    margin where it stands) has a kink inside the search's bracket. The search still ends on a bracket of a ring
    that falls and one that stands, within rtol, around the change from falling to standing that a bisection of
    stand/fall finds, in fewer analyses; the margin is the deficit where the ring falls and negative where it
    stands."""
    sc, rtol = semicircle(27, MU_RM * 0.99, 0.15), 1e-4

    def analysed(t):
        model = ring_model(sc, thickness=t, live=False)
        return dead_load_deficit(model), dead_load_margin(model)

    res = min_thickness(sc, rtol=rtol)
    lo, hi = res.bracket
    ((tau, falls), margin), ((_, stands), above) = analysed(lo), analysed(hi)
    assert falls.status == "unstable under self-weight" and stands.status == "stable under self-weight"
    assert 0 < hi - lo <= rtol * hi and res.thickness == hi
    assert margin == pytest.approx(tau, rel=1e-3) and above < 0
    assert res.mechanism.by_joint.sliding == falls.by_joint.sliding == [0]
    thinner = analysed(0.9 * lo)[0][1]
    assert thinner.by_joint.sliding == [] and len(thinner.by_joint.hinges) == 4  # another mechanism
    a, b = (f * sc.arch.span for f in _THICKNESS_RANGE)
    bisections = 1
    while b - a > rtol * b:
        mid, bisections = 0.5 * (a + b), bisections + 1
        a, b = (a, mid) if analysed(mid)[0][1].status == "stable under self-weight" else (mid, b)
    assert a < hi and lo < b
    assert res.evaluations < bisections


@pytest.mark.parametrize("friction_model", FRICTION_MODELS)
def test_no_thickness_below_mu_ms(friction_model):
    """A thick ring (t/R = 0.25 > 0.2006) stands just above mu_ms and falls just below, by sliding; below mu_ms
    the least-thickness search says that no thickness stands."""
    assert stands(27, MU_MS * 1.003, 0.25, friction_model)
    assert not stands(27, MU_MS * 0.997, 0.25, friction_model)
    with pytest.raises(NoStableThickness, match="slide"):
        min_thickness(semicircle(27, 0.30, 0.15), friction_model=friction_model)


@pytest.mark.slow
def test_thresholds_many_joints():
    """100 voussoirs (joints every 1.8 degrees) approach the continuous arch: mu_ms to 1e-4 and mu_rm to 0.3 %
    (the LP weighs the voussoirs at their true centroids, the publication on the centreline: the same shift as
    Heyman's 0.10748 against 0.107426), bisected on mu; and the least thickness just above mu_ms is t/R ~ 0.20."""
    def threshold(ratio, lo=0.25, hi=0.45):
        while hi - lo > 1e-5:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if stands(100, mid, ratio) else (mid, hi)
        return hi

    heyman = min_thickness(semicircle(100, 10.0, 0.15), rtol=1e-6).ratio
    assert threshold(heyman * (1 + 1e-4)) == pytest.approx(MU_RM, rel=3e-3)
    assert threshold(0.25) == pytest.approx(MU_MS, rel=1e-4)
    assert min_thickness(semicircle(100, MU_MS * 1.002, 0.25), rtol=1e-4).ratio == pytest.approx(ETA_MS, rel=0.05)


@pytest.mark.slow
def test_min_thickness_command_without_a_stable_thickness(tmp_scene):
    """`bridgefem min-thickness` at mu = 0.30 (below mu_ms): one line naming the sliding joints, exit code 1."""
    d = {"arch": {"shape": "semicircular", "span": 9.0, "thickness": 1.0, "voussoirs": 27},
         "masonry": {"young": 1e10, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 0.30}}
    out = bridgefem("min-thickness", tmp_scene(d))
    assert out.returncode == 1 and not out.stderr
    assert out.stdout.count("\n") == 1 and out.stdout.startswith("minimum thickness under self-weight: none:")
    assert "slide" in out.stdout
