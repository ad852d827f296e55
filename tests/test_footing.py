"""The fill's constitutive model calibrated on closed-form collapse loads, independently of the arch
(bridgefem.fe.footing: the plasticity module's return map on a plain soil box, displacement control, Newton).

References (all associated flow, psi = phi, which the bound theorems and the closed forms assume):
- Rankine: a smooth wall moved into / away from a soil column with weight; the column reaches a homogeneous
  limit state that P2 displacements represent exactly, so the force must match to round-off and plateau.
- Prandtl (1920): a rigid strip footing on a weightless soil, q = c N_c, the same for rough and smooth bases.
  Measured convergence of the collapse pressure on the graded P2 meshes of :func:`strip_footing` (B = 2 m,
  box 6B x 3B, E = 1e4 c, settlement 0.005 B (phi = 0) or 0.02 B (phi = 30) in 40 increments):

  | phi | base | cells/side 8 | 16 | 32 | Richardson (8-16-32) |
  |---|---|---|---|---|---|
  | 0 | smooth | 1.091 | 1.027 | 1.008 | 1.000 (order 1.75) |
  | 0 | rough | 1.120 | 1.038 | | |
  | 30 | smooth | 1.094 | 1.032 | 1.011 | 1.000 (order 1.53) |
  | 30 | rough | 1.153 | 1.063 | 1.029 | 1.010 (order 1.44) |

  so the tests run 16 cells per side and allow the measured 16-cell error plus 1 %. The same mesh with P1
  displacements overestimates N_c by 28 % at phi = 0: linear triangles lock under plastic flow (Sloan &
  Randolph 1982), which is why the fill needs quadratic elements.
- Martin (2005), method of characteristics: a rigid rough strip footing on a cohesionless soil with weight,
  q = gamma B N_gamma / 2, N_gamma = 14.75 at phi = 30 deg (cited, bridgefem.fe.footing.MARTIN_N_GAMMA); the FE reaches
  c = 0 through two vanishing cohesions on a cone with a smoothed apex (bridgefem.fe.footing.cohesionless_n_gamma).
  Its mesh convergence (8-16-32 cells) is benchmarks/footing_convergence.py.
"""
import numpy as np
import pytest

from bridgefem.fe.footing import (
    MARTIN_N_GAMMA,
    cohesionless_n_gamma,
    graded,
    prandtl_nc,
    rankine_coefficient,
    retaining_wall,
    strip_footing,
)
from bridgefem.laws.soil import MohrCoulomb

GAMMA = 18e3  # N/m^3
C = 10e3  # Pa


def test_prandtl_factor_closed_form():
    """N_c(0) = 2 + pi; N_c(30) = 30.14 (Prandtl's tabulated value); N_c -> 2 + pi as phi -> 0."""
    assert prandtl_nc(0.0) == pytest.approx(5.1416, abs=1e-4)
    assert prandtl_nc(30.0) == pytest.approx(30.14, abs=0.01)
    assert prandtl_nc(1e-6) == pytest.approx(2 + np.pi, rel=1e-5)


def test_graded_grid_puts_a_line_at_the_footing_edge():
    x = graded(16, 12.0, 1.0, 2.0)
    assert len(x) == 17 and x[0] == 0 and x[-1] == pytest.approx(12.0) and np.all(np.diff(x) > 0)
    assert np.min(np.abs(x - 1.0)) < 1e-12
    edge = np.argmin(np.abs(x - 1.0))
    assert np.diff(x)[edge - 1] < np.diff(x).mean() / 4 and np.diff(x)[edge] < np.diff(x).mean() / 4


@pytest.mark.parametrize("passive,cohesion", [(True, 0.0), (False, 0.0), (True, 5e3)],
                         ids=["passive", "active", "passive-c5k"])
def test_smooth_wall_reaches_rankine(passive, cohesion):
    """Wall force per metre: K_p gamma H^2 / 2 + 2 c sqrt(K_p) H, or K_a gamma H^2 / 2 (c = 0), phi = 30 deg."""
    height = 2.0
    soil = MohrCoulomb(20e6, 0.3, 30.0, cohesion)
    result = retaining_wall(soil, height, GAMMA, passive, cells=4, movement=0.02, steps=10)
    k = rankine_coefficient(30.0, passive)
    expected = 0.5 * k * GAMMA * height ** 2 + (2 * cohesion * np.sqrt(k) * height if passive else 0.0)
    assert result.limit == pytest.approx(expected, rel=1e-5)
    assert abs(result.plateau) < 1e-4


def footing(phi, rough, degree=2, cells=16):
    soil = MohrCoulomb(1e4 * C, 0.3, phi, C, tension_cutoff=1e12)  # weightless: no cut-off in the way
    return strip_footing(soil, 2.0, rough, cells, degree, settlement=0.005 if phi == 0 else 0.02, steps=40)


@pytest.mark.slow
@pytest.mark.parametrize("rough,measured", [(False, 0.027), (True, 0.038)], ids=["smooth", "rough"])
def test_tresca_footing_reaches_prandtl(rough, measured):
    """phi = 0: q / c -> 2 + pi; measured 1.027 x (smooth) and 1.038 x (rough) on 16 cells per side, converging
    from above (a displacement method overstates the collapse load)."""
    result = footing(0.0, rough)
    assert 1.0 < result.limit / C / prandtl_nc(0.0) < 1.0 + measured + 0.01
    assert result.plateau < 0.005


@pytest.mark.slow
@pytest.mark.parametrize("rough,measured", [(False, 0.032), (True, 0.063)], ids=["smooth", "rough"])
def test_frictional_footing_reaches_prandtl(rough, measured):
    """phi = 30 deg: q / c -> N_c = 30.14; measured 1.032 x (smooth) and 1.063 x (rough) on 16 cells per side,
    converging from above (docs/fill.md has the finer meshes)."""
    result = footing(30.0, rough)
    assert 1.0 < result.limit / C / prandtl_nc(30.0) < 1.0 + measured + 0.01
    assert result.plateau < 0.01


@pytest.mark.slow
def test_linear_triangles_lock():
    """The same mesh with P1 displacements overstates N_c by far more than P2 (Sloan & Randolph 1982)."""
    p1 = footing(0.0, False, degree=1)
    assert p1.limit / C > 1.15 * prandtl_nc(0.0)


@pytest.mark.slow
def test_cohesionless_rough_footing_approaches_martin_n_gamma():
    """phi = 30 deg, c = 0 (cohesionless_n_gamma: two vanishing cohesions on the smoothed cone, extrapolated):
    N_gamma = 14.75 (Martin 2005, rough) approached from above on 8 cells per side, pushed to 0.25 B in 50 steps
    (the increment of the 0.2 B / 40 steps of the finer meshes; on 8 cells the curve still rises 1.1 % over the last
    quarter at 0.2 B, 0.9 % at 0.25 B): measured 1.384 x; the test allows that error plus 2 % against the published
    value, so a mesh that overshoots it by more, or falls below it, fails. The convergence study itself (8, 16,
    32 cells: 1.374, 1.163, 1.087 x at 0.2 B, each halving of the cells at least halving the distance to Martin's
    value) is benchmarks/footing_convergence.py (docs/fill.md)."""
    n_gamma, runs = cohesionless_n_gamma(30.0, True, 8, settlement=0.25, steps=50)
    assert 1.0 < n_gamma / MARTIN_N_GAMMA[30.0][0] < 1.384 + 0.02
    assert max(r.plateau for r in runs) < 0.01
