"""The schema of scene files: :data:`SCHEMA`, the one source of every scene key: its type, default, unit, allowed
values and a one-line description, with the speed-accuracy presets that supply some defaults.

The dataclasses take their defaults from it (:mod:`bridgefem.scene.model`), the reader validates a scene against it
(:mod:`bridgefem.scene.reader`), ``bridgefem check`` prints a scene resolved against it and docs/scene-keys.md is
generated from it (:func:`keys_markdown`). To add a key: one :class:`~bridgefem.scene.keys.Key` line in its section
of :data:`SCHEMA` and a field of the same name in the section's dataclass in :mod:`bridgefem.scene.model` (default
``_default(section, key)``); a key that applies only with a given value of another key names it in ``only``. Then
regenerate docs/scene-keys.md (``./run python -m bridgefem.scene.schema > docs/scene-keys.md``).
"""
from __future__ import annotations

from typing import Any

from ..geometry.ring import RING_BONDS
from ..geometry.shapes import SHAPES
from .keys import REQUIRED, Key, toml_value
from .names import MAX_NAME, MAX_NAME_BYTES
from .petsc_options import MUMPS_CNTL, MUMPS_ICNTL, PETSC_SCENE_OPTIONS, petsc_key
from .vehicles import DISPERSIONS, MAX_AXLES, VEHICLES

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
MAX_RINGS = 12  # rings of one barrel
MAX_SPANS = 20  # [[span]] tables in one scene
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
        "rings": Key(int, "rings of the barrel, laid one over the other, each of equal thickness thickness / rings "
                     "(brick rings)", 1, low=1, high=MAX_RINGS, derived="1, or the number of ring_thicknesses",
                     why=f"a single ring to {MAX_RINGS} (the thickest brick barrels have about eight rings)"),
        "ring_thicknesses": Key(list, "thickness of each ring from the intrados out, summing to thickness; instead "
                                "of equal rings", None, derived="thickness / rings each",
                                why=f"2 to {MAX_RINGS} rings, each at least 1e-3 of the barrel's thickness"),
        "ring_bond": Key(str, "staggered: every other ring shifted half a voussoir (brick bond, half voussoirs at "
                         "the springings); aligned: every ring's joints continue the outer ring's",
                         "staggered", choices=RING_BONDS),
    },
    "pier": {
        "width": _length("clear distance between the two spans' intrados corners at springing level", 0.01, 2.0,
                         why="from a sliver of a pier to twice the span (wider, a pier is an abutment)"),
        "height": _length("from springing level down to the pier's foundation", 0.01, 5.0,
                          why="from a pier that is all springing to the tallest viaducts' (a few times the span)"),
        "batter": Key(float, "outward lean of each face per metre down (a wider base)", 0.0, "m/m", low=0.0,
                      high=0.5, why="from a vertical face to a lean of 1 in 2 (a buttress rather than a pier)"),
        "blocks": Key(int, "courses of the pier, between horizontal bed joints evenly spaced from springing level to "
                      "the foundation, where it can rock or slide", 1, low=1, high=100,
                      why="from one block on its foundation to a course every few decimetres of a tall pier"),
        "young": _modulus("Young's modulus of the pier", None, derived="the masonry's"),
        "density": Key(float, "density of the pier", None, "kg/m^3", low=_DENSITY.low, high=_DENSITY.high,
                       derived="the masonry's", why=_DENSITY.why),
    },
    "masonry": {
        "young": _modulus("Young's modulus of the voussoirs"),
        "poisson": _poisson("Poisson's ratio of the voussoirs", 0.2),
        "density": _DENSITY,
        "compressive_strength": Key(float, "compressive strength f_c of every masonry joint (voussoir joints, "
                                    "springings): a joint crushes under a rectangular stress block of f_c",
                                    None, "Pa", low=100.0, high=1e9, derived="infinitely strong (no crushing)",
                                    why="from the self-weight stresses of a laboratory model (about 1 kPa) to "
                                        "beyond the strongest granite (about 250 MPa)"),
    },
    "joints": {
        "friction": _coefficient("Coulomb coefficient of every joint, springing joints included"),
        "ring_friction": _coefficient("Coulomb coefficient of the interfaces between rings", None,
                                      derived="friction"),
        "ring_cohesion": Key(float, "cohesion (shear strength at no normal stress) of the mortar between rings; "
                             "no tension across a ring interface either way", 0.0, "Pa", low=1.0, high=1e7,
                             zero=True, why="0 for unbonded rings, else from 1 Pa to 10 MPa (a strong cement "
                                            "mortar's bond; weathered lime mortar has tens of kPa)"),
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
        "element_size": _length("fill mesh size away from the rings (0: twice the coarsest span's outer ring "
                                "element size)", 2e-3, 1.0, 0.0, zero=True,
                                why="finer than 1/500 of the span meshes a fill in millions of cells, coarser than the "
                                    "span meshes nothing"),
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
        "elements_through_thickness": Key(int, "elements through the thickness of each ring",
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
        "max_iterations": Key(int, "active-set (Newton) iterations per load step (the self-weight's: at least one "
                              "per joint of the structure)", 60, low=1, high=10000,
                              why="from one to far more than any converging step takes"),
        "max_load": _force("live load where the search stops as \"locked\" (0: 100 x ring weight)"),
        "initial_step": _force("first live-load step (0: ring weight / 4)"),
        "max_steps": Key(int, "load steps in all", 200, low=1, high=100000,
                         why="from one to far more than any limit search takes"),
        "stiffness_drop": Key(float, "with a fill: a step whose secant stiffness, or tangent stiffness at its end, "
                              "falls below this fraction of the initial one, with its curve's plateau within the "
                              "tolerance above, marks the limit (0: off)", 0.02, low=0.0,
                              high=1.0, high_open=True, why="a fraction of the initial stiffness"),
        "petsc": Key(dict, "PETSc options of the contact solver, from the allow-list below", {}),
    },
}
"""Every scene key, by section ("load": the keys of each [[load]] table; "pier": of each [[pier]] table; a bridge of
several spans gives [[span]] tables with the keys of "arch")."""


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
        header = {"load": "## [[load]]", "pier": "## [[pier]] (\"x span\": the longer of its two spans)"}.get(
            section, f"## [{section}]")
        if section == "arch":
            header += " (or [[span]] tables, one per span of a bridge of several spans, each with these keys)"
        out += [header, "",
                "| key | default | unit | allowed | meaning | why this range |", "|---|---|---|---|---|---|"]
        for k, key in keys.items():
            default = ("*required*" if key.default is REQUIRED else key.derived if key.derived
                       else "{}" if key.default == {} else toml_value(key.default))
            only = f" (only with {key.only[0]} = \"{key.only[1]}\")" if key.only else ""
            out.append(f"| `{k}` | {default} | {key.unit} | {key.allowed()} | {key.doc}{only} | {key.why} |")
        out.append("")
    out += ["## [solver.petsc]", "",
            "A scene may set only these solver options (prefix `bridgefem_` is added); anything else, e.g. "
            "viewers and monitors, only on the command line (`--petsc KEY=VALUE`). Without a plastic fill they set "
            "the solver of the reduced system (the joint faces' displacements and the joint forces, the blocks' "
            "interiors condensed out once: `bridgefem/solver/interior.py`); with one, of the whole system.", "",
            "| key | allowed | meaning |", "|---|---|---|"]
    out += [f"| `{k}` | {key.allowed()} | {key.doc} |" for k, key in PETSC_SCENE_OPTIONS.items()]
    out += [f"| `mat_mumps_icntl_{n}` | {petsc_key(f'mat_mumps_icntl_{n}').allowed()} | MUMPS ICNTL({n}) |"
            for n in MUMPS_ICNTL]
    out += [
            f"| `mat_mumps_cntl_N`, N = {', '.join(map(str, MUMPS_CNTL))} | {petsc_key('mat_mumps_cntl_1').allowed()} "
            "| MUMPS real controls |", ""]
    return "\n".join(out)


if __name__ == "__main__":
    print(keys_markdown(), end="")
