"""Scene keys: the :class:`Key` type (a key's type, default, unit, range and description), its check of a value, and
the scales a relative range is a multiple of (the span, the ring's weight).

A number's range holds for a bridge of any size when its bounds are multiples of the span (the bridge's lengths) or
of the ring's weight (the solver's forces): :attr:`Key.per` names the scale, :func:`ring_weight` and
:func:`springing_reach` compute the scene's values from its [arch] alone, before the scene is built. Every rejected
value raises :class:`SceneError` naming the key, the value and what is allowed, written by :func:`show_value` and
:func:`toml_value`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry.ring import polygon_area_centroid
from ..geometry.shapes import make_shape


class SceneError(ValueError):
    """A scene value that cannot be used; the message names key, value and what is allowed."""


REQUIRED = object()  # a Key default: the key must be given

SCALES = {"span": "span", "ring weight": "the ring's weight"}
"""What a relative range (:attr:`Key.per`) is a multiple of: the [arch] span (m), or the ring's weight (N, the
voussoirs' density x gravity x width x the ring's area, :func:`ring_weight`)."""
RANGE_RTOL = 1e-12  # a relative bound is met up to this fraction of it: the round-off of bound x scale


@dataclass(frozen=True)
class Key:
    """One scene key. ``default``: REQUIRED, a value, or None when the code derives it (``derived`` says how);
    numbers must be finite and within ``low``..``high`` (``low_open``/``high_open``: the bound itself excluded),
    bounds that are multiples of the scene's ``per`` (:data:`SCALES`: "span" or "ring weight") when it is given, so
    that a range holds for a bridge of any size; ``zero``: 0 is allowed too, outside the range (the key's "none" or
    "derived" value); ``why``: the physical argument for the range; ``choices``: the allowed values; ``only``: (key,
    value) of the same section without which this key is refused (e.g. the Mohr-Coulomb keys of an elastic fill)."""

    kind: type
    doc: str
    default: Any = REQUIRED
    unit: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple = ()
    only: tuple[str, str] | None = None
    derived: str = ""
    per: str = ""
    zero: bool = False
    why: str = ""

    def _bound(self, value: float) -> str:
        if not self.per:
            return f"{value:g}"
        name = SCALES[self.per]
        return name if value == 1 else f"{value:g} x {name}"

    def allowed(self, scale: float | None = None) -> str:
        """What is allowed, in words, e.g. "a number from 0.0001 x span to below span in m"; with the scene's
        ``scale`` of a relative range (the span in m, the ring's weight in N) also the bounds it gives."""
        if self.choices:
            return " or ".join(f'"{c}"' if isinstance(c, str) else str(c) for c in self.choices)
        if self.kind is not int and self.kind is not float:
            return {bool: "true or false", str: "a string", dict: "a table", list: "a list"}[self.kind]
        noun = "integer" if self.kind is int else "number"
        article = "an" if noun == "integer" else "a"
        lo, hi, unit = self.low, self.high, f" in {self.unit}" if self.unit else ""
        above = f"{'>' if self.low_open else '>='} {self._bound(lo)}" if lo is not None else ""
        below = f"{'<' if self.high_open else '<='} {self._bound(hi)}" if hi is not None else ""
        if lo is not None and hi is not None and not (self.low_open or self.high_open):
            text = f"{article} {noun} from {self._bound(lo)} to {self._bound(hi)}{unit}"
        elif lo == 0 and self.low_open:
            up = f" {'below' if self.high_open else 'up to'} {self._bound(hi)}" if hi is not None else ""
            text = f"a positive {noun}{unit}{up}"
        else:
            text = f"{article} {noun}{unit} {' and '.join(t for t in (above, below) if t)}".rstrip()
        if self.zero:
            text = "0 or " + text
        if scale is not None and self.per:
            ends = [f"{v * scale:.4g}" for v in (lo, hi) if v is not None]
            text += f" ({' to '.join(ends)}{' ' + self.unit if self.unit else ''} in this scene)"
        return text

    def check(self, where: str, value: Any, scale: float | None = None) -> Any:
        """The value, typed (an integer where a number is expected becomes a float), or SceneError; ``scale``: the
        scene's span or ring weight (:data:`SCALES`) that a relative range is a multiple of."""
        if self.kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, self.kind) or (self.kind is not bool and isinstance(value, bool)):
            kind = {float: "number", int: "integer", str: "string", bool: "true or false", dict: "table",
                    list: "list"}[self.kind]
            raise SceneError(f"{where} = {show_value(value)}: expected {kind} ({self.allowed(scale)})")
        ok = True
        if isinstance(value, float) and not math.isfinite(value):
            ok = False
        elif self.choices:
            ok = value in self.choices
        elif self.kind in (int, float) and not (self.zero and value == 0):
            if self.per and scale is None:
                raise TypeError(f"{where}: a range relative to the {self.per} needs the scene's {self.per}")
            ok = self.within(value, 1.0 if scale is None else scale)
        if not ok:
            raise SceneError(f"{where} = {show_value(value)}: allowed is {self.allowed(scale)}")
        return value

    def within(self, value: float, scale: float = 1.0) -> bool:
        """Whether ``value`` lies in the range with its bounds times ``scale``; a relative bound is met up to the
        round-off of that product (1e-12 of it), so that the bound a message prints is allowed."""
        slack = RANGE_RTOL if self.per else 0.0
        lo = None if self.low is None else self.low * scale
        hi = None if self.high is None else self.high * scale
        if lo is not None and not (value > lo if self.low_open else value >= lo - slack * abs(lo)):
            return False
        return hi is None or (value < hi if self.high_open else value <= hi + slack * abs(hi))


def show_value(value: Any, limit: int = 60) -> str:
    """A value for a one-line message: its repr, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def toml_value(value: Any) -> str:
    """A value as TOML writes it: what ``bridgefem check`` prints and docs/scene-keys.md shows as a default."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, float) and len(repr(value)) > 12 and float(f"{value:g}") == value:
        return f"{value:g}"  # 1e+10, not 10000000000.0
    return repr(value)


def ring_weight(arch: dict[str, Any], density: float, gravity: float) -> float:
    """The ring's weight (N) from the scene alone, the scale of the [solver] force keys' ranges: density x gravity x
    width x the area between the intrados and the extrados (a polygon through 257 points of each: within 1e-4 of
    the voussoirs' area, 2e-3 at the cap of a tall pointed crown; a scale, not the analysis' weight)."""
    shape = make_shape(arch["shape"], arch["span"], arch["rise"])
    p = np.linspace(0.0, 1.0, 257)
    intrados = shape.point(p)
    extrados = intrados + arch["thickness"] * shape.normal(p)
    area = abs(polygon_area_centroid(np.vstack([intrados, extrados[::-1]]))[0])
    return density * gravity * arch["width"] * area


def springing_reach(arch: dict[str, Any]) -> float:
    """Horizontal distance (m) from a springing's intrados corner to its extrados corner."""
    shape = make_shape(arch["shape"], arch["span"], arch["rise"])
    return float(abs(arch["thickness"] * shape.normal(0.0)[0]))
