"""The intrados curves of an arch ring (pure numpy): a curve parameter ``p`` in [0, 1] runs along the intrados
from the left springing (p = 0) to the right springing (p = 1); coordinates in metres, origin at the midpoint of
the springing line, x to the right and y up.

The intrados of each shape (:data:`SHAPES`) passes through both springings and the crown: semicircular and segmental
a circular arc, pointed two circular arcs centred on the springing line meeting at the apex (a kink), elliptical a
semi-ellipse, parabolic ``y = rise (1 - (2x/span)^2)``. :func:`make_shape` gives the curve of a named
shape; :mod:`bridgefem.geometry.ring` builds the ring's joints and voussoirs on it.
"""
from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

SHAPES = ("semicircular", "segmental", "pointed", "elliptical", "parabolic")


class Shape(ABC):
    """An intrados curve: ``point(p)`` and ``normal(p)`` for p in [0, 1], vectorised; ``kinks`` lists corners."""

    kinks: tuple[float, ...] = ()

    @abstractmethod
    def point(self, p: np.ndarray) -> np.ndarray:
        """Intrados points (m), shape (..., 2)."""

    @abstractmethod
    def normal(self, p: np.ndarray) -> np.ndarray:
        """Unit normals towards the extrados, shape (..., 2)."""


class _Circular(Shape):
    """Circular arc through both springings and the crown (semicircular when rise = span/2)."""

    def __init__(self, span: float, rise: float):
        self.radius = (span ** 2 / 4 + rise ** 2) / (2 * rise)
        self.yc = rise - self.radius
        self.a0 = np.arccos(np.clip(span / (2 * self.radius), -1.0, 1.0))

    def _angle(self, p):
        return self.a0 + np.asarray(p, float) * (np.pi - 2 * self.a0)

    def point(self, p):
        a = self._angle(p)
        return np.stack([-self.radius * np.cos(a), self.yc + self.radius * np.sin(a)], axis=-1)

    def normal(self, p):
        a = self._angle(p)
        return np.stack([-np.cos(a), np.sin(a)], axis=-1)


class _Pointed(Shape):
    """Two circular arcs centred on the springing line, meeting at the crown (equilateral if rise = span*sqrt(3)/2)."""

    kinks = (0.5,)

    def __init__(self, span: float, rise: float):
        self.x0 = (rise ** 2 - span ** 2 / 4) / span
        self.radius = span / 2 + self.x0
        self.a_top = np.arccos(self.x0 / self.radius)

    def _left(self, q):
        a = 2 * np.asarray(q, float) * self.a_top
        pt = np.stack([self.x0 - self.radius * np.cos(a), self.radius * np.sin(a)], axis=-1)
        return pt, np.stack([-np.cos(a), np.sin(a)], axis=-1)

    def _mirror(self, p, which):
        p = np.asarray(p, float)
        left = p <= 0.5
        v = which(np.where(left, p, 1.0 - p))
        return np.where(left[..., None], v, v * np.array([-1.0, 1.0]))

    def point(self, p):
        return self._mirror(p, lambda q: self._left(q)[0])

    def normal(self, p):
        n = self._mirror(p, lambda q: self._left(q)[1])
        crown = np.isclose(np.asarray(p, float), 0.5, rtol=0, atol=1e-12)  # p = 0.5 up to round-off: the apex
        return np.where(crown[..., None], np.array([0.0, 1.0]), n)


class _Elliptical(Shape):
    """Semi-ellipse with semi-axes span/2 (horizontal) and rise (vertical)."""

    def __init__(self, span: float, rise: float):
        self.a, self.b = span / 2, rise

    def point(self, p):
        t = np.pi * np.asarray(p, float)
        return np.stack([-self.a * np.cos(t), self.b * np.sin(t)], axis=-1)

    def normal(self, p):
        t = np.pi * np.asarray(p, float)
        n = np.stack([-self.b * np.cos(t), self.a * np.sin(t)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


class _Parabolic(Shape):
    """Parabola y = rise (1 - (2x/span)^2)."""

    def __init__(self, span: float, rise: float):
        self.span, self.rise = span, rise

    def point(self, p):
        x = self.span * (np.asarray(p, float) - 0.5)
        return np.stack([x, self.rise * (1 - (2 * x / self.span) ** 2)], axis=-1)

    def normal(self, p):
        x = self.span * (np.asarray(p, float) - 0.5)
        n = np.stack([8 * self.rise * x / self.span ** 2, np.ones_like(x)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


def make_shape(shape: str, span: float, rise: float) -> Shape:
    """The intrados curve of a named shape (see ``SHAPES``); span and rise in m on the intrados."""
    return {"semicircular": _Circular, "segmental": _Circular, "pointed": _Pointed,
            "elliptical": _Elliptical, "parabolic": _Parabolic}[shape](span, rise)
