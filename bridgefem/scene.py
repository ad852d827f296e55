"""Scene files (TOML): read, validate and hold everything a run needs, in SI units.

Every rejected value raises :class:`SceneError` naming the key, the value and what is allowed;
the command line turns it into exit code 2 before anything is written.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from .geometry import SHAPES, make_shape


class SceneError(ValueError):
    """A scene value that cannot be used; the message names key, value and what is allowed."""


@dataclass(frozen=True)
class Arch:
    """The masonry ring: lengths in m measured on the intrados (span, rise); thickness normal to the centreline."""

    shape: str
    span: float
    rise: float
    thickness: float
    width: float
    voussoirs: int
    joint_at_loads: bool = True


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
    cone matched to Mohr-Coulomb in plane strain, see :mod:`bridgefem.plasticity`) with friction_angle (degrees),
    cohesion (Pa), tension_cutoff (Pa, limit of the mean stress) and dilation_angle (degrees, 0 to friction_angle;
    None: equal to friction_angle, associated flow); interface_friction: Coulomb coefficient of
    the arch-fill interface (the extrados); element_size (m): mesh size away from the ring.
    """

    unit_weight: float
    young: float
    depth: float
    extension: float
    poisson: float = 0.3
    material: str = "elastic"
    friction_angle: float = 30.0
    cohesion: float = 0.0
    tension_cutoff: float = 0.0
    dilation_angle: float | None = None
    interface_friction: float = 0.5
    element_size: float = 0.0


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

    model: str = "rigid"
    height: float | None = None  # this key and the next five: elastic abutments only (None when rigid)
    length: float | None = None
    young: float | None = None
    poisson: float | None = None
    unit_weight: float | None = None
    friction: float | None = None
    movement_springing: str = ""
    movement_horizontal: float = 0.0
    movement_vertical: float = 0.0
    movement_steps: int = 4

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
    length: float = 0.0
    factor: float = 1.0

    def x_range(self, span: float) -> tuple[float, float]:
        """Horizontal extent on the extrados (m); a point load has zero length."""
        x = -span / 2 + self.position * span
        return x - self.length / 2, x + self.length / 2


@dataclass(frozen=True)
class MeshOptions:
    """Elements through the ring thickness and Lagrange degree of the displacement field (1 or 2)."""

    elements_through_thickness: int = 4
    degree: int = 1


@dataclass(frozen=True)
class ModelOptions:
    """2D idealisation: plane strain (default) or plane stress."""

    plane: str = "strain"


@dataclass(frozen=True)
class SolverOptions:
    """Path following and semismooth Newton settings.

    tolerance: relative width of the limit-load bracket; max_iterations: active-set iterations per step;
    max_load: live load (N) at which the search stops as "locked" (0: 100 x ring weight);
    initial_step: first live-load step (N; 0: ring weight / 4); max_steps: load steps in all;
    petsc: PETSc options for the linear solver (prefix ``bridgefem_``), e.g. {pc_factor_mat_solver_type = "mumps"};
    preset: the speed-accuracy preset (:data:`PRESETS`) that supplied the mesh and tolerance defaults;
    stiffness_drop: with a fill, a load step whose secant stiffness falls below this fraction of the tangent
    stiffness after self-weight marks the limit (the load-deflection curve is flat; 0: only a lost equilibrium).
    """

    tolerance: float = 0.0001
    max_iterations: int = 60
    max_load: float = 0.0
    initial_step: float = 0.0
    max_steps: int = 200
    petsc: dict = field(default_factory=dict)
    preset: str = "default"
    stiffness_drop: float = 0.02


@dataclass(frozen=True)
class Scene:
    """A validated scene; ``gravity`` in m/s^2."""

    name: str
    arch: Arch
    masonry: Masonry
    joints: JointProperties
    loads: tuple[Load, ...]
    gravity: float = 9.81
    fill: Fill | None = None
    abutments: Abutments = RIGID_ABUTMENTS
    mesh: MeshOptions = MeshOptions()
    model: ModelOptions = ModelOptions()
    solver: SolverOptions = SolverOptions()

    def load_edges_x(self) -> list[float]:
        """Horizontal positions (m) of point loads and patch edges: where joints go by default."""
        xs: list[float] = []
        for ld in self.loads:
            a, b = ld.x_range(self.arch.span)
            xs.extend([a] if ld.kind == "point" else [a, b])
        return xs


PRESETS: dict[str, dict[tuple[str, str], Any]] = {
    "fast": {("mesh", "elements_through_thickness"): 2, ("mesh", "degree"): 1, ("solver", "tolerance"): 0.0005},
    "default": {("mesh", "elements_through_thickness"): 4, ("mesh", "degree"): 1, ("solver", "tolerance"): 0.0001},
    "accurate": {("mesh", "elements_through_thickness"): 8, ("mesh", "degree"): 1, ("solver", "tolerance"): 0.0001},
}
"""Speed-accuracy presets (``[solver] preset``): the mesh and bracket settings they imply, all three on the Pareto
front measured by ``demos/speed_accuracy.py`` (README, "Speed and accuracy"): ``fast`` the most accurate within
the cost of the cheapest run, ``default`` the cheapest within a worst error bound of 0.05 %, ``accurate`` within
0.02 %.
A key given explicitly in the scene overrides its preset value."""

_REQUIRED = object()


@dataclass(frozen=True)
class _Key:
    kind: type
    default: Any = _REQUIRED
    check: Callable[[Any], bool] = lambda v: True
    allowed: str = ""


def _positive(v):
    return v > 0 and math.isfinite(v)


def _finite(v):
    return math.isfinite(v)


FILL_MATERIALS = ("elastic", "mohr-coulomb")
ABUTMENT_MODELS = ("rigid", "elastic")
MOVING_SPRINGINGS = ("left", "right", "both")
_ELASTIC_ONLY = ("height", "length", "young", "poisson", "unit_weight", "friction")  # [abutments] keys

_SCHEMA: dict[str, dict[str, _Key]] = {
    "scene": {
        "name": _Key(str, None, lambda v: bool(v.strip()), "a non-empty string"),
        "gravity": _Key(float, 9.81, _positive, "a positive number (m/s^2)"),
    },
    "arch": {
        "shape": _Key(str, check=lambda v: v in SHAPES, allowed="one of " + ", ".join(SHAPES)),
        "span": _Key(float, check=_positive, allowed="a positive length in m"),
        "rise": _Key(float, None, _positive, "a positive length in m"),
        "thickness": _Key(float, check=_positive, allowed="a positive length in m"),
        "width": _Key(float, 1.0, _positive, "a positive length in m"),
        "voussoirs": _Key(int, check=lambda v: 2 <= v <= 4096, allowed="an integer from 2 to 4096"),
        "joint_at_loads": _Key(bool, True),
    },
    "masonry": {
        "young": _Key(float, check=_positive, allowed="a positive modulus in Pa"),
        "poisson": _Key(float, 0.2, lambda v: 0 <= v < 0.5, allowed="0 <= poisson < 0.5"),
        "density": _Key(float, check=_positive, allowed="a positive density in kg/m^3"),
    },
    "joints": {
        "friction": _Key(float, check=lambda v: v >= 0 and math.isfinite(v), allowed="a number >= 0"),
    },
    "load": {
        "kind": _Key(str, check=lambda v: v in ("point", "patch"), allowed="point or patch"),
        "position": _Key(float, check=lambda v: 0 <= v <= 1, allowed="a fraction of the span from 0 to 1"),
        "length": _Key(float, 0.0, lambda v: v >= 0, "a length >= 0 in m (patch loads only)"),
        "factor": _Key(float, 1.0, _positive, "a positive share of the load pattern"),
    },
    "fill": {
        "unit_weight": _Key(float, check=_positive, allowed="a positive weight density in N/m^3"),
        "young": _Key(float, check=_positive, allowed="a positive modulus in Pa"),
        "depth": _Key(float, check=_positive, allowed="a positive depth in m of the road above the crown extrados"),
        "extension": _Key(float, check=_positive, allowed="a positive length in m beyond each springing"),
        "poisson": _Key(float, 0.3, lambda v: 0 <= v < 0.5, "0 <= poisson < 0.5"),
        "material": _Key(str, "elastic", lambda v: v in FILL_MATERIALS, " or ".join(FILL_MATERIALS)),
        "friction_angle": _Key(float, 30.0, lambda v: 0 <= v <= 60, "an angle from 0 to 60 degrees"),
        "cohesion": _Key(float, 0.0, lambda v: 0 <= v < math.inf, "a stress >= 0 in Pa"),
        "tension_cutoff": _Key(float, 0.0, lambda v: 0 <= v < math.inf, "a stress >= 0 in Pa"),
        "dilation_angle": _Key(float, None, lambda v: 0 <= v <= 60, "an angle from 0 to friction_angle in degrees "
                               "(default: friction_angle, associated flow)"),
        "interface_friction": _Key(float, 0.5, lambda v: 0 <= v < math.inf, "a number >= 0"),
        "element_size": _Key(float, 0.0, lambda v: 0 <= v < math.inf, "a length >= 0 in m (0: automatic)"),
    },
    "abutments": {
        "model": _Key(str, "rigid", lambda v: v in ABUTMENT_MODELS, " or ".join(f'"{m}"' for m in ABUTMENT_MODELS)),
        "height": _Key(float, None, _positive, "a positive depth in m of the base below the springing line"),
        "length": _Key(float, None, _positive, "a positive length in m outwards from the springing's intrados"),
        "young": _Key(float, None, _positive, "a positive modulus in Pa (default: the masonry's)"),
        "poisson": _Key(float, None, lambda v: 0 <= v < 0.5, "0 <= poisson < 0.5 (default: the masonry's)"),
        "unit_weight": _Key(float, None, _positive, "a positive weight density in N/m^3 (default: the masonry's)"),
        "friction": _Key(float, None, lambda v: 0 <= v < math.inf, "a number >= 0 (default: the joints')"),
        "movement_springing": _Key(str, None, lambda v: v in MOVING_SPRINGINGS,
                                   " or ".join(f'"{m}"' for m in MOVING_SPRINGINGS)),
        "movement_horizontal": _Key(float, 0.0, _finite, "a length in m (positive: spreading, away from the span)"),
        "movement_vertical": _Key(float, 0.0, _finite, "a length in m (positive: up; settlement negative)"),
        "movement_steps": _Key(int, 4, lambda v: 1 <= v <= 1000, "an integer from 1 to 1000"),
    },
    "mesh": {
        "elements_through_thickness": _Key(int, 4, lambda v: 1 <= v <= 64, "an integer from 1 to 64"),
        "degree": _Key(int, 1, lambda v: v in (1, 2), "1 or 2"),
    },
    "model": {
        "plane": _Key(str, "strain", lambda v: v in ("strain", "stress"), "strain or stress"),
    },
    "solver": {
        "tolerance": _Key(float, 0.0001, lambda v: 1e-8 <= v <= 0.5, "a relative tolerance from 1e-8 to 0.5"),
        "max_iterations": _Key(int, 60, lambda v: 1 <= v <= 10000, "an integer from 1 to 10000"),
        "max_load": _Key(float, 0.0, lambda v: v >= 0, "a load >= 0 in N (0: automatic)"),
        "initial_step": _Key(float, 0.0, lambda v: v >= 0, "a load >= 0 in N (0: automatic)"),
        "max_steps": _Key(int, 200, lambda v: 1 <= v <= 100000, "an integer from 1 to 100000"),
        "petsc": _Key(dict, {}),
        "preset": _Key(str, "default", lambda v: v in PRESETS, "one of " + ", ".join(f'"{p}"' for p in PRESETS)),
        "stiffness_drop": _Key(float, 0.02, lambda v: 0 <= v < 1, "a fraction from 0 (off) to below 1 of the "
                               "initial stiffness (used only with a fill)"),
    },
}
_REQUIRED_SECTIONS = ("arch", "masonry", "joints")
_OPTIONAL_SECTIONS = ("fill", "abutments")


def _typed(where: str, value: Any, key: _Key) -> Any:
    if key.kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, key.kind) or (key.kind is int and isinstance(value, bool)):
        raise SceneError(f"{where} = {value!r}: expected {key.kind.__name__}"
                         + (f" ({key.allowed})" if key.allowed else ""))
    if not key.check(value):
        raise SceneError(f"{where} = {value!r}: allowed is {key.allowed}")
    return value


def _section(data: Any, name: str, label: str) -> dict[str, Any]:
    if not isinstance(data, dict):
        raise SceneError(f"{label}: expected a table, got {data!r}")
    schema = _SCHEMA[name]
    unknown = sorted(set(data) - set(schema))
    if unknown:
        raise SceneError(f"{label}: unknown key {unknown[0]!r}; allowed keys are {', '.join(schema)}")
    out = {}
    for k, key in schema.items():
        where = f"{label} {k}"
        if k in data:
            out[k] = _typed(where, data[k], key)
        elif key.default is _REQUIRED:
            raise SceneError(f"{where}: missing; expected {key.kind.__name__} ({key.allowed})")
        else:
            out[k] = key.default
    return out


def _check_rise(a: dict[str, Any]) -> float:
    span, rise, shape = a["span"], a["rise"], a["shape"]
    if shape == "semicircular":
        if rise is not None and not math.isclose(rise, span / 2, rel_tol=1e-6):
            raise SceneError(f"[arch] rise = {rise!r}: a semicircular arch has rise = span/2 = {span / 2:g} m "
                             "(omit rise, or use shape = \"segmental\" / \"elliptical\")")
        return span / 2
    if rise is None:
        raise SceneError(f"[arch] rise: missing; required for shape = \"{shape}\" (a positive length in m)")
    limits = {"segmental": (rise <= span / 2, f"0 < rise <= span/2 = {span / 2:g} m"),
              "pointed": (rise >= span / 2, f"rise >= span/2 = {span / 2:g} m"),
              "elliptical": (rise <= 2 * span, f"0 < rise <= 2 x span = {2 * span:g} m"),
              "parabolic": (rise <= 2 * span, f"0 < rise <= 2 x span = {2 * span:g} m")}
    ok, allowed = limits[shape]
    if not ok:
        raise SceneError(f"[arch] rise = {rise!r}: for shape = \"{shape}\" allowed is {allowed}")
    return rise


def scene_from_dict(data: dict[str, Any], default_name: str = "scene") -> Scene:
    """Validate a parsed TOML document and build a :class:`Scene`."""
    unknown = sorted(set(data) - set(_SCHEMA) - {"load"})
    if unknown:
        raise SceneError(f"[{unknown[0]}]: unknown section; allowed sections are "
                         + ", ".join(f"[{s}]" for s in _SCHEMA if s != "load") + ", [[load]]")
    for name in _REQUIRED_SECTIONS:
        if name not in data:
            raise SceneError(f"[{name}]: missing section")
    sec = {name: _section(data.get(name, {}), name, f"[{name}]") for name in _SCHEMA
           if name != "load" and (name in data or name not in _OPTIONAL_SECTIONS)}
    for (name, key), value in PRESETS[sec["solver"]["preset"]].items():
        if key not in data.get(name, {}):
            sec[name][key] = value
    a = sec["arch"]
    a["rise"] = _check_rise(a)
    if a["thickness"] >= a["span"]:
        raise SceneError(f"[arch] thickness = {a['thickness']!r}: allowed is 0 < thickness < span = {a['span']:g} m")
    raw_loads = data.get("load", [])
    if not isinstance(raw_loads, list):
        raise SceneError(f"[[load]] = {raw_loads!r}: expected [[load]] tables (none: self-weight only)")
    loads = []
    for i, raw in enumerate(raw_loads):
        label = f"[[load]] #{i + 1}"
        ld = Load(**_section(raw, "load", label))
        if ld.kind == "point" and ld.length:
            raise SceneError(f"{label} length = {ld.length!r}: a point load has no length (use kind = \"patch\")")
        if ld.kind == "patch" and ld.length <= 0:
            raise SceneError(f"{label} length = {ld.length!r}: a patch load needs a positive length in m")
        lo, hi = ld.x_range(a["span"])
        if lo < -a["span"] / 2 - 1e-12 or hi > a["span"] / 2 + 1e-12:
            raise SceneError(f"{label} position = {ld.position!r}, length = {ld.length!r}: the load spans "
                             f"x = {lo:g}..{hi:g} m, outside the span -{a['span'] / 2:g}..{a['span'] / 2:g} m")
        loads.append(ld)
    solver = dict(sec["solver"])
    solver["petsc"] = {str(k): v for k, v in solver["petsc"].items()}
    fill = Fill(**sec["fill"]) if "fill" in sec else None
    if fill is not None and fill.material == "mohr-coulomb" and fill.friction_angle == 0 and fill.cohesion == 0:
        raise SceneError("[fill] cohesion = 0.0: a mohr-coulomb fill with friction_angle = 0 needs cohesion > 0")
    if fill is not None and fill.dilation_angle is not None and fill.dilation_angle > fill.friction_angle:
        raise SceneError(f"[fill] dilation_angle = {fill.dilation_angle!r}: allowed is an angle from 0 to "
                         f"friction_angle = {fill.friction_angle:g} degrees")
    abutments = _abutments(sec["abutments"], data["abutments"], sec) if "abutments" in sec else RIGID_ABUTMENTS
    return Scene(name=sec["scene"]["name"] or default_name, gravity=sec["scene"]["gravity"], fill=fill,
                 abutments=abutments,
                 arch=Arch(**a), masonry=Masonry(**sec["masonry"]), joints=JointProperties(**sec["joints"]),
                 loads=tuple(loads), mesh=MeshOptions(**sec["mesh"]), model=ModelOptions(**sec["model"]),
                 solver=SolverOptions(**solver))


def springing_reach(arch: dict[str, Any]) -> float:
    """Horizontal distance (m) from a springing's intrados corner to its extrados corner."""
    shape = make_shape(arch["shape"], arch["span"], arch["rise"])
    return float(abs(arch["thickness"] * shape.normal(0.0)[0]))


def _abutments(ab: dict[str, Any], given: dict[str, Any], sec: dict[str, dict[str, Any]]) -> Abutments:
    """Check the [abutments] keys against each other and fill in the defaults taken from the masonry and joints."""
    if (ab["movement_horizontal"] or ab["movement_vertical"]) and ab["movement_springing"] is None:
        raise SceneError("[abutments] movement_springing: missing; required with a support movement "
                         "(" + " or ".join(f'"{m}"' for m in MOVING_SPRINGINGS) + ")")
    if ab["model"] == "rigid":
        extra = [k for k in _ELASTIC_ONLY if k in given]
        if extra:
            raise SceneError(f"[abutments] {extra[0]} = {given[extra[0]]!r}: only for model = \"elastic\" "
                             "(rigid abutments are the ground itself)")
        return Abutments(**{**ab, "movement_springing": ab["movement_springing"] or ""})
    if ab["height"] is None:
        raise SceneError("[abutments] height: missing; required for model = \"elastic\" "
                         "(a positive depth in m of the base below the springing line)")
    reach = springing_reach(sec["arch"])
    if ab["length"] is not None and ab["length"] < reach * (1 - 1e-9):
        raise SceneError(f"[abutments] length = {ab['length']!r}: allowed is a length >= {reach:g} m, the "
                         "springing joint's horizontal reach (the joint must rest on the abutment)")
    m = sec["masonry"]
    defaults = {"length": reach, "young": m["young"], "poisson": m["poisson"],
                "unit_weight": m["density"] * sec["scene"]["gravity"], "friction": sec["joints"]["friction"]}
    ab.update({k: v for k, v in defaults.items() if ab[k] is None})
    return Abutments(**{**ab, "movement_springing": ab["movement_springing"] or ""})


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; the scene name defaults to the file name without extension."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file") from None
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{path}: not valid TOML ({err})") from None
    return scene_from_dict(data, default_name=path.stem)
