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
3. the bracket (thinnest of the range, thickest) is bisected until its width is below ``rtol`` x its stable end;
4. the stable end is the least thickness; the deficit LP just below it gives the mechanism (hinges, slips).

Lengths in m.

A barrel of rings (``[arch] rings``) each thinner than the least thickness stands only when its ring interfaces
carry enough shear: :func:`least_ring_friction` finds the least ring-interface friction that lets it carry its
self-weight, by the same deficit LP.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..laws.crushing import strength_text
from ..scene.model import Scene
from ..scene.schema import SCHEMA
from .rigid_block import LPResult, dead_load_deficit
from .ring_blocks import ring_model

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
    ``bracket``: (unstable, stable) thicknesses, m; ``evaluations``: thicknesses analysed."""

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


def min_thickness(scene: Scene, rtol: float = 1e-4, friction_model: str = "associative",
                  **options) -> ThicknessResult:
    """Bisect the ring thickness (all else fixed, no live load) for the least one that carries the self-weight.

    A thickness is stable when :func:`~bridgefem.limit.rigid_block.dead_load_deficit` is zero; the bracket starts
    at ``_THICKNESS_RANGE`` x span and is halved until its width is below ``rtol`` x thickness (steps of the module
    docstring). Raises :class:`NoStableThickness` when even the thickest ring of the range falls. For circular shapes
    the centreline radius is ``R = R_intrados + t/2`` and ``ratio = t/R``; ``options`` go to the deficit LP.
    """
    span = scene.arch.span
    evals = 0

    def analyse(t) -> LPResult:
        nonlocal evals
        evals += 1
        return dead_load_deficit(ring_model(scene, thickness=t, live=False), friction_model, **options)[1]

    lo, hi = _THICKNESS_RANGE[0] * span, _THICKNESS_RANGE[1] * span
    thickest = analyse(hi)
    if thickest.status != "stable under self-weight":
        mech = thickest.by_joint
        how = f"joints {mech.sliding} slide" if mech.sliding else f"hinges form at joints {mech.hinges}"
        raise NoStableThickness(f"no ring thickness up to {hi:g} m ({_THICKNESS_RANGE[1]:g} x span) carries the "
                                f"self-weight with friction {scene.joints.friction:g} ({friction_model})"
                                f"{strength_text(scene)}: {how}")
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if analyse(mid).status == "stable under self-weight":
            hi = mid
        else:
            lo = mid
    mechanism = analyse(lo)
    radius = ratio = None
    if scene.arch.shape in ("semicircular", "segmental"):
        a = scene.arch
        radius = (a.span ** 2 / 4 + a.rise ** 2) / (2 * a.rise) + hi / 2
        ratio = hi / radius
    return ThicknessResult(hi, ratio, radius, mechanism, (lo, hi), evals)


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
