"""Backfill plasticity (bridgefem.laws.soil) against closed forms that do not use the implementation.

Every reference is recomputed here from (E, nu, phi, c, sigma_t): Hooke's law, the stress invariants, the
cone ``sqrt(J2) + alpha I1 - k``, the Mohr-Coulomb plane-strain limit states, and the Kuhn-Tucker conditions
of the closest-point projection (admissibility, associated flow, complementarity, maximum dissipation),
which for a convex elastic domain characterise the return uniquely. Sign convention: tension positive;
4-vectors [xx, yy, zz, xy], strains with engineering shear.

Tolerances: stresses are O(L) = 50 kPa and elastic strains O(L/E) = 1e-3; round-off in the return is
~1e-16 relative, so "exact" identities are asserted to 1e-10 .. 1e-8 relative, leaving margin for the
sums of a few terms without admitting any modelling error.
"""
import numpy as np
import pytest
from scipy.optimize import brentq

from bridgefem.laws.soil import MohrCoulomb, elastic_tangent, return_map

E = 50e6  # Pa
L = 50e3  # Pa: stress scale of the tests, a few metres of backfill
MATERIALS = {
    "phi30-c10k": MohrCoulomb(E, 0.3, 30.0, 10e3),  # cut-off p <= 0 below the apex (17.3 kPa): cap + corner
    "sand-phi35": MohrCoulomb(E, 0.3, 35.0, 0.0),  # cohesionless, no tension: cut-off at the apex
    "tresca-phi0": MohrCoulomb(E, 0.25, 0.0, 20e3, 5e3),  # phi = 0 (no apex) with a cut-off
    "phi50-apex": MohrCoulomb(E, 0.2, 50.0, 5e3, 50e3),  # cut-off beyond the apex (4.2 kPa): apex return
    "phi20-cut2k": MohrCoulomb(E, 0.35, 20.0, 10e3, 2e3),
}
material_cases = pytest.mark.parametrize("mat", MATERIALS.values(), ids=MATERIALS.keys())
M = np.array([1.0, 1.0, 1.0, 0.0])
W = np.array([1.0, 1.0, 1.0, 2.0])  # a:b = sum(W a b) for tensor components; tensor -> engineering strain
IN_PLANE = [0, 1, 3]


# ---- independent reference formulas -------------------------------------------------------------------
def moduli(mat):
    """(lambda, G, K) from E and nu."""
    e, nu = mat.young, mat.poisson
    return e * nu / ((1 + nu) * (1 - 2 * nu)), e / (2 * (1 + nu)), e / (3 * (1 - 2 * nu))


def hooke(mat, strain):
    """Stress of the elastic strain (n, 4), engineering shear."""
    lam, g, _ = moduli(mat)
    stress = lam * strain[:, :3].sum(axis=1, keepdims=True) * M + 2 * g * strain
    stress[:, 3] = g * strain[:, 3]
    return stress


def compliance(mat, stress):
    """Elastic strain (n, 4) of the stress, engineering shear."""
    e, nu = mat.young, mat.poisson
    strain = (1 + nu) / e * stress - nu / e * stress[:, :3].sum(axis=1, keepdims=True) * M
    strain[:, 3] = 2 * (1 + nu) / e * stress[:, 3]
    return strain


def invariants(stress):
    """Mean stress p, deviator s and q = sqrt(J2)."""
    p = stress[:, :3].mean(axis=1)
    s = stress - p[:, None] * M
    return p, s, np.sqrt(0.5 * (W * s * s).sum(axis=1))


def strength(mat):
    """(alpha, k, largest admissible p, sqrt(J2) where the cut-off meets the cone)."""
    t = np.tan(np.radians(mat.friction_angle))
    alpha, k = t / np.sqrt(9 + 12 * t * t), 3 * mat.cohesion / np.sqrt(9 + 12 * t * t)
    apex = mat.cohesion / t if t > 0 else np.inf
    p_max = min(mat.tension_cutoff, apex)
    return alpha, k, p_max, k - 3 * alpha * p_max


def cone(mat, stress):
    alpha, k, _, _ = strength(mat)
    p, _, q = invariants(stress)
    return q + 3 * alpha * p - k


def principal_in_plane(stress):
    """Centre m = (s1 + s3)/2 and radius R = (s1 - s3)/2 of the in-plane Mohr circle."""
    return 0.5 * (stress[:, 0] + stress[:, 1]), np.hypot(0.5 * (stress[:, 0] - stress[:, 1]), stress[:, 3])


def strain_for_trial(mat, trial, plastic):
    """Total strain (eps_zz = 0) whose elastic trial stress is ``trial`` given the old plastic strain; the
    old plastic eps_zz absorbs the out-of-plane elastic strain of the trial."""
    plastic = plastic.copy()
    elastic = compliance(mat, trial)
    plastic[:, 2] = -elastic[:, 2]
    return elastic + plastic, plastic


def unit_deviators(rng, n):
    """Random deviators (n, 4) (zz included) with sqrt(J2) = 1."""
    s = rng.standard_normal((n, 4))
    s[:, :3] -= s[:, :3].mean(axis=1, keepdims=True)
    return s / np.sqrt(0.5 * (W * s * s).sum(axis=1))[:, None]


def random_states(mat, n, seed):
    """Random trial stresses with |p|, sqrt(J2) up to a few L (all regimes), random old plastic strain."""
    rng = np.random.default_rng(seed)
    trial = rng.uniform(0, 4 * L, (n, 1)) * unit_deviators(rng, n) + rng.uniform(-4 * L, 2 * L, (n, 1)) * M
    return strain_for_trial(mat, trial, rng.normal(0, L / E, (n, 4)))


# ---- material constants -------------------------------------------------------------------------------
@material_cases
def test_constants_are_the_plane_strain_mohr_coulomb_match(mat):
    """With associated flow, plane-strain collapse has s_zz = -2 alpha sqrt(J2), so J2 = R^2 / (1 - 3 alpha^2)
    and f = 0 reads R sqrt(1 - 3 alpha^2) + 3 alpha m = k: the Mohr-Coulomb line R = c cos(phi) - m sin(phi)
    iff k / sqrt(1 - 3 alpha^2) = c cos(phi) and 3 alpha / sqrt(1 - 3 alpha^2) = sin(phi)."""
    phi = np.radians(mat.friction_angle)
    root = np.sqrt(1 - 3 * mat.alpha ** 2)
    assert mat.k / root == pytest.approx(mat.cohesion * np.cos(phi), rel=1e-14, abs=1e-9)
    assert 3 * mat.alpha / root == pytest.approx(np.sin(phi), rel=1e-14, abs=1e-15)
    assert mat.mean_stress_limit == pytest.approx(strength(mat)[2], rel=1e-14)


@material_cases
def test_elastic_tangent_is_plane_strain_hooke(mat):
    nu = mat.poisson
    d = mat.young * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    expected = d * np.array([[1, nu / (1 - nu), 0], [nu / (1 - nu), 1, 0], [0, 0, (1 - 2 * nu) / (2 * (1 - nu))]])
    np.testing.assert_allclose(elastic_tangent(mat), expected, rtol=1e-14, atol=1e-14 * E)


@pytest.mark.parametrize("bad", [dict(young=0.0), dict(poisson=0.5), dict(friction_angle=-1.0),
                                 dict(friction_angle=90.0), dict(cohesion=-1.0), dict(tension_cutoff=-1.0),
                                 dict(cohesion=np.nan)])
def test_rejects_invalid_parameters(bad):
    with pytest.raises(ValueError):
        MohrCoulomb(**{**dict(young=E, poisson=0.3, friction_angle=30.0, cohesion=1e3), **bad})


# ---- the return map -----------------------------------------------------------------------------------
@material_cases
def test_elastic_range_is_plane_strain_hooke(mat):
    rng = np.random.default_rng(1)
    n = 2000
    strain = rng.normal(0, 0.5 * L / E, (n, 4)) + np.array([-1, -1, 0, 0]) * 0.5 * L / E
    strain[:, 2] = 0.0
    plastic = rng.normal(0, L / E, (n, 4))
    expected = hooke(mat, strain - plastic)
    inside = (cone(mat, expected) < -1e-6 * L) & (expected[:, :3].mean(axis=1) < mat.tension_cutoff - 1e-6 * L)
    assert inside.sum() > 100
    stress, tangent, new_plastic = return_map(mat, strain[inside], plastic[inside])
    np.testing.assert_allclose(stress, expected[inside], rtol=0, atol=1e-12 * L)
    np.testing.assert_allclose(tangent, np.broadcast_to(elastic_tangent(mat), tangent.shape), rtol=0,
                               atol=1e-12 * E)
    np.testing.assert_array_equal(new_plastic, plastic[inside])


@material_cases
def test_return_is_admissible_on_the_boundary_and_elastic(mat):
    """After the return: stress = Hooke(strain - plastic strain); f <= 0 and p <= sigma_t; every point whose
    plastic strain changed lies on the boundary, max(f, p - sigma_t) = 0, to 1e-8 relative."""
    strain, plastic = random_states(mat, 4000, seed=2)
    stress, tangent, new_plastic = return_map(mat, strain, plastic)
    np.testing.assert_allclose(stress, hooke(mat, strain - new_plastic), rtol=0, atol=1e-10 * L)
    f, cut = cone(mat, stress), stress[:, :3].mean(axis=1) - mat.tension_cutoff
    assert f.max() <= 1e-8 * L and cut.max() <= 1e-8 * L
    yielded = np.any(new_plastic != plastic, axis=1)
    assert 0.2 < yielded.mean() < 0.95  # the sample covers both the elastic range and plastic returns
    np.testing.assert_allclose(np.maximum(f, cut)[yielded], 0.0, atol=1e-8 * L)
    # The algorithmic tangent of a projection onto a convex set (associated flow) is symmetric, PSD.
    np.testing.assert_allclose(tangent, tangent.transpose(0, 2, 1), rtol=0, atol=1e-10 * E)
    assert np.linalg.eigvalsh(tangent).min() >= -1e-10 * E


@material_cases
def test_plastic_flow_is_associated_and_dissipative(mat):
    """Kuhn-Tucker conditions of the return: the plastic strain increment lies in the normal cone of the
    elastic domain {f <= 0, p <= sigma_t} at the returned stress, i.e. d_eps_p = a df/dsigma + b I/3 with
    a, b >= 0, a > 0 only on the cone, b > 0 only on the cut-off (at the apex df/dsigma is the subdifferential
    {g + alpha I: |g| <= 1/sqrt(2)}); and maximum plastic dissipation: (sigma - sigma*) : d_eps_p >= 0 for
    admissible sigma* (sigma* = 0 gives dissipation >= 0)."""
    alpha = strength(mat)[0]
    strain, plastic = random_states(mat, 4000, seed=3)
    stress, _, new_plastic = return_map(mat, strain, plastic)
    p, s, q = invariants(stress)
    f, on_cut = cone(mat, stress), np.abs(p - mat.tension_cutoff) <= 1e-8 * L
    on_cone = np.abs(f) <= 1e-8 * L
    d_eps = (new_plastic - plastic) / W  # tensor components
    trace = d_eps[:, :3].sum(axis=1)
    dev = d_eps - trace[:, None] / 3 * M
    tol = 1e-9 * L / E  # strain tolerance

    smooth = q > 1e-9 * L
    q_safe = np.where(smooth, q, 1.0)
    # a: multiplier of df/dsigma = s/(2q) + alpha I; at the apex the least a with |dev| <= a/sqrt(2).
    a = np.where(smooth, (W * dev * s).sum(axis=1) / q_safe, np.sqrt(2 * (W * dev * dev).sum(axis=1)))
    residual = dev - np.where(smooth, a / (2 * q_safe), 0.0)[:, None] * s
    b = trace - 3 * alpha * a
    assert np.abs(residual[smooth]).max() <= tol  # deviatoric flow along s where sqrt(J2) > 0
    assert a.min() >= -tol and b.min() >= -tol
    assert np.all(on_cone[a > tol])
    # b > 0 needs the cut-off, except at the cone apex, where a can grow to absorb it.
    assert np.all((on_cut | (~smooth & on_cone & (alpha > 0)))[b > tol])
    # Every regime occurs in the sample: smooth cone, cut-off face (if there is one), corner or apex.
    assert np.any((a > tol) & (b <= tol) & smooth)
    assert np.any((a <= tol) & (b > tol) & on_cut) or strength(mat)[3] == 0
    assert np.any((a > tol) & (b > tol))

    rng = np.random.default_rng(4)
    candidates = rng.uniform(0, 3 * L, (400, 1)) * unit_deviators(rng, 400) + rng.uniform(-3 * L, L, (400, 1)) * M
    admissible = candidates[(cone(mat, candidates) <= 0) & (candidates[:, :3].mean(axis=1) <= mat.tension_cutoff)]
    admissible = np.vstack([admissible, np.zeros(4)])
    work = (stress * (new_plastic - plastic)).sum(axis=1)  # sigma : d_eps_p with engineering shear
    assert work.min() >= -1e-9 * L * L / E
    other = (new_plastic - plastic) @ admissible.T
    assert (work[:, None] - other).min() >= -1e-9 * L * L / E


def regime_states(mat, regime, n, seed):
    """Trial states whose closed-form return is known by construction (q = sqrt(J2), p): a point of the
    boundary plus a trial offset C:(normal) in the interior of its normal cone. Returns strain, plastic
    strain, expected stress."""
    alpha, k, p_max, r_corner = strength(mat)
    _, g, bulk = moduli(mat)
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.5, 2.0, n) * L  # offsets, kept O(L) from every regime boundary
    u = rng.uniform(0.5, 2.0, n) * L
    p0 = min(p_max, 0.0) - L
    if regime == "elastic":  # half-way between the axis and the cone, the return is the trial itself
        p = p_tr = np.full(n, p0)
        q = q_tr = np.full(n, 0.5 * (k - 3 * alpha * p0))
    elif regime == "cone":  # on the cone at p0, offset along the normal s/(2q) + alpha I
        p, q = np.full(n, p0), np.full(n, k - 3 * alpha * p0)
        q_tr, p_tr = q + t, p + 3 * bulk * alpha * t / g
    elif regime == "cap":  # the cut-off face below the corner, offset along I
        p, q = np.full(n, p_max), rng.uniform(0.2, 0.8, n) * r_corner
        q_tr, p_tr = q, p + u
    else:  # corner (the apex if r_corner = 0), offset along both normals
        p, q = np.full(n, p_max), np.full(n, r_corner)
        q_tr, p_tr = q + t, p + 3 * bulk * alpha * t / g + u
    direction = unit_deviators(rng, n)
    expected = q[:, None] * direction + p[:, None] * M
    strain, plastic = strain_for_trial(mat, q_tr[:, None] * direction + p_tr[:, None] * M,
                                       rng.normal(0, L / E, (n, 4)))
    return strain, plastic, expected


REGIME_CASES = [pytest.param(m, r, id=f"{name}-{r}") for name, m in MATERIALS.items()
                for r in ("elastic", "cone", "cap", "corner")
                if not (r == "cap" and strength(m)[3] == 0)]  # no cut-off face when sigma_t is at the apex


@pytest.mark.parametrize("mat,regime", REGIME_CASES)
def test_return_and_consistent_tangent_per_regime(mat, regime):
    """The return lands on the closest point constructed in closed form, and the tangent equals central
    differences of the returned stress. Step h = 1e-8 against strains O(1e-3): truncation ~ E (h/1e-3)^2
    and round-off ~ 1e-16 L / h are both < 1e-6 E, and every point is O(L/E) >> h from a regime boundary."""
    strain, plastic, expected = regime_states(mat, regime, 20, seed=5)
    stress, tangent, _ = return_map(mat, strain, plastic)
    np.testing.assert_allclose(stress, expected, rtol=0, atol=1e-9 * L)
    assert_tangent_is_the_derivative(mat, strain, plastic, tangent, 1e-6 * E)


def assert_tangent_is_the_derivative(mat, strain, plastic, tangent, atol):
    """The tangent (n, 3, 3) equals central differences of the returned stress, step h = 1e-8."""
    h = 1e-8
    for j, component in enumerate(IN_PLANE):
        step = np.zeros(4)
        step[component] = h
        upper, _, _ = return_map(mat, strain + step, plastic)
        lower, _, _ = return_map(mat, strain - step, plastic)
        np.testing.assert_allclose(tangent[:, :, j], (upper - lower)[:, IN_PLANE] / (2 * h), rtol=0, atol=atol)


# ---- loading paths with Mohr-Coulomb closed forms -----------------------------------------------------
def mixed_control(mat, steps, prescribed, free, target):
    """Strain path with strain components ``prescribed(i) -> {index: value}`` and the stress components
    ``free`` held at ``target`` by Newton's method on the matching strains (uses the consistent tangent)."""
    strain, plastic = np.zeros((1, 4)), np.zeros((1, 4))
    rows = [IN_PLANE.index(i) for i in free]
    for i in range(steps):
        for index, value in prescribed(i).items():
            strain[0, index] = value
        for _ in range(20):
            stress, tangent, new_plastic = return_map(mat, strain, plastic)
            residual = stress[0, free] - target
            if np.abs(residual).max() <= 1e-12 * L:
                break
            strain[0, free] -= np.linalg.solve(tangent[0][np.ix_(rows, rows)], residual)
        else:
            raise AssertionError(f"Newton did not converge in step {i}")
        plastic = new_plastic
    return stress


@material_cases
def test_biaxial_compression_reaches_the_passive_mohr_coulomb_limit(mat):
    """Plane-strain biaxial test: sigma_xx = -s_c held, eps_yy compressed far beyond yield. At collapse the
    Mohr-Coulomb criterion (s1 - s3)/2 = c cos(phi) - (s1 + s3)/2 sin(phi) with s1 = -s_c gives
    sigma_yy = -(s_c (1 + sin phi) + 2 c cos phi) / (1 - sin phi) (passive: s_c K_p + 2 c sqrt(K_p))."""
    phi, s_c = np.radians(mat.friction_angle), L
    stress = mixed_control(mat, 60, lambda i: {1: -(i + 1) * 5e-3}, [0], [-s_c])
    expected = -(s_c * (1 + np.sin(phi)) + 2 * mat.cohesion * np.cos(phi)) / (1 - np.sin(phi))
    assert stress[0, 1] == pytest.approx(expected, rel=1e-9)
    centre, radius = principal_in_plane(stress)
    assert radius[0] == pytest.approx(mat.cohesion * np.cos(phi) - centre[0] * np.sin(phi), rel=1e-9)


@material_cases
def test_simple_shear_under_constant_normal_stress(mat):
    """Simple shear (eps_xx = 0, gamma_xy driven) with sigma_yy = -s_n held. At steady collapse the x direction
    does not extend; with associated flow (dilatancy = phi) that makes the horizontal plane the Coulomb
    plane: tau_xy = c + s_n tan(phi) (Davis 1968: tau / s_n = sin phi cos psi / (1 - sin phi sin psi)), and
    the Mohr circle touches the Mohr-Coulomb line."""
    phi, s_n = np.radians(mat.friction_angle), L
    stress = mixed_control(mat, 60, lambda i: {0: 0.0, 3: (i + 1) * 5e-3}, [1], [-s_n])
    assert stress[0, 3] == pytest.approx(mat.cohesion + s_n * np.tan(phi), rel=1e-9)
    centre, radius = principal_in_plane(stress)
    assert radius[0] == pytest.approx(mat.cohesion * np.cos(phi) - centre[0] * np.sin(phi), rel=1e-9)


@pytest.mark.parametrize("cohesion", [1e3, 20e3, 100e3])
def test_pure_shear_with_zero_friction_gives_tau_equal_to_cohesion(cohesion):
    """phi = 0, eps_xx = eps_yy = 0, gamma driven: tau = G gamma until tau = c, then tau = c (sigma = 0 else)."""
    mat = MohrCoulomb(E, 0.3, 0.0, cohesion)
    g = moduli(mat)[1]
    gammas = np.linspace(0, 4 * cohesion / g, 41)
    plastic, taus = np.zeros((1, 4)), []
    for gamma in gammas:
        stress, _, plastic = return_map(mat, np.array([[0, 0, 0, gamma]]), plastic)
        taus.append(stress[0, 3])
        np.testing.assert_allclose(stress[0, :3], 0.0, atol=1e-12 * cohesion)
    np.testing.assert_allclose(taus, np.minimum(g * gammas, cohesion), rtol=1e-12, atol=1e-12 * cohesion)


@material_cases
def test_deviatoric_loading_at_constant_mean_stress_reaches_the_cone(mat):
    """gamma_xy driven with eps_xx = eps_yy adjusted (root finding, no tangent) so that p = p0 throughout:
    sqrt(J2) grows elastically (q = G gamma_xy-part) and then stays exactly at k - alpha I1 = k - 3 alpha p0."""
    alpha, k, _, _ = strength(mat)
    p0 = -L
    limit = k - 3 * alpha * p0
    plastic, qs = np.zeros((1, 4)), []
    for gamma in np.linspace(0, 6 * limit / moduli(mat)[1], 31):
        def mean_stress_error(e0):
            return return_map(mat, np.array([[e0, e0, 0.0, gamma]]), plastic)[0][0, :3].mean() - p0
        e0 = brentq(mean_stress_error, -0.1, 0.1, xtol=1e-18, rtol=1e-15)
        stress, _, plastic = return_map(mat, np.array([[e0, e0, 0.0, gamma]]), plastic)
        assert stress[0, :3].mean() == pytest.approx(p0, rel=1e-10)
        qs.append(invariants(stress)[2][0])
    qs = np.array(qs)
    assert np.all(qs <= limit * (1 + 1e-10))
    np.testing.assert_allclose(qs[-10:], limit, rtol=1e-10)


@pytest.mark.parametrize("mat", [*MATERIALS.values(), MohrCoulomb(E, 0.3, 0.0, 0.0), MohrCoulomb(E, 0.3, 50, 0.0)],
                         ids=[*MATERIALS.keys(), "no-strength", "sand-phi50"])
def test_volumetric_extension_returns_to_the_cutoff_or_apex(mat):
    """Isotropic extension (eps_xx = eps_yy = eps_zz) far beyond the cut-off: sigma = min(sigma_t, apex) I.
    Plane-strain extension (eps_zz = 0): p = min(sigma_t, apex) and sqrt(J2) <= the corner radius (= 0 at
    the apex, i.e. zero deviator)."""
    _, _, p_max, r_corner = strength(mat)
    e = 10 * L / E
    stress, _, _ = return_map(mat, np.array([[e, e, e, 0.0], [e, e, 0.0, 0.0]]), np.zeros((2, 4)))
    np.testing.assert_allclose(stress[0], p_max * M, rtol=0, atol=1e-10 * L)
    p, _, q = invariants(stress[1:])
    assert p[0] == pytest.approx(p_max, abs=1e-10 * L)
    assert q[0] <= r_corner + 1e-10 * L


@pytest.mark.parametrize("mat", [MohrCoulomb(E, 0.3, 0.0, 0.0), MohrCoulomb(E, 0.3, 50.0, 0.0),
                                 MohrCoulomb(E, 0.0, 0.0, 1e3, 1e6), MohrCoulomb(E, 0.49, 45.0, 0.0, 1e3)],
                         ids=["no-strength", "sand-phi50", "tresca-nu0", "nu049-cut"])
def test_degenerate_materials_stay_finite_and_admissible(mat):
    strain, plastic = random_states(mat, 2000, seed=6)
    stress, tangent, new_plastic = return_map(mat, strain, plastic)
    assert np.isfinite(stress).all() and np.isfinite(tangent).all() and np.isfinite(new_plastic).all()
    assert cone(mat, stress).max() <= 1e-8 * L
    assert stress[:, :3].mean(axis=1).max() <= mat.tension_cutoff + 1e-8 * L
    np.testing.assert_allclose(stress, hooke(mat, strain - new_plastic), rtol=0, atol=1e-9 * L)


# ---- non-associated flow (dilation angle psi < phi) ----------------------------------------------------
DILATANT = {f"phi{phi:g}-psi{psi:g}-c{c / 1e3:g}k": MohrCoulomb(E, 0.3, phi, c, dilation_angle=psi)
            for phi, c in ((30.0, 5e3), (35.0, 0.0), (20.0, 10e3)) for psi in (0.0, phi / 2)}
dilatant_cases = pytest.mark.parametrize("mat", DILATANT.values(), ids=DILATANT.keys())


@dilatant_cases
def test_biaxial_compression_strength_does_not_depend_on_the_dilation_angle(mat):
    """The cone is matched to Mohr-Coulomb in plane strain for every psi: the biaxial test's passive limit
    sigma_yy = -(s_c (1 + sin phi) + 2 c cos phi) / (1 - sin phi) is reached with psi = 0 and phi/2 too."""
    phi, s_c = np.radians(mat.friction_angle), L
    stress = mixed_control(mat, 60, lambda i: {1: -(i + 1) * 5e-3}, [0], [-s_c])
    expected = -(s_c * (1 + np.sin(phi)) + 2 * mat.cohesion * np.cos(phi)) / (1 - np.sin(phi))
    assert stress[0, 1] == pytest.approx(expected, rel=1e-9)


@dilatant_cases
def test_simple_shear_strength_with_dilation_is_davis(mat):
    """Simple shear under a constant normal stress s_n, x not extending: Davis (1968) for plane-strain flow with
    dilation angle psi gives tau = (c cos phi cos psi + s_n sin phi cos psi) / (1 - sin phi sin psi), the
    associated Coulomb value c + s_n tan(phi) at psi = phi and less for psi < phi."""
    phi, psi, s_n = np.radians(mat.friction_angle), np.radians(mat.dilation_angle), L
    stress = mixed_control(mat, 80, lambda i: {0: 0.0, 3: (i + 1) * 5e-3}, [1], [-s_n])
    expected = (mat.cohesion * np.cos(phi) + s_n * np.sin(phi)) * np.cos(psi) / (1 - np.sin(phi) * np.sin(psi))
    assert stress[0, 3] == pytest.approx(expected, rel=1e-9)


@dilatant_cases
def test_plastic_volume_change_follows_the_dilation_angle(mat):
    """In plane-strain flow on the cone the plastic strain increment has volumetric part / principal difference
    = -sin(psi) (tension positive: dilation under shear), i.e. no plastic volume change at psi = 0."""
    psi = np.radians(mat.dilation_angle)
    strain, plastic, states = np.zeros((1, 4)), np.zeros((1, 4)), []
    for i in range(60):  # simple shear in steps of 5e-3, sigma_yy = -L held by Newton on eps_yy
        strain[0, 3] = (i + 1) * 5e-3
        for _ in range(20):
            stress, tangent, new_plastic = return_map(mat, strain, plastic)
            strain[0, 1] -= (stress[0, 1] + L) / tangent[0, 1, 1]
        plastic = new_plastic
        states.append(plastic[0].copy())
    d = states[-1] - states[-2]  # one step of steady flow
    radius = np.sqrt(((d[0] - d[1]) / 2) ** 2 + (d[3] / 2) ** 2)  # engineering shear -> tensor
    assert abs(d[2]) < 1e-12 * radius
    assert (d[0] + d[1]) / (2 * radius) == pytest.approx(np.sin(psi), abs=1e-9)


@dilatant_cases
def test_non_associated_tangent_is_the_derivative_and_unsymmetric(mat):
    """Random plastic states: the consistent tangent equals central differences of the returned stress (step and
    tolerance as for the associated regimes), and is unsymmetric on the cone."""
    rng = np.random.default_rng(11)
    strain = rng.normal(0, 2 * L / E, (200, 4))
    strain[:, 2] = 0.0
    strain[:, :2] -= 3 * L / E  # mostly compressed: cone returns
    plastic = np.zeros_like(strain)
    stress, tangent, _ = return_map(mat, strain, plastic)
    on_cone = np.abs(cone_of(mat, stress)) < 1e-9 * L
    assert_tangent_is_the_derivative(mat, strain, plastic, tangent, 1e-5 * E)
    asymmetry = np.abs(tangent - tangent.transpose(0, 2, 1)).max(axis=(1, 2))
    assert on_cone.sum() > 20 and np.median(asymmetry[on_cone]) > 1e-3 * E


def cone_of(mat, stress):
    """The cone f = q + 3 alpha p - k with the psi-dependent plane-strain match (module docstring of plasticity):
    alpha = beta sin(phi) / 3, k = beta c cos(phi), beta = 1 / (sqrt(1 - 3 a^2) + a sin(phi)), a = alpha_psi."""
    phi, psi = np.radians(mat.friction_angle), np.radians(mat.dilation_angle)
    a = np.tan(psi) / np.sqrt(9 + 12 * np.tan(psi) ** 2)
    beta = 1 / (np.sqrt(1 - 3 * a * a) + a * np.sin(phi))
    p, _, q = invariants(stress)
    return q + beta * np.sin(phi) * p - beta * mat.cohesion * np.cos(phi)


# ---- hyperbolic apex smoothing (Abbo & Sloan 1995), used for a cohesionless soil's N_gamma ------------------
SMOOTHED = {
    "sand-phi30": MohrCoulomb(E, 0.3, 30.0, 0.0, 0.0, apex_smoothing=0.02 * L),
    "phi35-c10k-psi10": MohrCoulomb(E, 0.3, 35.0, 10e3, 1e12, dilation_angle=10.0, apex_smoothing=0.05 * L),
    "phi20-psi5": MohrCoulomb(E, 0.3, 20.0, 0.0, 0.0, dilation_angle=5.0, apex_smoothing=1e3),
}
smoothed_cases = pytest.mark.parametrize("mat", SMOOTHED.values(), ids=SMOOTHED.keys())


def hyperbola(mat, stress):
    """f = sqrt(J2 + a^2) + alpha_phi,psi I1 - k with the plane-strain match of ``cone_of``."""
    phi = np.radians(mat.friction_angle)
    psi = np.radians(mat.friction_angle if mat.dilation_angle is None else mat.dilation_angle)
    a = np.tan(psi) / np.sqrt(9 + 12 * np.tan(psi) ** 2)
    beta = 1 / (np.sqrt(1 - 3 * a * a) + a * np.sin(phi))
    p, _, q = invariants(stress)
    return np.sqrt(q * q + mat.apex_smoothing ** 2) + beta * np.sin(phi) * p - beta * mat.cohesion * np.cos(phi)


@smoothed_cases
def test_smoothed_return_lands_on_the_hyperbola_and_keeps_elastic_states(mat):
    """Random trial states (all regions, beyond the tip too): admissible (f <= 0); a plastic point lands on f = 0
    with its deviator parallel to the trial's; an elastic one keeps its trial stress."""
    strain, plastic = random_states(mat, 400, 21)
    trial = hooke(mat, strain - plastic)
    stress, _, _ = return_map(mat, strain, plastic)
    f_trial, f = hyperbola(mat, trial), hyperbola(mat, stress)
    assert np.all(f <= 1e-9 * L)
    yielding = f_trial > 0
    assert yielding.sum() > 20 and (~yielding).sum() > 20
    np.testing.assert_allclose(f[yielding], 0.0, atol=1e-9 * L)
    np.testing.assert_allclose(stress[~yielding], trial[~yielding], rtol=0, atol=1e-9 * L)
    _, s_trial, q_trial = invariants(trial)
    _, s, q = invariants(stress)
    cross = s * q_trial[:, None] - s_trial * q[:, None]  # parallel deviators
    assert np.abs(cross[yielding]).max() <= 1e-8 * L * max(q_trial.max(), L)


@smoothed_cases
def test_smoothed_tangent_is_the_derivative(mat):
    """Random states: the consistent tangent equals central differences of the returned stress (as above)."""
    strain, plastic = random_states(mat, 300, 3)
    _, tangent, _ = return_map(mat, strain, plastic)
    assert_tangent_is_the_derivative(mat, strain, plastic, tangent, 1e-6 * E)


def test_smoothing_vanishes_away_from_the_apex():
    """Far from the apex the hyperbola differs from the cone by a^2 / (2 sqrt(J2)): a return of a strongly
    compressed, sheared state moves by that order only."""
    cone = MohrCoulomb(E, 0.3, 30.0, 0.0, 0.0)
    rng = np.random.default_rng(4)
    trial = rng.uniform(1, 3, (100, 1)) * L * unit_deviators(rng, 100) - rng.uniform(2, 4, (100, 1)) * L * M
    strain, plastic = strain_for_trial(cone, trial, np.zeros((100, 4)))
    exact, _, _ = return_map(cone, strain, plastic)
    far = invariants(exact)[0] < -0.5 * L  # returned onto the cone's face, not to its apex
    assert far.sum() > 50
    for a in (1e-2 * L, 1e-3 * L):
        smooth, _, _ = return_map(MohrCoulomb(E, 0.3, 30.0, 0.0, 0.0, apex_smoothing=a), strain, plastic)
        assert np.abs(smooth - exact)[far].max() < 10 * a * a / L


@pytest.mark.parametrize("kwargs", [dict(friction_angle=0.0, cohesion=1e4), dict(friction_angle=30.0,
                                                                                   cohesion=1e4),
                                    dict(friction_angle=30.0, cohesion=0.0, dilation_angle=0.0)],
                         ids=["no-apex", "cutoff-inside-tip", "no-dilation"])
def test_smoothing_rejects_what_it_cannot_return(kwargs):
    with pytest.raises(ValueError):
        MohrCoulomb(E, 0.3, tension_cutoff=0.0, apex_smoothing=0.1 * L, **kwargs)
