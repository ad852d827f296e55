"""Elastic-perfectly-plastic backfill soil at quadrature points (plane strain, pure numpy, vectorised).

Material: isotropic linear elasticity (Young's modulus E, Poisson's ratio nu) with a Drucker-Prager cone
(Drucker & Prager 1952) matched to Mohr-Coulomb in plane strain, plus a tension cut-off on the mean stress:

- cone: ``f = sqrt(J2) + alpha I1 - k <= 0`` with ``alpha = tan(phi) / sqrt(9 + 12 tan^2 phi)`` and
  ``k = 3 c / sqrt(9 + 12 tan^2 phi)``; in the notation of de Souza Neto, Peric & Owen, *Computational
  Methods for Plasticity* (Wiley 2008), chapter 6 (Drucker-Prager approximations of Mohr-Coulomb,
  "plane strain match") this is ``sqrt(J2) + eta p - xi c`` with ``eta = 3 alpha``, ``xi c = k``;
- cut-off: ``p = I1 / 3 <= sigma_t`` (``tension_cutoff``; 0 = no-tension soil).

Plastic flow on the cone follows the potential ``g = sqrt(J2) + alpha_psi I1`` with the dilation angle psi
(``alpha_psi`` = the formula of alpha with psi for phi): associated (psi = phi) by default, non-associated for
0 <= psi < phi; on the cut-off the flow is volumetric. No hardening.

Why the cone is *the* plane-strain match. At plane-strain collapse the plastic out-of-plane strain rate is zero:
``s_zz = -2 alpha_psi q`` with ``q = sqrt(J2)``. Writing the in-plane principal stresses ``s1 >= s3`` with
centre ``m = (s1 + s3)/2`` and radius ``R = (s1 - s3)/2``, that gives ``q = R / sqrt(1 - 3 alpha_psi^2)`` and
``p = m - alpha_psi q``, so ``f = 0`` becomes ``R beta^-1 + 3 alpha m = k`` with
``beta = 1 / (sqrt(1 - 3 alpha_psi^2) + alpha_psi sin(phi))``, the Mohr-Coulomb criterion
``R = c cos(phi) - m sin(phi)`` exactly when ``alpha = beta sin(phi) / 3`` and ``k = beta c cos(phi)``.
Associated (psi = phi) this is ``alpha = tan(phi) / sqrt(9 + 12 tan^2 phi)`` (above); psi = 0 gives
``alpha = sin(phi) / 3``, ``k = c cos(phi)``. So the cone gives the Mohr-Coulomb plane-strain strength whatever
psi, and with psi = phi the Mohr-Coulomb plane-strain collapse loads of the bound theorems.
phi = 0 is the plane-strain match of Tresca (von Mises with ``sqrt(J2) <= c``); c = 0 a cohesionless soil.

Conventions: SI units (Pa, strain dimensionless), tension positive (soil under self-weight has negative
stresses). Stresses and strains are 4-vectors ``[xx, yy, zz, xy]``; the strain vector carries the
*engineering* shear strain ``gamma_xy = 2 eps_xy`` and ``eps_zz = 0`` in plane strain, while ``sigma_zz`` is
tracked. Tangents are 3x3 on the in-plane Voigt components ``[xx, yy, xy]`` with engineering shear, so that
``d sigma = D d strain``.

The return map is the closest-point projection in the energy norm (associated; along the potential's normal
otherwise), integrated by backward Euler in one step
(exact for perfect plasticity with a linear flow vector): elastic, return to the smooth cone, to the
cap ``p = sigma_t`` (deviator kept), or to the corner where the cap meets the cone (deviator scaled to the
cone radius). If ``sigma_t`` is at or beyond the cone apex ``p = c cot(phi)``, the corner is the apex itself
(zero deviator), the usual Drucker-Prager apex return (de Souza Neto et al. 2008, chapter 8).

Apex smoothing (``apex_smoothing`` a > 0, Pa; off by default): the cone is replaced by the hyperboloid
``sqrt(J2 + a^2) + alpha I1 - k <= 0`` (Abbo & Sloan 1995, "A smooth hyperbolic approximation to the Mohr-Coulomb
yield criterion", Computers & Structures 54:427), which lies inside the cone, approaches it as ``sqrt(J2)`` grows
(by ``a^2 / (2 sqrt(J2))``) and has a smooth tip on the hydrostatic axis at ``p = (k - a) / (3 alpha)``, where the
cone has its apex. It is meant for a cohesionless soil (c = 0), whose unloaded surface sits at the cone's apex and
stalls Newton's method there. The return is the same backward-Euler step onto the smooth surface, a scalar
equation for the multiplier solved per point by a safeguarded Newton iteration, with its consistent tangent; the
cut-off must then lie beyond the tip (it is never reached).
"""
from __future__ import annotations

from dataclasses import dataclass
from math import cos, isfinite, radians, sin, sqrt, tan

import numpy as np

_M = np.array([1.0, 1.0, 1.0, 0.0])  # second-order identity as a stress-like 4-vector
_TENSOR_SHEAR = np.array([1.0, 1.0, 1.0, 0.5])  # engineering -> tensor strain components
# Tensor -> engineering strain components; also the weights of a:b = sum(w a b) for tensor 4-vectors.
_ENGINEERING = np.array([1.0, 1.0, 1.0, 2.0])
_IN_PLANE = [0, 1, 3]
# Deviatoric projector mapping an engineering strain 4-vector to the tensor deviatoric strain components.
_DEV = np.diag(_TENSOR_SHEAR) - np.outer(_M, _M) / 3.0


@dataclass(frozen=True)
class MohrCoulomb:
    """Backfill soil: elasticity, plane-strain matched Drucker-Prager cone and mean-stress cut-off.

    ``young`` (Pa), ``poisson`` (-), ``friction_angle`` phi (degrees, 0 <= phi < 90), ``cohesion`` c (Pa),
    ``tension_cutoff`` sigma_t >= 0 (Pa), the limit of the mean stress ``p = tr(sigma)/3`` (tension positive),
    ``dilation_angle`` psi (degrees, 0 <= psi <= phi; None: psi = phi, associated flow), ``apex_smoothing`` a
    (Pa, >= 0; 0: the exact cone) of the hyperbolic surface ``sqrt(J2 + a^2) + alpha I1 - k`` (module docstring).
    """

    young: float
    poisson: float
    friction_angle: float
    cohesion: float
    tension_cutoff: float = 0.0
    dilation_angle: float | None = None
    apex_smoothing: float = 0.0

    def __post_init__(self):
        values = (self.young, self.poisson, self.friction_angle, self.cohesion, self.tension_cutoff)
        if not all(isfinite(v) for v in values):
            raise ValueError(f"material parameters must be finite, got {values}")
        if self.young <= 0 or not -1.0 < self.poisson < 0.5:
            raise ValueError(f"need young > 0 and -1 < poisson < 0.5, got {self.young}, {self.poisson}")
        if not 0.0 <= self.friction_angle < 90.0:
            raise ValueError(f"need 0 <= friction_angle < 90 degrees, got {self.friction_angle}")
        if self.dilation_angle is not None and not 0.0 <= self.dilation_angle <= self.friction_angle:
            raise ValueError(f"need 0 <= dilation_angle <= friction_angle, got {self.dilation_angle}")
        if self.cohesion < 0 or self.tension_cutoff < 0:
            raise ValueError(f"need cohesion >= 0 and tension_cutoff >= 0, got {self.cohesion}, "
                             f"{self.tension_cutoff}")
        a = self.apex_smoothing
        if not isfinite(a) or a < 0:
            raise ValueError(f"need apex_smoothing >= 0, got {a}")
        if a > 0 and self.alpha_dilation == 0:
            raise ValueError("apex_smoothing needs friction and dilation angles > 0 (a cone with an apex, and a "
                             "state beyond the tip returns along the potential's volumetric part)")
        if a > 0 and self.tension_cutoff < self.smoothed_tip:
            raise ValueError(f"with apex_smoothing the tension_cutoff ({self.tension_cutoff}) must lie beyond the "
                             f"smoothed tip p = {self.smoothed_tip:g} Pa")

    @property
    def shear_modulus(self) -> float:
        """G = E / (2 (1 + nu)) (Pa)."""
        return self.young / (2.0 * (1.0 + self.poisson))

    @property
    def bulk_modulus(self) -> float:
        """K = E / (3 (1 - 2 nu)) (Pa)."""
        return self.young / (3.0 * (1.0 - 2.0 * self.poisson))

    @property
    def lame_lambda(self) -> float:
        """lambda = K - 2 G / 3 (Pa)."""
        return self.bulk_modulus - 2.0 * self.shear_modulus / 3.0

    @property
    def alpha_dilation(self) -> float:
        """Slope alpha_psi = tan(psi) / sqrt(9 + 12 tan^2 psi) (-) of the plastic potential."""
        psi = self.friction_angle if self.dilation_angle is None else self.dilation_angle
        t = tan(radians(psi))
        return t / sqrt(9.0 + 12.0 * t * t)

    @property
    def _beta(self) -> float:
        """beta = 1 / (sqrt(1 - 3 alpha_psi^2) + alpha_psi sin(phi)) of the plane-strain match (module docstring)."""
        a = self.alpha_dilation
        return 1.0 / (sqrt(1.0 - 3.0 * a * a) + a * sin(radians(self.friction_angle)))

    @property
    def alpha(self) -> float:
        """Cone slope alpha = beta sin(phi) / 3 (-), multiplying I1 = tr(sigma); tan(phi) / sqrt(9 + 12 tan^2 phi)
        when associated."""
        return self._beta * sin(radians(self.friction_angle)) / 3.0

    @property
    def k(self) -> float:
        """Cone intercept k = beta c cos(phi) (Pa), the limit of sqrt(J2) at I1 = 0; 3 c / sqrt(9 + 12 tan^2 phi)
        when associated."""
        return self._beta * self.cohesion * cos(radians(self.friction_angle))

    @property
    def smoothed_tip(self) -> float:
        """Mean stress (Pa) of the hyperbolic surface's tip ``(k - a) / (3 alpha)`` (phi > 0)."""
        return (self.k - self.apex_smoothing) / (3.0 * self.alpha)

    @property
    def mean_stress_limit(self) -> float:
        """Largest admissible mean stress (Pa): the cut-off sigma_t or the cone apex c cot(phi) if smaller."""
        if self.alpha == 0.0:
            return self.tension_cutoff
        return min(self.tension_cutoff, self.k / (3.0 * self.alpha))


def elastic_tangent(material: MohrCoulomb) -> np.ndarray:
    """Plane-strain Hooke matrix (3, 3) (Pa) on ``[xx, yy, xy]`` with engineering shear strain."""
    lam, g = material.lame_lambda, material.shear_modulus
    return np.array([[lam + 2 * g, lam, 0.0], [lam, lam + 2 * g, 0.0], [0.0, 0.0, g]])


def return_map(material: MohrCoulomb, strain: np.ndarray, plastic_strain: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stress, consistent tangent and plastic strain after one backward-Euler step at n points.

    ``strain``: total strain (n, 4) ``[exx, eyy, ezz (= 0 in plane strain), gamma_xy]`` (engineering shear);
    ``plastic_strain``: (n, 4) converged plastic strain of the last load step, same layout. Returns the stress (n, 4)
    ``[sxx, syy, szz, sxy]`` (Pa, tension positive), the consistent (algorithmic) tangent (n, 3, 3) ``d[sxx, syy, sxy] /
    d[exx, eyy, gamma_xy]`` (Pa) and the updated plastic strain (n, 4). The tangent is unsymmetric on the cone if the
    flow is non-associated, singular off the smooth cone: no bulk stiffness on the cut-off, zero at the apex (a stress
    held at a fixed vertex of the elastic domain); a global solver needs elastic neighbours or regularisation where
    whole regions sit there.
    """
    strain = np.asarray(strain, dtype=float)
    plastic_strain = np.asarray(plastic_strain, dtype=float)
    if strain.ndim != 2 or strain.shape[1] != 4 or plastic_strain.shape != strain.shape:
        raise ValueError(f"strain and plastic_strain must both be (n, 4), got {strain.shape} and "
                         f"{plastic_strain.shape}")
    g, bulk, alpha, k = material.shear_modulus, material.bulk_modulus, material.alpha, material.k
    alpha_g = material.alpha_dilation
    p_max = material.mean_stress_limit
    r_corner = k - 3.0 * alpha * p_max  # sqrt(J2) where the cap meets the cone (0 at the apex)

    # Elastic predictor: trial deviator s_tr, mean stress p_tr and q_tr = sqrt(J2_tr).
    elastic = (strain - plastic_strain) * _TENSOR_SHEAR
    volumetric = elastic[:, :3].sum(axis=1)
    p_tr = bulk * volumetric
    s_tr = 2.0 * g * (elastic - volumetric[:, None] / 3.0 * _M)
    q_tr = np.sqrt(0.5 * (_ENGINEERING * s_tr * s_tr).sum(axis=1))
    if material.apex_smoothing > 0.0:
        return _smoothed_return(material, s_tr, p_tr, q_tr, plastic_strain)
    f_tr = q_tr + 3.0 * alpha * p_tr - k

    # Regime selection: disjoint regions of the trial state (normal cones of the closest-point projection).
    h_cone = g + 9.0 * bulk * alpha * alpha_g
    d_gamma = np.maximum(f_tr, 0.0) / h_cone  # cone multiplier (valid where the cone return applies)
    p_cone = p_tr - 3.0 * bulk * alpha_g * d_gamma
    cone = (f_tr > 0.0) & (p_cone <= p_max)
    cap = ~cone & (p_tr > p_max) & (q_tr <= r_corner)
    corner = ~cone & ~cap & ((f_tr > 0.0) | (p_tr > p_max))

    q_safe = np.where(q_tr > 0.0, q_tr, 1.0)
    beta = np.where(cone, g * d_gamma / q_safe, 0.0)  # fraction of the trial deviator removed on the cone
    rho = np.where(q_tr > 0.0, r_corner / q_safe, 0.0)  # corner: deviator scaled to the corner radius
    scale = np.select([cone, corner], [1.0 - beta, rho], 1.0)
    p = np.select([cone, cap | corner], [p_cone, p_max], p_tr)
    stress = scale[:, None] * s_tr + p[:, None] * _M

    # Plastic strain increment = elastic compliance applied to (trial stress - stress); exactly 0 if elastic.
    d_plastic = ((1.0 - scale)[:, None] * s_tr / (2.0 * g) + ((p_tr - p) / (3.0 * bulk))[:, None] * _M)
    new_plastic = plastic_strain + d_plastic * _ENGINEERING

    # Consistent tangent D = a 2G Idev + b N N + c h_g h_f + d K m m with the unit trial direction N, in which
    #   cone:   a = 1 - beta, b = 2G beta, c = -1/(G + 9 K alpha alpha_psi), h_f = sqrt(2) G N + 3 alpha K m
    #           (yield normal) and h_g the same with alpha_psi (flow direction), d = 1;
    #   cap:    a = 1, d = 0 (p fixed);   corner: a = rho, b = -2G rho, d = 0;   elastic: a = 1, d = 1.
    unit = s_tr / (np.sqrt(2.0) * q_safe)[:, None]
    h_f = np.sqrt(2.0) * g * unit + 3.0 * alpha * bulk * _M
    h_g = np.sqrt(2.0) * g * unit + 3.0 * alpha_g * bulk * _M
    b = np.select([cone, corner], [2.0 * g * beta, -2.0 * g * rho], 0.0)
    c = np.where(cone, -1.0 / h_cone, 0.0)
    d = np.where(cap | corner, 0.0, 1.0)
    ip = _IN_PLANE
    unit, h_f, h_g = unit[:, ip], h_f[:, ip], h_g[:, ip]
    tangent = (scale[:, None, None] * (2.0 * g * _DEV[np.ix_(ip, ip)])  # a = scale
               + b[:, None, None] * unit[:, :, None] * unit[:, None, :]
               + c[:, None, None] * h_g[:, :, None] * h_f[:, None, :]
               + d[:, None, None] * (bulk * np.outer(_M[ip], _M[ip])))
    return stress, tangent, new_plastic


def _smoothed_return(material: MohrCoulomb, s_tr: np.ndarray, p_tr: np.ndarray, q_tr: np.ndarray,
                     plastic_strain: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`return_map` onto the hyperbolic surface ``rho + 3 alpha p - k = 0``, ``rho = sqrt(q^2 + a^2)``.

    Backward Euler along the potential ``sqrt(J2 + a^2) + alpha_psi I1``: ``s = s_tr rho / (rho + G dg)``,
    ``p = p_tr - 3 K alpha_psi dg``; with ``rho = k - 3 alpha p_tr + H dg`` (``H = 9 K alpha alpha_psi``) the
    multiplier dg solves ``h(dg) = q (rho + G dg) / rho - q_tr = 0``, increasing from ``h <= 0`` at the smallest dg
    with ``rho >= a``: bisection-safeguarded Newton. The consistent tangent follows from differentiating the two
    equations in (q, dg) with respect to (q_tr, p_tr)."""
    g, bulk, alpha, k = material.shear_modulus, material.bulk_modulus, material.alpha, material.k
    alpha_g, a = material.alpha_dilation, material.apex_smoothing
    h_rate = 9.0 * bulk * alpha * alpha_g
    rho0 = k - 3.0 * alpha * p_tr
    plastic = np.sqrt(q_tr * q_tr + a * a) - rho0 > 0.0

    def residual(dg):
        rho = np.where(plastic, rho0 + h_rate * dg, 1.0)
        q = np.sqrt(np.maximum(rho * rho - a * a, 0.0))
        return np.where(plastic, q * (rho + g * dg) / rho - q_tr, 0.0), rho, q

    lo = np.where(plastic & (rho0 < a), (a - rho0) / max(h_rate, 1e-300), 0.0)
    hi = lo + (q_tr + a) / g
    for _ in range(200):  # grow the bracket until h(hi) >= 0 (h grows without bound with dg)
        bad = residual(hi)[0] < 0.0
        if not bad.any():
            break
        hi = np.where(bad, lo + 2.0 * (hi - lo), hi)
    dg = hi.copy()
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # infinite slope at the tip: bisect
        for _ in range(100):
            h, rho, q = residual(dg)
            if np.all(np.abs(h[plastic]) <= 1e-14 * (q_tr[plastic] + a)):
                break
            lo, hi = np.where(h < 0.0, dg, lo), np.where(h >= 0.0, dg, hi)
            slope = (h_rate * rho / q) * (rho + g * dg) / rho + q * g * (rho - h_rate * dg) / (rho * rho)
            step = dg - h / slope
            dg = np.where((step > lo) & (step < hi), step, 0.5 * (lo + hi))
    dg = np.where(plastic, dg, 0.0)
    rho = np.where(plastic, rho0 + h_rate * dg, 1.0)
    q = np.where(plastic, np.sqrt(np.maximum(rho * rho - a * a, 0.0)), q_tr)
    scale = np.where(plastic, rho / (rho + g * dg), 1.0)  # = q / q_tr, finite at q_tr = 0
    p = p_tr - 3.0 * bulk * alpha_g * dg
    stress = scale[:, None] * s_tr + p[:, None] * _M
    d_plastic = (1.0 - scale)[:, None] * s_tr / (2.0 * g) + ((p_tr - p) / (3.0 * bulk))[:, None] * _M
    new_plastic = plastic_strain + d_plastic * _ENGINEERING

    # d q and d dg from (q/rho) dq - H d dg = -3 alpha dp_tr and A dq + q G d dg = rho dq_tr, with
    # A = rho + G dg + (q - q_tr) q / rho; dq_tr = sqrt(2) G N:de, dp_tr = K m:de (N the unit trial deviator).
    big = rho + g * dg + (q - q_tr) * q / rho
    det = np.where(plastic, q * q * g / rho + h_rate * big, 1.0)
    dq_n = np.where(plastic, h_rate * rho * np.sqrt(2.0) * g / det, np.sqrt(2.0) * g)  # dq = dq_n N:de + dq_m m:de
    dq_m = np.where(plastic, -3.0 * alpha * bulk * q * g / det, 0.0)
    dg_n = np.where(plastic, q * np.sqrt(2.0) * g / det, 0.0)  # d dg = dg_n N:de + dg_m m:de
    dg_m = np.where(plastic, 3.0 * alpha * bulk * big / det, 0.0)
    q_safe = np.where(q_tr > 0.0, q_tr, 1.0)
    unit = (s_tr / (np.sqrt(2.0) * q_safe)[:, None])[:, _IN_PLANE]
    m = _M[_IN_PLANE]
    # s = scale s_tr: ds = scale 2G Idev de + sqrt(2) N (dq - scale dq_tr); dp = K m:de - 3 K alpha_psi d dg
    dev_n = np.sqrt(2.0) * (dq_n - scale * np.sqrt(2.0) * g)
    tangent = (scale[:, None, None] * (2.0 * g * _DEV[np.ix_(_IN_PLANE, _IN_PLANE)])
               + unit[:, :, None] * (dev_n[:, None] * unit + np.sqrt(2.0) * dq_m[:, None] * m)[:, None, :]
               + m[None, :, None] * (bulk * m[None, :] - 3.0 * bulk * alpha_g * (dg_n[:, None] * unit
                                                                                 + dg_m[:, None] * m))[:, None, :])
    return stress, tangent, new_plastic
