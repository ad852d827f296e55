"""Scene files (TOML): read, validate and hold everything a run needs, in SI units.

:data:`SCHEMA` is the one source of every scene key: its type, default, unit, allowed values and a one-line
description. The dataclasses take their defaults from it, ``bridgefem check`` prints a scene resolved against it
and docs/scene-keys.md is generated from it (:func:`keys_markdown`). To add a key: one :class:`Key` line in its
section of :data:`SCHEMA` and a field of the same name in the section's dataclass (default
``_default(section, key)``); a key that applies only with a given value of another key names it in ``only``.
Then regenerate docs/scene-keys.md (``./run python -m bridgefem.scene.schema > docs/scene-keys.md``).

Every rejected value raises :class:`SceneError` naming the key, the value and what is allowed; the command line
turns it into exit code 2 before anything is written.
"""
from __future__ import annotations

import copy
import dataclasses
import difflib
import math
import os
import re
import stat
import tomllib
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..geometry.ring import SHAPES, make_shape, polygon_area_centroid

PETSC_PREFIX = "bridgefem_"
"""Options prefix of the contact solver's PETSc objects: ``-bridgefem_ksp_type ...`` on the command line."""


class SceneError(ValueError):
    """A scene value that cannot be used; the message names key, value and what is allowed."""


REQUIRED = object()  # a Key default: the key must be given


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
            raise SceneError(f"{where} = {_show(value)}: expected {kind} ({self.allowed(scale)})")
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
            raise SceneError(f"{where} = {_show(value)}: allowed is {self.allowed(scale)}")
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


def _show(value: Any, limit: int = 60) -> str:
    """A value for a one-line message: its repr, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def did_you_mean(name: str, allowed, show=repr) -> str:
    """The hint after an unknown name in a one-line message: ``"did you mean 'span'? "`` when an allowed name is
    close to ``name`` (:func:`difflib.get_close_matches`; ``show`` writes it), else ``""``."""
    close = difflib.get_close_matches(name, list(allowed), n=1) if isinstance(name, str) else []
    return f"did you mean {show(close[0])}? " if close else ""


PRESETS: dict[str, dict[tuple[str, str], Any]] = {
    "fast": {("mesh", "elements_through_thickness"): 2, ("mesh", "degree"): 1, ("solver", "tolerance"): 0.0005},
    "default": {("mesh", "elements_through_thickness"): 4, ("mesh", "degree"): 1, ("solver", "tolerance"): 0.0001},
    "accurate": {("mesh", "elements_through_thickness"): 8, ("mesh", "degree"): 1, ("solver", "tolerance"): 0.0001},
}
"""Speed-accuracy presets (``[solver] preset``): the mesh and bracket settings they imply, all three on the Pareto
front measured by ``demos/speed_accuracy.py`` (README, "Speed and accuracy"): ``fast`` the most accurate within
the cost of the cheapest run, ``default`` the cheapest within a worst error bound of 0.05 %, ``accurate`` within
0.02 %. The ``default`` preset is the source of these keys' defaults; a key given in the scene overrides its
preset value."""

FILL_PRESETS: dict[str, dict[tuple[str, str], Any]] = {
    "fast": {("mesh", "elements_through_thickness"): 2, ("mesh", "degree"): 2, ("solver", "tolerance"): 0.01},
    "default": {("mesh", "elements_through_thickness"): 2, ("mesh", "degree"): 2, ("solver", "tolerance"): 0.005},
    "accurate": {("mesh", "elements_through_thickness"): 4, ("mesh", "degree"): 2, ("solver", "tolerance"): 0.005},
}
"""What each preset sets instead when the scene has a Mohr-Coulomb fill: quadratic displacements (linear
triangles lock under plastic flow and overstate the limit, docs/fill.md) and a bracket no tighter than the mesh
error (the fill's limit converges slowly: docs/fill.md, "Mesh convergence on Prestwood", measures each preset's
distance from the extrapolated limit). A key given in the scene overrides its preset value."""

FILL_MATERIALS = ("elastic", "mohr-coulomb")
ABUTMENT_MODELS = ("rigid", "elastic")
MOVING_SPRINGINGS = ("left", "right", "both")
MAX_LOADS = 100  # [[load]] tables in one scene
MAX_AXLES = 20  # axles of one vehicle
VEHICLES: dict[str, dict[str, Any]] = {
    "EN1991-2-LM2": {"axles": (400e3,), "spacing": (), "contact_length": 0.0,
                     "source": "EN 1991-2:2003, 4.3.3(1): Load Model 2, a single axle of beta_Q x 400 kN (beta_Q = "
                               "alpha_Q1 = 1 unless the National Annex says otherwise), dynamic amplification "
                               "included"},
    "EN1991-2-LM1-single-axle": {"axles": (600e3,), "spacing": (), "contact_length": 0.0,
                                 "source": "EN 1991-2:2003, 4.3.2(6)b: for spans above 10 m, the tandem system of "
                                           "Lane 1 replaced by one axle of the two axles' weight, 600 alpha_Q1 kN "
                                           "(alpha_Q1 = 1 unless specified)"},
}
"""Published assessment vehicles and load models (``[vehicle] standard``): axle loads (N, the whole vehicle's: the
scene's width is the ring width that carries it), spacings (m) and the tyre contact along the road (m; 0 where the
source read did not give it). Each has the source it was read from (docs/assessment.md); a vehicle whose source
could not be read is not here."""
DISPERSIONS = ("boussinesq", "spread-2:1", "spread-30", "none")
"""How the rigid-block LP carries an axle through a fill to the extrados (:mod:`bridgefem.assess.dispersion`)."""
MAX_NAME = 100  # characters of a scene name (a file name)
MAX_NAME_BYTES = 200  # in UTF-8: results/<name> and the names a run makes beside it (up to 32 bytes longer) fit 255
MAX_SCENE_BYTES = 1_000_000  # a scene file larger than this is not a scene
SCALES = {"span": "span", "ring weight": "the ring's weight"}
"""What a relative range (:attr:`Key.per`) is a multiple of: the [arch] span (m), or the ring's weight (N, the
voussoirs' density x gravity x width x the ring's area, :func:`ring_weight`)."""
RANGE_RTOL = 1e-12  # a relative bound is met up to this fraction of it: the round-off of bound x scale
_MC = ("material", "mohr-coulomb")
_ELASTIC = ("model", "elastic")
_WHY_MODULUS = ("from rubber-like laboratory blocks (1 MPa) to ten times the stiffest rock (basalt, granite: about "
                "100 GPa), a practically rigid ring")
_WHY_POISSON = ("the physical range of an isotropic solid that does not expand under compression; 0.5 "
                "(incompressible) makes plane strain singular")
_WHY_FRICTION = ("0 is the frictionless idealisation, real joints and interfaces have 0.3 to 1, and a large value "
                 "(1e4 = tan 89.99 degrees) switches sliding off")
_WHY_STRENGTH = ("0 for none, else from 100 Pa (below it a strength is no strength against a fill's own weight) to "
                 "10 MPa (a weak concrete backing)")
_WHY_ANGLE = "from 0 (an undrained clay) to beyond the densest rockfill (about 50 degrees)"
_WHY_FORCE = ("0 for the default; a load below 1e-12 of the ring's weight is no load (far below the equilibrium "
              "residual), and no ring carries 1e6 times its weight")


def _length(doc: str, low: float, high: float, default: Any = REQUIRED, **kw) -> Key:
    """A length of the bridge in m, its range a multiple of the span: the bridge's shape, whatever its size."""
    return Key(float, doc, default, "m", low=low, high=high, per="span", **kw)


def _modulus(doc: str, default: Any = REQUIRED, **kw) -> Key:
    return Key(float, doc, default, "Pa", low=1e6, high=1e12, why=_WHY_MODULUS, **kw)


def _poisson(doc: str, default: Any, **kw) -> Key:
    return Key(float, doc, default, low=0.0, high=0.5, high_open=True, why=_WHY_POISSON, **kw)


def _coefficient(doc: str, default: Any = REQUIRED, **kw) -> Key:
    return Key(float, doc, default, low=0.0, high=1e4, why=_WHY_FRICTION, **kw)


_GRAVITY = Key(float, "acceleration of gravity", 9.81, "m/s^2", low=1.0, high=100.0,
               why="from the Moon's (1.6) to a ten-g centrifuge model")
_DENSITY = Key(float, "density of the voussoirs", unit="kg/m^3", low=500.0, high=5000.0,
               why="from timber laboratory blocks to beyond the densest building stone (basalt, about 3000)")


def _unit_weight(doc: str, default: Any = REQUIRED, **kw) -> Key:
    """A weight density (N/m^3): the masonry's density range times the gravity range (so that an abutment's default,
    the masonry's density x gravity, is always in it)."""
    return Key(float, doc, default, "N/m^3", low=_DENSITY.low * _GRAVITY.low, high=_DENSITY.high * _GRAVITY.high,
               why="the masonry's density range times the gravity range (fills: about 500 kg/m^3 for a foamed "
                   "concrete to 2500 for a rockfill)", **kw)


def _strength(doc: str, **kw) -> Key:
    return Key(float, doc, 0.0, "Pa", low=100.0, high=1e7, zero=True, why=_WHY_STRENGTH, **kw)


def _angle(doc: str, default: Any, **kw) -> Key:
    return Key(float, doc, default, "degrees", low=0.0, high=60.0, why=_WHY_ANGLE, **kw)


def _force(doc: str) -> Key:
    return Key(float, doc, 0.0, "N", low=1e-12, high=1e6, per="ring weight", zero=True, why=_WHY_FORCE)


def _movement(doc: str) -> Key:
    return _length(doc, -0.1, 0.1, 0.0, why="none (0) to a tenth of the span either way: a movement that large "
                   "brings down any masonry arch, and beyond it a geometrically linear model means nothing")


def _preset(section: str, key: str) -> Any:
    return PRESETS["default"][(section, key)]


SCHEMA: dict[str, dict[str, Key]] = {
    "scene": {
        "name": Key(str, f"output folder results/<name>/; a file name, not a path: 1 to {MAX_NAME} characters "
                    f"({MAX_NAME_BYTES} bytes in UTF-8), no /, \\, control or bidi characters, not starting with \".\"",
                    None,
                    derived="the scene file's name without .toml"),
        "gravity": _GRAVITY,
    },
    "arch": {
        "shape": Key(str, "shape of the intrados", choices=SHAPES),
        "span": Key(float, "clear span between the springings, on the intrados", unit="m", low=0.1, high=200.0,
                    why="from laboratory models of a few decimetres to beyond the longest masonry arch built (the "
                        "Danhe bridge, 146 m)"),
        "rise": _length("intrados rise (semicircular: span/2; segmental <= span/2; pointed >= span/2)", 0.05, 2.0,
                        None, derived="span/2 (semicircular only)",
                        why="from a flat segmental arch (1/20; the flattest built are about 1/12) to a lancet twice "
                            "as tall as wide"),
        "thickness": _length("ring thickness normal to the centreline", 1e-4, 1.0, high_open=True,
                             why="from a sliver below the least thickness that stands of the flattest ring allowed "
                                 "(about 5e-4 x span at rise/span = 0.1) to the span itself (a thicker ring is a "
                                 "pierced wall)"),
        "width": Key(float, "out-of-plane width; loads and results are for this width", 1.0, "m", low=0.01,
                     high=100.0, why="from a centimetre slice of a laboratory model to the widest bridge decks and "
                                     "the longest culvert barrels"),
        "voussoirs": Key(int, "voussoirs; joints perpendicular to the centreline, evenly spaced along it", low=2,
                         high=4096, why="from two (one crown joint) to the courses of a brick ring over the longest "
                                        "span"),
        "joint_at_loads": Key(bool, "move the nearest joint under each point load and patch edge", True),
    },
    "masonry": {
        "young": _modulus("Young's modulus of the voussoirs"),
        "poisson": _poisson("Poisson's ratio of the voussoirs", 0.2),
        "density": _DENSITY,
    },
    "joints": {
        "friction": _coefficient("Coulomb coefficient of every joint, springing joints included"),
    },
    "load": {
        "kind": Key(str, "a point load or a patch (uniform per horizontal metre)", choices=("point", "patch")),
        "position": Key(float, "fraction of the span from the left springing (a patch: its centre)", None, low=0.0,
                        high=1.0, derived="x / span (give position or x)",
                        why="the span, from the left springing to the right one"),
        "x": _length("metres from the left springing (a patch: its centre); instead of position", 0.0, 1.0, None,
                     derived="position x span (give position or x)",
                     why="the span, from the left springing to the right one"),
        "length": _length("length along the span (patch loads only; 0: a point load)", 1e-3, 1.0, 0.0, zero=True,
                          why="a patch shorter than 1e-3 x span is a point load (kind = \"point\"), one longer "
                              "than the span is off the arch"),
        "factor": Key(float, "share of the load pattern: this load is factor x the load level (N)", 1.0, low=1e-3,
                      high=1e3, why="shares of one pattern (the axles of a vehicle): a load 1e6 times smaller "
                                    "than another is no load"),
    },
    "vehicle": {
        "standard": Key(str, "a published vehicle or load model of the library (docs/assessment.md, with its "
                        "source); instead of axles and spacing", "", choices=tuple(VEHICLES),
                        derived="none (axles and spacing given)"),
        "axles": Key(list, "axle loads in N for the scene's width, first (leftmost) axle first", None,
                     derived="the standard vehicle's",
                     why=f"1 to {MAX_AXLES} axles, each a load from 1e-6 to 1e6 x the ring's weight"),
        "spacing": Key(list, "distances in m between consecutive axles (one fewer than axles)", None,
                       derived="the standard vehicle's; none for one axle",
                       why="each longer than the tyre contact and at most 10 x span"),
        "contact_length": _length("tyre contact along the road (0: point loads; a patch of this length per axle)",
                                  1e-3, 1.0, None, zero=True, derived="the standard vehicle's, else 0",
                                  why="a patch shorter than 1e-3 x span is a point load"),
        "dispersion": Key(str, "how the rigid-block LP spreads an axle through a fill onto the extrados (the FE "
                          "carries it through the fill itself)", "boussinesq", choices=DISPERSIONS),
    },
    "fill": {
        "unit_weight": _unit_weight("weight density of the fill"),
        "young": Key(float, "Young's modulus of the fill", unit="Pa", low=1e5, high=1e11,
                     why="from a very soft soil (0.1 MPa) to a concrete backing (about 30 GPa)"),
        "depth": _length("road level above the crown's extrados", 0.01, 10.0,
                         why="from a road surfacing on the crown to a deep embankment over a culvert"),
        "extension": _length("fill beyond each springing's extrados corner", 0.01, 10.0,
                             why="from the spandrel walls' end at the springings to a long approach embankment"),
        "poisson": _poisson("Poisson's ratio of the fill", 0.3),
        "material": Key(str, "elastic, or a Drucker-Prager cone matched to Mohr-Coulomb in plane strain",
                        "elastic", choices=FILL_MATERIALS),
        "friction_angle": _angle("friction angle of the fill", 30.0, only=_MC),
        "cohesion": _strength("cohesion of the fill", only=_MC),
        "tension_cutoff": _strength("limit of the fill's mean tensile stress", only=_MC),
        "dilation_angle": _angle("dilation angle of the fill's plastic flow (0 to friction_angle)", None, only=_MC,
                                 derived="friction_angle (associated flow, the bound theorems' assumption)"),
        "interface_friction": _coefficient("Coulomb coefficient of the arch-fill interface (the extrados)", 0.5),
        "element_size": _length("fill mesh size away from the ring (0: twice the ring's element size)", 2e-3, 1.0,
                                0.0, zero=True, why="finer than 1/500 of the span meshes a fill in millions of "
                                                    "cells, coarser than the span meshes nothing"),
        "loading_beam": Key(bool, "each patch load reaches the road through a rigid loading beam of the patch's "
                            "length, bonded to the road (false: a flexible uniform pressure)", True),
    },
    "abutments": {
        "model": Key(str, "rigid: the springings bear on the ground; elastic: a block below each springing",
                     "rigid", choices=ABUTMENT_MODELS),
        "height": _length("from the springing line (y = 0) down to the abutment's base", 0.01, 10.0, None,
                          only=_ELASTIC, derived="required for elastic abutments",
                          why="from a low footing to a pier ten spans tall"),
        "length": _length("outwards from the springing's intrados corner, at least to its extrados corner", 0.0,
                          10.0, None, low_open=True, only=_ELASTIC, derived="to the springing's extrados corner",
                          why="from the springing joint's reach (the joint rests on the abutment) to a long "
                              "abutment wall"),
        "young": _modulus("Young's modulus of the abutments", None, only=_ELASTIC, derived="the masonry's"),
        "poisson": _poisson("Poisson's ratio of the abutments", None, only=_ELASTIC, derived="the masonry's"),
        "unit_weight": _unit_weight("weight density of the abutments", None, only=_ELASTIC,
                                    derived="masonry density x gravity"),
        "friction": _coefficient("Coulomb coefficient of the abutments' base joints", None, only=_ELASTIC,
                                 derived="the joints'"),
        "movement_springing": Key(str, "where the ground moves", "", choices=MOVING_SPRINGINGS,
                                  derived="none (required with a movement)"),
        "movement_horizontal": _movement("ground movement, positive = spreading (away from the span)"),
        "movement_vertical": _movement("ground movement, positive = up (a settlement is negative)"),
        "movement_steps": Key(int, "increments of the movement, after the self-weight, before the live load", 4,
                              low=1, high=1000, why="one to a thousand increments"),
    },
    "mesh": {
        "elements_through_thickness": Key(int, "elements through the ring thickness",
                                          _preset("mesh", "elements_through_thickness"), low=1, high=64,
                                          why="from one to a mesh finer than any mesh study needs"),
        "degree": Key(int, "Lagrange degree of the displacement", _preset("mesh", "degree"), choices=(1, 2)),
    },
    "model": {
        "plane": Key(str, "2D idealisation: plane strain or plane stress", "strain", choices=("strain", "stress")),
    },
    "solver": {
        "preset": Key(str, "speed-accuracy preset: defaults of the mesh keys and the tolerance (their own with a "
                      "Mohr-Coulomb fill)", "default",
                      choices=tuple(PRESETS)),
        "tolerance": Key(float, "relative width of the limit-load bracket", _preset("solver", "tolerance"),
                         low=1e-8, high=0.5, why="from the equilibrium residual (1e-8) to a bracket of a factor 2"),
        "max_iterations": Key(int, "active-set (Newton) iterations per load step", 60, low=1, high=10000,
                              why="from one to far more than any converging step takes"),
        "max_load": _force("live load where the search stops as \"locked\" (0: 100 x ring weight)"),
        "initial_step": _force("first live-load step (0: ring weight / 4)"),
        "max_steps": Key(int, "load steps in all", 200, low=1, high=100000,
                         why="from one to far more than any limit search takes"),
        "stiffness_drop": Key(float, "with a fill: a step whose secant stiffness, or tangent stiffness at its end, "
                              "falls below this fraction of the initial one marks the limit (0: off)", 0.02, low=0.0,
                              high=1.0, high_open=True, why="a fraction of the initial stiffness"),
        "petsc": Key(dict, "PETSc options of the contact solver, from the allow-list below", {}),
    },
}
"""Every scene key, by section ("load": the keys of each [[load]] table)."""
_REQUIRED_SECTIONS = ("arch", "masonry", "joints")
_OPTIONAL_SECTIONS = ("fill", "abutments", "vehicle")

_KSP_TOLERANCE = dict(unit="", low=0.0, low_open=True, high=1.0)
PETSC_SCENE_OPTIONS: dict[str, Key] = {
    "ksp_type": Key(str, "Krylov method (preonly: the direct solve alone)", choices=("preonly", "gmres", "fgmres",
                                                                                    "bcgs", "richardson")),
    "pc_type": Key(str, "preconditioner (lu: direct solve)", choices=("lu", "ilu", "jacobi", "sor", "none")),
    "pc_factor_mat_solver_type": Key(str, "direct solver package", choices=("mumps", "petsc", "superlu_dist")),
    "pc_factor_mat_ordering_type": Key(str, "fill-reducing ordering of PETSc's own LU",
                                       choices=("nd", "natural", "rcm", "qmd", "1wd")),
    "pc_factor_shift_type": Key(str, "pivot shift", choices=("none", "nonzero", "positive_definite", "inblocks")),
    "pc_factor_shift_amount": Key(float, "pivot shift amount", low=0.0, high=1.0),
    "ksp_rtol": Key(float, "relative tolerance of an iterative solve", **_KSP_TOLERANCE),
    "ksp_atol": Key(float, "absolute tolerance of an iterative solve", low=0.0, low_open=True, high=1e10),
    "ksp_divtol": Key(float, "divergence tolerance of an iterative solve", low=1.0, high=1e30),
    "ksp_max_it": Key(int, "iterations of an iterative solve", low=1, high=1000000),
}
"""PETSc options a scene's [solver.petsc] may set: solver settings only. Viewers, monitors, anything that reads or
writes a file or opens a display or socket is refused here; the command line (--petsc) may pass any option."""
MUMPS_ICNTL = {6: (0, 7), 7: (0, 7), 8: (-2, 77), 10: (-100, 100), 12: (0, 3), 13: (-1, 100000), 14: (0, 1000),
               23: (0, 100000), 24: (0, 1), 25: (-1, 100000), 28: (0, 2), 29: (0, 2), 35: (0, 3), 36: (0, 1),
               38: (0, 1000)}
"""MUMPS integer controls a scene may set (mat_mumps_icntl_N: allowed range): orderings, scaling, pivoting,
workspace (14: extra %, 23: MB, bounded so that a scene cannot ask for the machine's memory), null pivots, low
rank; not 1-4 (output streams and verbosity) nor 22 (out-of-core files)."""
MUMPS_CNTL = (1, 2, 3, 4, 5, 7)
"""MUMPS real controls a scene may set (mat_mumps_cntl_N): pivoting thresholds, refinement, low-rank dropping."""


def _petsc_key(name: str) -> Key | None:
    if name in PETSC_SCENE_OPTIONS:
        return PETSC_SCENE_OPTIONS[name]
    m = re.fullmatch(r"mat_mumps_(icntl|cntl)_([0-9]{1,2})", name)
    if m and m[1] == "icntl" and int(m[2]) in MUMPS_ICNTL:
        low, high = MUMPS_ICNTL[int(m[2])]
        return Key(int, f"MUMPS ICNTL({int(m[2])})", low=low, high=high)
    if m and m[1] == "cntl" and int(m[2]) in MUMPS_CNTL:
        return Key(float, "MUMPS CNTL", low=-1e30, high=1e30)
    return None


def _petsc_allowed() -> str:
    return (", ".join(PETSC_SCENE_OPTIONS) + ", mat_mumps_icntl_N (N = " + ", ".join(map(str, MUMPS_ICNTL))
            + "), mat_mumps_cntl_N (N = " + ", ".join(map(str, MUMPS_CNTL)) + ")")


def _default(section: str, key: str) -> Any:
    """A key's default, from :data:`SCHEMA` (the dataclasses' field defaults)."""
    return SCHEMA[section][key].default


@dataclass(frozen=True)
class Arch:
    """The masonry ring: lengths in m measured on the intrados (span, rise); thickness normal to the centreline."""

    shape: str
    span: float
    rise: float
    thickness: float
    width: float
    voussoirs: int
    joint_at_loads: bool = _default("arch", "joint_at_loads")


@dataclass(frozen=True)
class Masonry:
    """Voussoir material: Young's modulus (Pa), Poisson's ratio, density (kg/m^3)."""

    young: float
    poisson: float
    density: float


@dataclass(frozen=True)
class JointProperties:
    """Coulomb friction coefficient of every joint, springings included."""

    friction: float


@dataclass(frozen=True)
class Fill:
    """Backfill over the ring, in plane strain, between vertical ends and a base at the level of the springings'
    extrados corners (the rigid abutments below it are not meshed).

    unit_weight (N/m^3); young (Pa), poisson; depth (m): road level above the crown's extrados; extension (m):
    horizontal reach beyond each springing's extrados corner; material: "elastic" or "mohr-coulomb" (Drucker-Prager
    cone matched to Mohr-Coulomb in plane strain, see :mod:`bridgefem.laws.soil`) with friction_angle (degrees),
    cohesion (Pa), tension_cutoff (Pa, limit of the mean stress) and dilation_angle (degrees, 0 to friction_angle;
    None: equal to friction_angle, associated flow); interface_friction: Coulomb coefficient of
    the arch-fill interface (the extrados); element_size (m): mesh size away from the ring; loading_beam: patch
    loads reach the road through rigid loading beams (a test's spreader beam, a wheel's footprint) rather than as a
    flexible pressure, whose edge a frictional fill cannot carry (q <= c N_c at the edge of a uniform pressure).
    """

    unit_weight: float
    young: float
    depth: float
    extension: float
    poisson: float = _default("fill", "poisson")
    material: str = _default("fill", "material")
    friction_angle: float = _default("fill", "friction_angle")
    cohesion: float = _default("fill", "cohesion")
    tension_cutoff: float = _default("fill", "tension_cutoff")
    dilation_angle: float | None = _default("fill", "dilation_angle")
    interface_friction: float = _default("fill", "interface_friction")
    element_size: float = _default("fill", "element_size")
    loading_beam: bool = _default("fill", "loading_beam")


@dataclass(frozen=True)
class Abutments:
    """What carries the ring at its springings, and an optional imposed support movement.

    model: "rigid" (the springing joints bear on the rigid ground; no abutment mesh) or "elastic" (a block below
    each springing, from the springing line y = 0 down to y = -height (m), reaching ``length`` (m) outwards from
    the springing's intrados corner, with its own joints: the springing joint to the ring and its base to the
    rigid ground); young (Pa), poisson, unit_weight (N/m^3) of the blocks; friction: Coulomb coefficient of the
    base joints. Movement of the ground under ``movement_springing`` ("left", "right" or "both": under the
    springing joint, or under the abutment's base): movement_horizontal (m, positive = spreading, away from the
    span), movement_vertical (m, positive = up; a settlement is negative), imposed after the self-weight and
    before the live load in ``movement_steps`` equal increments.
    """

    model: str = _default("abutments", "model")
    height: float | None = None  # this key and the next five: elastic abutments only (None when rigid)
    length: float | None = None
    young: float | None = None
    poisson: float | None = None
    unit_weight: float | None = None
    friction: float | None = None
    movement_springing: str = _default("abutments", "movement_springing")
    movement_horizontal: float = _default("abutments", "movement_horizontal")
    movement_vertical: float = _default("abutments", "movement_vertical")
    movement_steps: int = _default("abutments", "movement_steps")

    @property
    def elastic(self) -> bool:
        return self.model == "elastic"

    @property
    def moves(self) -> bool:
        return bool(self.movement_horizontal or self.movement_vertical)


RIGID_ABUTMENTS = Abutments()


@dataclass(frozen=True)
class Load:
    """A vertical live load on the extrados, or on the road surface when the scene has a fill; ``position`` is the
    fraction of the span from the left springing (the centre of a patch), ``length`` the patch length along the
    span (m), ``factor`` its share of the load pattern (the live load is factor x load level, N)."""

    kind: str
    position: float
    length: float = _default("load", "length")
    factor: float = _default("load", "factor")
    x: float | None = _default("load", "x")

    def x_range(self, span: float) -> tuple[float, float]:
        """Horizontal extent on the extrados (m); a point load has zero length."""
        x = -span / 2 + self.position * span
        return x - self.length / 2, x + self.length / 2


@dataclass(frozen=True)
class Vehicle:
    """A vehicle rolled across the bridge (``bridgefem assess``): ``axles`` loads (N, for the scene's width), first
    (leftmost) axle first, ``spacing`` (m) between consecutive axles, ``contact_length`` (m) of each tyre patch
    along the road (0: point loads), ``dispersion``: how the rigid-block LP spreads an axle through a fill,
    ``standard``: the library vehicle (:data:`VEHICLES`) it was taken from, or ""."""

    axles: tuple[float, ...]
    spacing: tuple[float, ...]
    contact_length: float
    dispersion: str = _default("vehicle", "dispersion")
    standard: str = _default("vehicle", "standard")

    @property
    def offsets(self) -> np.ndarray:
        """Each axle's distance (m) behind the first (leftmost) one."""
        return np.concatenate([[0.0], np.cumsum(self.spacing)])

    @property
    def length(self) -> float:
        """From the first axle to the last (m)."""
        return float(sum(self.spacing))


@dataclass(frozen=True)
class MeshOptions:
    """Elements through the ring thickness and Lagrange degree of the displacement field (1 or 2)."""

    elements_through_thickness: int = _default("mesh", "elements_through_thickness")
    degree: int = _default("mesh", "degree")


@dataclass(frozen=True)
class ModelOptions:
    """2D idealisation: plane strain (default) or plane stress."""

    plane: str = _default("model", "plane")


@dataclass(frozen=True)
class SolverOptions:
    """Path following and semismooth Newton settings.

    tolerance: relative width of the limit-load bracket; max_iterations: active-set iterations per step;
    max_load: live load (N) at which the search stops as "locked" (0: 100 x ring weight);
    initial_step: first live-load step (N; 0: ring weight / 4); max_steps: load steps in all;
    petsc: PETSc options for the linear solver (prefix ``bridgefem_``), e.g. {pc_factor_mat_solver_type = "mumps"};
    preset: the speed-accuracy preset (:data:`PRESETS`, :data:`FILL_PRESETS` with a Mohr-Coulomb fill) that
    supplied the mesh and tolerance defaults;
    stiffness_drop: with a fill, a load step whose secant stiffness (load over deflection increment), or tangent
    stiffness at its converged state, falls below this fraction of the tangent stiffness after self-weight marks the
    limit (the load-deflection curve is flat: :mod:`bridgefem.search.pathfollow`, *Flat curve*; 0: only a lost equilibrium).
    """

    tolerance: float = _default("solver", "tolerance")
    max_iterations: int = _default("solver", "max_iterations")
    max_load: float = _default("solver", "max_load")
    initial_step: float = _default("solver", "initial_step")
    max_steps: int = _default("solver", "max_steps")
    petsc: dict = field(default_factory=dict)
    preset: str = _default("solver", "preset")
    stiffness_drop: float = _default("solver", "stiffness_drop")


@dataclass(frozen=True)
class Scene:
    """A validated scene; ``gravity`` in m/s^2. ``document``: the dictionary it was validated from (the TOML
    document as given, before defaults), which an edit re-validates with its changes
    (:mod:`bridgefem.scene.document`); not part of the scene's value."""

    name: str
    arch: Arch
    masonry: Masonry
    joints: JointProperties
    loads: tuple[Load, ...]
    gravity: float = _default("scene", "gravity")
    fill: Fill | None = None
    abutments: Abutments = RIGID_ABUTMENTS
    vehicle: Vehicle | None = None
    mesh: MeshOptions = MeshOptions()
    model: ModelOptions = ModelOptions()
    solver: SolverOptions = SolverOptions()
    document: dict | None = field(default=None, compare=False, repr=False)

    def load_edges_x(self) -> list[float]:
        """Horizontal positions (m) of point loads and patch edges: where joints go by default."""
        xs: list[float] = []
        for ld in self.loads:
            a, b = ld.x_range(self.arch.span)
            xs.extend([a] if ld.kind == "point" else [a, b])
        return xs


_BIDI = frozenset([0x061C, 0x200E, 0x200F, *range(0x202A, 0x202F), *range(0x2066, 0x206A)])


def unsafe_character(text: str) -> str | None:
    """The first character of ``text`` that must not be in a name bridgefem prints and creates, as "U+202E (...)",
    or None: C0 and C1 control characters and DEL (a terminal acts on them: ESC and CSI sequences), the Unicode
    bidirectional-text controls (they reorder how the name is shown: ``arch\\u202egpj.exe`` shows as
    ``archexe.jpg``), line and paragraph separators (a name in a one-line message) and bytes that are not UTF-8
    (decoded as lone surrogates, which cannot be printed)."""
    for c in text:
        code = ord(c)
        if code < 0x20 or 0x7F <= code <= 0x9F:
            what = "a control character"
        elif code in _BIDI:
            what = "a bidirectional-text control, which reorders how the name is shown"
        elif code in (0x2028, 0x2029):
            what = "a line or paragraph separator"
        elif 0xD800 <= code <= 0xDFFF:
            return f"byte 0x{code & 0xFF:02X} (not UTF-8)"
        else:
            continue
        return f"U+{code:04X} ({what})"
    return None


def check_name(name: str, where: str) -> str:
    """A scene name is a file name: 1 to MAX_NAME characters and MAX_NAME_BYTES bytes, no path separator, no
    control or bidi character (:func:`unsafe_character`: it is printed and names a folder), not
    starting with "." (so neither "." nor ".." nor a hidden folder)."""
    unsafe = unsafe_character(name)
    bad = (unsafe or not name or len(name) > MAX_NAME or len(name.encode()) > MAX_NAME_BYTES or name.startswith(".")
           or "/" in name or "\\" in name or name != name.strip())
    if bad:
        held = f" (it holds {unsafe})" if unsafe else ""
        raise SceneError(f"{where} = {_show(name)}{held}: allowed is a file name of 1 to {MAX_NAME} characters "
                         f"({MAX_NAME_BYTES} bytes in UTF-8) without /, \\, control or bidi characters or surrounding "
                         "spaces, not starting with \".\"")
    return name


def _section(data: Any, name: str, label: str, scales: dict[str, float]) -> dict[str, Any]:
    """The section's keys checked and typed, defaults filled in; a key that needs another key's value
    (:attr:`Key.only`) is refused without it. A relative range is checked against ``scales`` (:data:`SCALES`), to
    which the [arch] span is added when it is read (the ring's other lengths follow it in the section)."""
    if not isinstance(data, dict):
        raise SceneError(f"{label}: expected a table, got {_show(data)}")
    schema = SCHEMA[name]
    unknown = sorted(set(data) - set(schema))
    if unknown:
        raise SceneError(f"{label}: unknown key {_show(unknown[0])}; {did_you_mean(unknown[0], schema)}allowed keys "
                         f"are {', '.join(schema)}")
    out = {}
    for k, key in schema.items():
        where = f"{label} {k}"
        if k in data:
            out[k] = key.check(where, data[k], scales.get(key.per))
            if (name, k) == ("arch", "span"):
                scales["span"] = out[k]
        elif key.default is REQUIRED:
            raise SceneError(f"{where}: missing; expected {key.allowed()}")
        else:
            out[k] = key.default
    for k, key in schema.items():
        if key.only and k in data and out[key.only[0]] != key.only[1]:
            raise SceneError(f"{label} {k} = {_show(data[k])}: only for {key.only[0]} = \"{key.only[1]}\" "
                             f"({key.only[0]} is \"{out[key.only[0]]}\")")
    return out


def _petsc(table: dict[str, Any]) -> dict[str, Any]:
    """The scene's [solver.petsc] table, every key on the allow-list and its value checked."""
    out = {}
    for k, v in table.items():
        key = _petsc_key(k)
        if key is None:
            name = k if re.fullmatch(r"[A-Za-z0-9_]{1,60}", k) else _show(k)
            raise SceneError(f"[solver.petsc] {name}: not an allowed solver option; allowed in a "
                             f"scene are {_petsc_allowed()} (any other PETSc option only on the command line: --petsc)")
        out[k] = key.check(f"[solver.petsc] {k}", v)
    return out


def _check_rise(a: dict[str, Any]) -> float:
    span, rise, shape = a["span"], a["rise"], a["shape"]
    if shape == "semicircular":
        if rise is not None and not math.isclose(rise, span / 2, rel_tol=1e-6):
            raise SceneError(f"[arch] rise = {rise!r}: allowed for a semicircular arch is rise = span/2 = {span / 2:g} m "
                             "(omit rise, or use shape = \"segmental\" / \"elliptical\")")
        return span / 2
    if rise is None:
        raise SceneError(f"[arch] rise: missing; required for shape = \"{shape}\" "
                         f"({SCHEMA['arch']['rise'].allowed(span)})")
    key = SCHEMA["arch"]["rise"]
    limits = {"segmental": (rise <= span / 2, f"rise from {key.low:g} x span to span/2 = {span / 2:g} m"),
              "pointed": (rise >= span / 2, f"rise from span/2 = {span / 2:g} m to {key.high:g} x span")}
    ok, allowed = limits.get(shape, (True, ""))
    if not ok:
        raise SceneError(f"[arch] rise = {rise!r}: for shape = \"{shape}\" allowed is {allowed}")
    return rise


def scene_from_dict(data: dict[str, Any], default_name: str = "scene") -> Scene:
    """Validate a parsed TOML document and build a :class:`Scene`."""
    unknown = sorted(set(data) - set(SCHEMA) - {"load"})
    if unknown:
        hint = did_you_mean(unknown[0], SCHEMA, lambda s: "[[load]]" if s == "load" else f"[{s}]")
        raise SceneError(f"[{_show(unknown[0])[1:-1]}]: unknown section; {hint}allowed sections are "
                         + ", ".join(f"[{s}]" for s in SCHEMA if s != "load") + ", [[load]]")
    for name in _REQUIRED_SECTIONS:
        if name not in data:
            raise SceneError(f"[{name}]: missing section; expected the sections "
                             + ", ".join(f"[{n}]" for n in _REQUIRED_SECTIONS) + " (and others as needed)")
    scales: dict[str, float] = {}
    sec: dict[str, dict[str, Any]] = {}
    for section in SCHEMA:
        if section == "load" or (section not in data and section in _OPTIONAL_SECTIONS):
            continue
        sec[section] = _section(data.get(section, {}), section, f"[{section}]", scales)
        if section == "arch":
            sec[section]["rise"] = _check_rise(sec[section])
        elif section == "masonry":
            scales["ring weight"] = ring_weight(sec["arch"], sec["masonry"]["density"], sec["scene"]["gravity"])
    name = check_name(sec["scene"]["name"], "[scene] name") if sec["scene"]["name"] is not None else default_name
    preset = sec["solver"]["preset"]
    plastic_fill = "fill" in sec and sec["fill"]["material"] == "mohr-coulomb"
    for (section, key), value in (FILL_PRESETS if plastic_fill else PRESETS)[preset].items():
        if key not in data.get(section, {}):
            sec[section][key] = value
    a = sec["arch"]
    raw_loads = data.get("load", [])
    if not isinstance(raw_loads, list):
        raise SceneError(f"[[load]] = {_show(raw_loads)}: expected [[load]] tables (none: self-weight only)")
    if len(raw_loads) > MAX_LOADS:
        raise SceneError(f"[[load]]: {len(raw_loads)} tables; allowed are at most {MAX_LOADS}")
    loads = []
    for i, raw in enumerate(raw_loads):
        label = f"[[load]] #{i + 1}"
        ld = Load(**_placed(_section(raw, "load", label, scales), label, a["span"]))
        if ld.kind == "point" and ld.length:
            raise SceneError(f"{label} length = {ld.length!r}: a point load has no length (use kind = \"patch\")")
        if ld.kind == "patch" and ld.length == 0:
            patch = replace(SCHEMA["load"]["length"], zero=False).allowed(a["span"])
            raise SceneError(f"{label} length = {ld.length!r}: a patch load needs a length; allowed is {patch}")
        lo, hi = ld.x_range(a["span"])
        if lo < -a["span"] / 2 * (1 + RANGE_RTOL) or hi > a["span"] / 2 * (1 + RANGE_RTOL):
            raise SceneError(f"{label} position = {ld.position!r}, length = {ld.length!r}: the load spans "
                             f"x = {lo:g}..{hi:g} m; allowed is a load within the span, x = -{a['span'] / 2:g}..{a['span'] / 2:g} m")
        loads.append(ld)
    solver = {**sec["solver"], "petsc": _petsc(sec["solver"]["petsc"])}
    fill = Fill(**sec["fill"]) if "fill" in sec else None
    if fill is not None and fill.material == "mohr-coulomb" and fill.friction_angle == 0 and fill.cohesion == 0:
        raise SceneError("[fill] cohesion = 0.0: a mohr-coulomb fill with friction_angle = 0 needs cohesion > 0")
    if fill is not None and fill.dilation_angle is not None and fill.dilation_angle > fill.friction_angle:
        raise SceneError(f"[fill] dilation_angle = {fill.dilation_angle!r}: allowed is an angle from 0 to "
                         f"friction_angle = {fill.friction_angle:g} degrees")
    if fill is not None and fill.material == "mohr-coulomb":
        for i, ld in enumerate(loads):
            if ld.kind == "point":
                raise SceneError(f"[[load]] #{i + 1} kind = \"point\": a point force on a Mohr-Coulomb fill has no "
                                 "finite collapse load; allowed is kind = \"patch\" with the length of the wheel or "
                                 "loading beam")
    if fill is not None and fill.loading_beam:
        _beams_apart(loads, a["span"])
    abutments = _abutments(sec["abutments"], sec) if "abutments" in sec else RIGID_ABUTMENTS
    vehicle = _vehicle(sec["vehicle"], scales, fill) if "vehicle" in sec else None
    return Scene(name=name, gravity=sec["scene"]["gravity"], fill=fill, abutments=abutments, vehicle=vehicle,
                 arch=Arch(**a), masonry=Masonry(**sec["masonry"]), joints=JointProperties(**sec["joints"]),
                 loads=tuple(loads), mesh=MeshOptions(**sec["mesh"]), model=ModelOptions(**sec["model"]),
                 solver=SolverOptions(**solver), document=copy.deepcopy(data))


def _placed(ld: dict[str, Any], label: str, span: float) -> dict[str, Any]:
    """A load's place from ``position`` (fraction of the span) or ``x`` (m from the left springing): one of them,
    or both when they agree (as ``bridgefem check`` prints them); both are kept."""
    if ld["position"] is None and ld["x"] is None:
        raise SceneError(f"{label} position: missing; expected position ({SCHEMA['load']['position'].allowed()}) "
                         f"or x ({SCHEMA['load']['x'].allowed(span)})")
    if ld["x"] is None:
        return {**ld, "x": ld["position"] * span}
    if ld["position"] is not None and abs(ld["position"] * span - ld["x"]) > 1e-9 * span:
        raise SceneError(f"{label} x = {ld['x']!r}: position = {ld['position']!r} places the load at "
                         f"x = {ld['position'] * span:.9g} m; allowed is one of them, or both agreeing")
    return {**ld, "position": ld["x"] / span}


def _vehicle(v: dict[str, Any], scales: dict[str, float], fill: Fill | None) -> Vehicle:
    """The [vehicle] table checked: a library vehicle (``standard``) or ``axles`` and ``spacing`` (each load from
    1e-6 to 1e6 x the ring's weight, each spacing longer than the tyre contact, at most 10 x span)."""
    span, weight = scales["span"], scales["ring weight"]
    if v["standard"]:
        if v["axles"] is not None or v["spacing"] is not None:
            given = "axles" if v["axles"] is not None else "spacing"
            raise SceneError(f"[vehicle] {given} = {_show(v[given])}: standard = \"{v['standard']}\" sets the axles "
                             "and their spacing; allowed is standard or axles and spacing, not both")
        lib = VEHICLES[v["standard"]]
        axles, spacing = list(lib["axles"]), list(lib["spacing"])
        contact = lib["contact_length"] if v["contact_length"] is None else v["contact_length"]
    else:
        if v["axles"] is None:
            raise SceneError("[vehicle] axles: missing; expected a list of axle loads in N (or standard = one of "
                             + ", ".join(f'"{n}"' for n in VEHICLES) + ")")
        axles, spacing = v["axles"], v["spacing"] if v["spacing"] is not None else []
        contact = v["contact_length"] or 0.0
    if not 1 <= len(axles) <= MAX_AXLES:
        raise SceneError(f"[vehicle] axles = {_show(axles)}: allowed is a list of 1 to {MAX_AXLES} axle loads in N")
    for a in axles:
        if isinstance(a, bool) or not isinstance(a, (int, float)) or not math.isfinite(a) \
                or not 1e-6 * weight <= a <= 1e6 * weight:
            raise SceneError(f"[vehicle] axles = {_show(axles)}: allowed are axle loads in N from 1e-6 to 1e6 x the "
                             f"ring's weight ({1e-6 * weight:.4g} to {1e6 * weight:.4g} N in this scene)")
    if len(spacing) != len(axles) - 1:
        raise SceneError(f"[vehicle] spacing = {_show(spacing)}: allowed is a list of {len(axles) - 1} distances "
                         f"in m (one between each two consecutive axles of the {len(axles)})")
    for d in spacing:
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not math.isfinite(d) \
                or not contact < d <= 10 * span:
            raise SceneError(f"[vehicle] spacing = {_show(spacing)}: allowed are distances in m longer than the "
                             f"contact length ({contact:g} m) and at most 10 x span ({10 * span:g} m)")
    if fill is not None and fill.material == "mohr-coulomb" and contact == 0:
        raise SceneError("[vehicle] contact_length = 0: a point axle on a Mohr-Coulomb fill has no finite collapse "
                         f"load; allowed is {SCHEMA['vehicle']['contact_length'].allowed(span)}, the tyre patch "
                         "along the road")
    return Vehicle(tuple(float(a) for a in axles), tuple(float(d) for d in spacing), float(contact),
                   v["dispersion"], v["standard"])


def _beams_apart(loads: list[Load], span: float) -> None:
    """With ``[fill] loading_beam`` each patch has its own rigid beam on the road: two patches may not overlap or
    touch (their beams would share road or a side)."""
    ranges = sorted((ld.x_range(span), i) for i, ld in enumerate(loads) if ld.kind == "patch")
    for ((a0, b0), i), ((a1, b1), j) in zip(ranges[:-1], ranges[1:]):
        if a1 <= b0:
            raise SceneError(f"[[load]] #{i + 1} and #{j + 1}: the patches over x = [{a0:.6g}, {b0:.6g}] and "
                             f"[{a1:.6g}, {b1:.6g}] m touch or overlap, and so would their loading beams; allowed: "
                             "patches apart, or [fill] loading_beam = false (pressures)")


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


def scene_scales(scene: Scene) -> dict[str, float]:
    """What the scene's relative ranges are multiples of (:data:`SCALES`): its span (m) and its ring's weight (N)."""
    return {"span": scene.arch.span,
            "ring weight": ring_weight(asdict(scene.arch), scene.masonry.density, scene.gravity)}


def springing_reach(arch: dict[str, Any]) -> float:
    """Horizontal distance (m) from a springing's intrados corner to its extrados corner."""
    shape = make_shape(arch["shape"], arch["span"], arch["rise"])
    return float(abs(arch["thickness"] * shape.normal(0.0)[0]))


def _abutments(ab: dict[str, Any], sec: dict[str, dict[str, Any]]) -> Abutments:
    """Check the [abutments] keys against each other and fill in the defaults taken from the masonry and joints."""
    if (ab["movement_horizontal"] or ab["movement_vertical"]) and not ab["movement_springing"]:
        raise SceneError("[abutments] movement_springing: missing; required with a support movement "
                         "(" + SCHEMA["abutments"]["movement_springing"].allowed() + ")")
    if ab["model"] == "rigid":
        return Abutments(**ab)
    if ab["height"] is None:
        raise SceneError("[abutments] height: missing; required for model = \"elastic\" "
                         f"({SCHEMA['abutments']['height'].allowed(sec['arch']['span'])})")
    reach = springing_reach(sec["arch"])
    if ab["length"] is not None and ab["length"] < reach * (1 - 1e-9):
        raise SceneError(f"[abutments] length = {ab['length']!r}: allowed is a length >= {reach:g} m, the "
                         "springing joint's horizontal reach (the joint must rest on the abutment)")
    m = sec["masonry"]
    defaults = {"length": reach, "young": m["young"], "poisson": m["poisson"],
                "unit_weight": m["density"] * sec["scene"]["gravity"], "friction": sec["joints"]["friction"]}
    ab.update({k: v for k, v in defaults.items() if ab[k] is None})
    return Abutments(**ab)


def show_path(path: str | Path) -> str:
    """A file name for a one-line message: as given, or its repr (cut) when it holds control characters or is
    long."""
    text = os.fsdecode(path)
    return text if len(text) <= 200 and text.isprintable() else _show(text, 200)


def read_scene_text(path: str | Path) -> str:
    """The text of a scene file: a regular file (not a folder, FIFO, device or socket, refused before reading),
    at most MAX_SCENE_BYTES, in UTF-8."""
    where = show_path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)  # O_NONBLOCK: a FIFO cannot block
    except FileNotFoundError:
        raise SceneError(f"{where}: no such scene file") from None
    except PermissionError:
        raise SceneError(f"{where}: cannot read the scene file (permission denied)") from None
    except ValueError:
        raise SceneError(f"{where}: not a usable file name (it holds a NUL character)") from None
    except OSError as err:
        raise SceneError(f"{where}: cannot open the scene file ({err.strerror})") from None
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise SceneError(f"{where}: is a folder; expected a scene file (TOML)")
        if not stat.S_ISREG(mode):
            raise SceneError(f"{where}: not a regular file (a FIFO, device or socket); expected a scene file (TOML)")
        chunks, size = [], 0
        while size <= MAX_SCENE_BYTES and (chunk := os.read(fd, MAX_SCENE_BYTES + 1 - size)):
            chunks.append(chunk)
            size += len(chunk)
        raw = b"".join(chunks)
    except OSError as err:
        raise SceneError(f"{where}: cannot read the scene file ({err.strerror})") from None
    finally:
        os.close(fd)
    if len(raw) > MAX_SCENE_BYTES:
        raise SceneError(f"{where}: larger than {MAX_SCENE_BYTES} bytes; a scene file is a short TOML text")
    try:
        return raw.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as err:
        raise SceneError(f"{where}: not UTF-8 text (byte {err.start}); a scene file is TOML in UTF-8") from None


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; the scene name defaults to the file name without extension."""
    text = read_scene_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{show_path(path)}: not valid TOML ({err})") from None
    except RecursionError:
        raise SceneError(f"{show_path(path)}: not valid TOML (nested too deeply)") from None
    stem = Path(os.fsdecode(path)).stem
    named = isinstance(data.get("scene"), dict) and "name" in data["scene"]
    if not named:
        check_name(stem, f"{show_path(path)}: the file name gives the scene name")
    return scene_from_dict(data, default_name=stem)


# ----------------------------------------------------------------------------- the resolved scene and the keys
def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, float) and len(repr(value)) > 12 and float(f"{value:g}") == value:
        return f"{value:g}"  # 1e+10, not 10000000000.0
    return repr(value)


def resolved_toml(scene: Scene) -> str:
    """The scene with every key resolved (defaults, preset and derived values filled in), as TOML with each
    key's unit: what ``bridgefem check`` prints. Reading it back gives the same scene."""
    objects = {"scene": scene, "arch": scene.arch, "masonry": scene.masonry, "joints": scene.joints,
               "fill": scene.fill, "abutments": scene.abutments, "mesh": scene.mesh, "model": scene.model,
               "solver": scene.solver, "vehicle": scene.vehicle}
    lines: list[str] = []

    def table(header: str, section: str, obj: Any) -> None:
        lines.append(header)
        for k, key in SCHEMA[section].items():
            value = getattr(obj, k)
            if k == "petsc" or value is None or value == "" or (key.only and getattr(obj, key.only[0]) != key.only[1]) \
                    or (section == "vehicle" and k in ("axles", "spacing") and obj.standard):
                continue
            note = "  # " + key.unit if key.unit else ""
            lines.append(f"{k} = {_toml_value(value)}{note}")
        lines.append("")

    for section in SCHEMA:
        if section == "load":
            for ld in scene.loads:
                table("[[load]]", "load", ld)
        elif objects[section] is not None:
            table(f"[{section}]", section, objects[section])
    if scene.solver.petsc:
        lines += ["[solver.petsc]"] + [f"{k} = {_toml_value(v)}" for k, v in scene.solver.petsc.items()] + [""]
    return "\n".join(lines)


def keys_markdown() -> str:
    """docs/scene-keys.md: a table of every scene key (generated from :data:`SCHEMA`)."""
    out = ["# Scene keys", "",
           "Generated from `bridgefem/scene/schema.py` (`SCHEMA`) by `./run python -m bridgefem.scene.schema`; a test checks "
           "that this file is up to date. Units are SI; *required* keys have no default.", "",
           "Every number has a range a real bridge can have (the last column says why). The bridge's lengths have "
           "ranges relative to the span (\"x span\": the [arch] span), so that they hold for a bridge of any size, "
           "and the solver's forces relative to the ring's weight (density x gravity x width x the ring's area); "
           "`bridgefem check` prints a value outside its range with the bounds it has in that scene. A value "
           "outside its range stops every command (run, check, lp, bounds, min-thickness, converge) with one "
           "line naming the key, the value and the range, exit code 2, before anything is written.", ""]
    for section, keys in SCHEMA.items():
        out += ["## [[load]]" if section == "load" else f"## [{section}]", "",
                "| key | default | unit | allowed | meaning | why this range |", "|---|---|---|---|---|---|"]
        for k, key in keys.items():
            default = ("*required*" if key.default is REQUIRED else key.derived if key.derived
                       else "{}" if key.default == {} else _toml_value(key.default))
            only = f" (only with {key.only[0]} = \"{key.only[1]}\")" if key.only else ""
            out.append(f"| `{k}` | {default} | {key.unit} | {key.allowed()} | {key.doc}{only} | {key.why} |")
        out.append("")
    out += ["## [solver.petsc]", "",
            "A scene may set only these solver options (prefix `bridgefem_` is added); anything else, e.g. "
            "viewers and monitors, only on the command line (`--petsc KEY=VALUE`).", "",
            "| key | allowed | meaning |", "|---|---|---|"]
    out += [f"| `{k}` | {key.allowed()} | {key.doc} |" for k, key in PETSC_SCENE_OPTIONS.items()]
    out += [f"| `mat_mumps_icntl_{n}` | {_petsc_key(f'mat_mumps_icntl_{n}').allowed()} | MUMPS ICNTL({n}) |"
            for n in MUMPS_ICNTL]
    out += [
            f"| `mat_mumps_cntl_N`, N = {', '.join(map(str, MUMPS_CNTL))} | {_petsc_key('mat_mumps_cntl_1').allowed()} "
            "| MUMPS real controls |", ""]
    return "\n".join(out)


if __name__ == "__main__":
    print(keys_markdown(), end="")


def with_mesh(scene: Scene, elements_through_thickness: int) -> Scene:
    """The scene with its ring (and so its fill) meshed by this many elements through the thickness."""
    return dataclasses.replace(scene, mesh=dataclasses.replace(scene.mesh,
                                                               elements_through_thickness=elements_through_thickness))
