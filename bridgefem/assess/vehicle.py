"""A vehicle at one position on the bridge, as the scene's live loads.

1. The vehicle stands with its first (leftmost) axle at ``x0`` (m from the left springing); axle i at
   ``x0 + offset_i`` (:attr:`bridgefem.scene.model.Vehicle.offsets`).
2. An axle acts on the bridge when it lies on it: a point axle strictly between the bridge's end springings (at
   least :data:`EDGE` x span inside; over a span or a pier), a patch axle (``contact_length`` c > 0) with the part
   of [x - c/2, x + c/2] that lies on the bridge, its load scaled by that part's share, when that part is at least
   the shortest patch the schema allows (1e-3 x span). Axles off the bridge carry nothing (they bear on the approach
   and the abutment). Span: the first span's.
3. Each axle on the bridge is a ``[[load]]`` table placed by ``x``, its ``factor`` = axle load (N) / the vehicle's
   heaviest axle, so that the load level of a run (N) divided by the heaviest axle is the vehicle's load factor;
   the scene is rebuilt through the schema (joints under the loads, every check a scene file gets).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from ..scene.model import Scene
from ..scene.reader import scene_from_dict
from ..scene.schema import SCHEMA

EDGE = 1e-3  # x span: a point axle closer than this to a springing bears on the abutment
MIN_PATCH = SCHEMA["load"]["length"].low  # x span: the shortest patch


@dataclass(frozen=True)
class Placement:
    """The vehicle with its first axle at ``x0`` (m from the left springing): ``scene`` with one ``[[load]]`` per
    axle on the bridge (None when none is), ``on`` the indices of those axles, ``load`` the vehicle load they carry
    (N, whole axles and the span's share of a clipped patch)."""

    x0: float
    scene: Scene | None
    on: tuple[int, ...]
    load: float


def axle_loads(scene: Scene, x0: float) -> list[dict]:
    """The ``[[load]]`` tables of the vehicle with its first axle at ``x0`` (m): step 2 of the module docstring;
    each with ``axle`` (its index) and ``share`` (the part of its load on the span) besides the table's keys."""
    v, span, length = scene.vehicle, scene.arch.span, bridge_length(scene)
    top = max(v.axles)
    out = []
    for i, (p, off) in enumerate(zip(v.axles, v.offsets)):
        x = x0 + off
        if v.contact_length == 0:
            if EDGE * span <= x <= length - EDGE * span:
                out.append({"axle": i, "share": 1.0, "kind": "point", "x": x, "factor": p / top})
            continue
        lo, hi = max(x - v.contact_length / 2, 0.0), min(x + v.contact_length / 2, length)
        if hi - lo >= MIN_PATCH * span * (1 + 1e-9):
            share = (hi - lo) / v.contact_length
            out.append({"axle": i, "share": share, "kind": "patch", "x": (lo + hi) / 2, "length": hi - lo,
                        "factor": p * share / top})
    return out


def place(scene: Scene, x0: float) -> Placement:
    """The scene with the vehicle's axles as its live loads, first axle at ``x0`` (m from the left springing)."""
    tables = axle_loads(scene, x0)
    if not tables:
        return Placement(x0, None, (), 0.0)
    doc = copy.deepcopy(scene.document)
    doc["load"] = [{k: t[k] for k in t if k not in ("axle", "share")} for t in tables]
    placed = scene_from_dict(doc, scene.name)
    load = sum(scene.vehicle.axles[t["axle"]] * t["share"] for t in tables)
    return Placement(x0, placed, tuple(t["axle"] for t in tables), load)


def bridge_length(scene: Scene) -> float:
    """From the first span's left springing to the last span's right springing (m, on the intrados; one span: the
    span)."""
    return scene.span_ranges()[-1][1] + scene.arch.span / 2


def positions(scene: Scene, step: float) -> np.ndarray:
    """First-axle positions (m) every ``step`` m, from where the last axle enters the bridge to where the
    first axle leaves it: x0 from -(vehicle length + c/2) to the bridge's length + c/2, on a grid that holds
    x0 = 0."""
    v = scene.vehicle
    lo, hi = -(v.length + v.contact_length / 2), bridge_length(scene) + v.contact_length / 2
    k0, k1 = int(np.floor(lo / step)), int(np.ceil(hi / step))
    return np.array([k * step for k in range(k0, k1 + 1) if lo < k * step < hi])
