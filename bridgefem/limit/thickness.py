"""The least thickness of a ring that carries its own weight (Heyman 1966, 1982), by the rigid-block LP.

Heyman's safe theorem: a ring of rigid voussoirs with no-tension joints that cannot slide stands if a thrust line in
equilibrium with its weight lies within the ring. At the least thickness a single such line remains, touching the
extrados and the intrados alternately at the hinges of a mechanism (Heyman 1966, *The stone skeleton*, Int. J.
Solids Struct. 2:249; Heyman 1982, *The Masonry Arch*, Ellis Horwood). For a semicircle with radial joints it is
``t/R = 0.1075``, R the centreline radius (Milankovitch's value; 0.107426 with the weight on the centreline,
Cocchetti & Rizzi 2020, Frattura ed Integrita Strutturale 51:356). With Coulomb friction the ring may slide
first: below a threshold friction (0.3958 for the semicircle) the least thickness grows, and below another
(0.3092) no thickness stands.

:func:`min_thickness` finds it for any shape and friction, with every other key of the scene fixed and no live
load:

1. a thickness stands when the dead-load deficit of its ring is zero
   (:func:`bridgefem.limit.rigid_block.dead_load_deficit`: the least joint tension and cohesion the self-weight needs);
2. the thickest ring of ``_THICKNESS_RANGE`` x span is analysed first; if it falls, :class:`NoStableThickness`;
   then the thinnest (if it stands, it is the answer);
3. the bracket (thinnest, thickest) is narrowed by Brent's method (:func:`_brent`) on a value that changes sign
   where the ring starts to stand: the deficit (N, > 0) where it falls, the associative margin (N, <= 0,
   :func:`bridgefem.limit.rigid_block.dead_load_margin`) where it stands. Between changes of mechanism the value
   is a smooth function of the thickness (the associative one passes through zero with no step), so the
   interpolation converges in a few LPs; where it is not (a change of mechanism, or a step between the
   non-associative deficit and the associative margin) Brent's bisection steps still shrink the bracket. It stops
   when the bracket (a thickness that falls, one that stands, both analysed) is narrower than ``rtol`` x one of
   its ends (the one with the smaller value), hence than ``rtol`` x its stable end;
4. the stable end is the least thickness; the deficit LP at the unstable end gives the mechanism (hinges, slips).

Lengths in m.

A barrel of rings (``[arch] rings``) each thinner than the least thickness stands only when its ring interfaces
carry enough shear: :func:`least_ring_friction` finds the least ring-interface friction that lets it carry its
self-weight, by the same deficit LP.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

from ..laws.crushing import strength_text
from ..scene.model import Scene
from ..scene.schema import SCHEMA
from .rigid_block import LPFailure, LPResult, dead_load_deficit, dead_load_margin
from .ring_blocks import ring_model

STANDS = "stable under self-weight"
# least-thickness search, x span: from the scene's least thickness (a sliver) to (almost) a solid half-disc (the
# scene's range ends below the span)
_THICKNESS_RANGE = (SCHEMA["arch"]["thickness"].low, 0.999)


class NoStableThickness(ValueError):
    """No ring thickness in the searched range carries the self-weight (e.g. too little friction: a semicircle
    needs mu >= 0.3092, Cocchetti & Rizzi 2020)."""


@dataclass
class ThicknessResult:
    """Least ring thickness carrying the self-weight (m); ``ratio`` = thickness / centreline radius (circular
    shapes, else None); ``mechanism``: the collapse mechanism just below it (deficit LP, dead work > 0);
    ``bracket``: (unstable, stable) thicknesses, m; ``evaluations``: thicknesses analysed. When even the thinnest
    ring of the search's range stands, the bracket is (thinnest, thinnest) and ``mechanism`` its LP (no mechanism)."""

    thickness: float
    ratio: float | None
    radius: float | None
    mechanism: LPResult
    bracket: tuple[float, float]
    evaluations: int

    def to_dict(self) -> dict:
        return {"thickness": self.thickness, "ratio": self.ratio, "radius": self.radius,
                "mechanism": self.mechanism.to_dict(), "bracket": list(self.bracket),
                "evaluations": self.evaluations}


@dataclass(frozen=True)
class _Point:
    """A thickness analysed by the search: ``t`` (m), the deficit LP's ``result`` and the search's ``value`` (N):
    the deficit where the ring falls (> 0), the associative margin where it stands (<= 0)."""

    t: float
    value: float
    result: LPResult

    @property
    def stands(self) -> bool:
        return self.result.status == STANDS


def _brent(analyse: Callable[[float], _Point], falls: _Point, stands: _Point, rtol: float) -> tuple[_Point, _Point]:
    """Brent's method (Brent 1973, *Algorithms for Minimization without Derivatives*, ch. 4; the zeroin that
    ``scipy.optimize.brentq`` implements) between a thickness that ``falls`` and one that ``stands``, on their
    ``value``: each step interpolates (the secant through the last two points, or the inverse quadratic through three)
    when that step is short enough, else bisects, and is at least half the tolerance; the bracket is always a
    point that falls and one that stands. Stops when it is narrower than ``rtol`` x its end with the smaller value
    (so than ``rtol`` x its stable end); returns it as (falls, stands)."""
    pre, cur, blk = falls, stands, falls
    s_pre = s_cur = cur.t - pre.t
    while True:
        if pre.stands != cur.stands:  # the bracket: the newest point and the last one on the other side
            blk, s_pre = pre, cur.t - pre.t
            s_cur = s_pre
        if abs(blk.value) < abs(cur.value):  # cur: the end with the smaller value
            pre, cur, blk = cur, blk, cur
        delta = 0.5 * rtol * cur.t
        s_bis = 0.5 * (blk.t - cur.t)
        if abs(s_bis) < delta:
            return (blk, cur) if cur.stands else (cur, blk)
        step = s_bis
        if abs(s_pre) > delta and abs(cur.value) < abs(pre.value):
            if pre is blk:  # secant
                trial = -cur.value * (cur.t - pre.t) / (cur.value - pre.value)
            else:  # inverse quadratic
                d_pre = (pre.value - cur.value) / (pre.t - cur.t)
                d_blk = (blk.value - cur.value) / (blk.t - cur.t)
                den = d_blk * d_pre * (blk.value - pre.value)
                trial = -cur.value * (blk.value * d_blk - pre.value * d_pre) / den if den else math.inf
            if 2 * abs(trial) < min(abs(s_pre), 3 * abs(s_bis) - delta):
                s_pre, step = s_cur, trial
            else:
                s_pre = s_bis
        else:
            s_pre = s_bis
        s_cur = step
        pre = cur
        cur = analyse(cur.t + (step if abs(step) > delta else math.copysign(delta, s_bis)))


def min_thickness(scene: Scene, rtol: float = 1e-4, friction_model: str = "associative",
                  **options) -> ThicknessResult:
    """The least ring thickness (all else fixed, no live load) that carries the self-weight, to ``rtol``.

    A thickness is stable when :func:`~bridgefem.limit.rigid_block.dead_load_deficit` is zero; the bracket starts
    at ``_THICKNESS_RANGE`` x span and is narrowed by Brent's method until its width is below ``rtol`` x thickness
    (steps of the module docstring). Raises :class:`NoStableThickness` when even the thickest ring of the range
    falls; when even the thinnest stands, it is the answer, with the bracket (thinnest, thinnest) and its own
    deficit LP as ``mechanism`` (none). For circular shapes the centreline radius is ``R = R_intrados + t/2`` and
    ``ratio = t/R``; ``options`` go to the deficit LP.
    """
    span = scene.arch.span
    evals = 0

    def analyse(t: float) -> _Point:
        nonlocal evals
        evals += 1
        model = ring_model(scene, thickness=t, live=False)
        tau, res = dead_load_deficit(model, friction_model, **options)
        if res.status != STANDS:
            return _Point(t, tau, res)
        try:
            return _Point(t, min(dead_load_margin(model), 0.0), res)
        except LPFailure:  # the ring stands (its deficit LP says so): a value of 0 only stops interpolating from it
            return _Point(t, 0.0, res)

    thickest = analyse(_THICKNESS_RANGE[1] * span)
    if not thickest.stands:
        mech = thickest.result.by_joint
        how = f"joints {mech.sliding} slide" if mech.sliding else f"hinges form at joints {mech.hinges}"
        raise NoStableThickness(f"no ring thickness up to {thickest.t:g} m ({_THICKNESS_RANGE[1]:g} x span) carries "
                                f"the self-weight with friction {scene.joints.friction:g} ({friction_model})"
                                f"{strength_text(scene)}: {how}")
    thinnest = analyse(_THICKNESS_RANGE[0] * span)
    falls, stands = (thinnest, thinnest) if thinnest.stands else _brent(analyse, thinnest, thickest, rtol)
    hi = stands.t
    radius = ratio = None
    if scene.arch.shape in ("semicircular", "segmental"):
        a = scene.arch
        radius = (a.span ** 2 / 4 + a.rise ** 2) / (2 * a.rise) + hi / 2
        ratio = hi / radius
    return ThicknessResult(hi, ratio, radius, falls.result, (falls.t, hi), evals)


class NoRingFriction(ValueError):
    """The barrel's rings carry their weight at every ring-interface friction, or at none in the searched range."""


@dataclass
class RingFrictionResult:
    """The least ring-interface friction with which a barrel of rings carries its self-weight: ``friction`` (the
    stable end of ``bracket``, (falls, stands)); ``mechanism``: the deficit LP's mechanism just below it;
    ``evaluations``: frictions analysed."""

    friction: float
    mechanism: LPResult
    bracket: tuple[float, float]
    evaluations: int


def least_ring_friction(scene: Scene, highest: float = 10.0, atol: float = 1e-5,
                        friction_model: str = "associative") -> RingFrictionResult:
    """Bisect the ring-interface friction (``[joints] ring_friction``; all else fixed, no live load) for the least
    one with which the barrel carries its self-weight.

    1. a friction stands when the dead-load deficit of the scene's blocks with it is zero
       (:func:`~bridgefem.limit.rigid_block.dead_load_deficit`);
    2. frictionless interfaces (the rings press on each other but share no shear beyond the cohesion) and
       ``highest`` are analysed first: if the first stands or the second falls, :class:`NoRingFriction`;
    3. the bracket (0, ``highest``) is halved until its width is below ``atol``;
    4. its stable end is the least friction; the deficit LP at its unstable end gives the mechanism.
    """
    evals = 0

    def analyse(mu: float) -> LPResult:
        nonlocal evals
        evals += 1
        joints = dataclasses.replace(scene.joints, ring_friction=mu)
        model = ring_model(dataclasses.replace(scene, joints=joints, loads=()), live=False)
        return dead_load_deficit(model, friction_model)[1]

    lo, hi = 0.0, highest
    if analyse(lo).status == "stable under self-weight":
        raise NoRingFriction("the barrel carries its self-weight with frictionless ring interfaces")
    if analyse(hi).status != "stable under self-weight":
        raise NoRingFriction(f"the barrel does not carry its self-weight with ring friction {hi:g}")
    while hi - lo > atol:
        mid = 0.5 * (lo + hi)
        if analyse(mid).status == "stable under self-weight":
            hi = mid
        else:
            lo = mid
    return RingFrictionResult(hi, analyse(lo), (lo, hi), evals)
