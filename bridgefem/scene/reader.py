"""Reading a scene: a TOML file (:func:`load_scene`) or a parsed document (:func:`scene_from_dict`) validated
against :data:`~bridgefem.scene.schema.SCHEMA` into a :class:`~bridgefem.scene.model.Scene`, and the scene written
back with every key resolved (:func:`resolved_toml`, what ``bridgefem check`` prints).

1. The file is read as a regular file of at most :data:`MAX_SCENE_BYTES` in UTF-8, then parsed as TOML.
2. Each section's keys are checked against the schema, in its order: unknown keys and sections are refused (with a
   "did you mean", :func:`did_you_mean`), missing defaults filled in, relative ranges checked against the span and
   the ring's weight as soon as these are read.
3. The preset's mesh and tolerance values fill the keys the scene does not give; then the keys are checked against
   each other (the rise against the shape, loads within the span, a fill's angles, abutments, the vehicle).

Every rejected value raises :class:`~bridgefem.scene.keys.SceneError` naming the key, the value and what is allowed;
the command line turns it into exit code 2 before anything is written.
"""
from __future__ import annotations

import copy
import difflib
import math
import os
import stat
import tomllib
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

from .keys import RANGE_RTOL, REQUIRED, SceneError, ring_weight, show_value, springing_reach, toml_value
from .model import (
    RIGID_ABUTMENTS,
    Abutments,
    Arch,
    Fill,
    JointProperties,
    Load,
    Masonry,
    MeshOptions,
    ModelOptions,
    Pier,
    Scene,
    SolverOptions,
    Vehicle,
    span_ranges,
)
from .names import check_name, show_path
from .petsc_options import check_petsc
from .schema import FILL_PRESETS, MAX_LOADS, MAX_RINGS, MAX_SPANS, PRESETS, SCHEMA
from .vehicles import MAX_AXLES, VEHICLES

MAX_SCENE_BYTES = 1_000_000  # a scene file larger than this is not a scene
_REQUIRED_SECTIONS = ("arch", "masonry", "joints")
_OPTIONAL_SECTIONS = ("fill", "abutments", "vehicle")


def did_you_mean(name: str, allowed, show=repr) -> str:
    """The hint after an unknown name in a one-line message: ``"did you mean 'span'? "`` when an allowed name is
    close to ``name`` (:func:`difflib.get_close_matches`; ``show`` writes it), else ``""``."""
    close = difflib.get_close_matches(name, list(allowed), n=1) if isinstance(name, str) else []
    return f"did you mean {show(close[0])}? " if close else ""


def _section(data: Any, name: str, label: str, scales: dict[str, float]) -> dict[str, Any]:
    """The section's keys checked and typed, defaults filled in; a key that needs another key's value
    (:attr:`~bridgefem.scene.keys.Key.only`) is refused without it. A relative range is checked against ``scales``
    (:data:`~bridgefem.scene.keys.SCALES`), to which the [arch] span is added when it is read (the ring's other
    lengths follow it in the section)."""
    if not isinstance(data, dict):
        raise SceneError(f"{label}: expected a table, got {show_value(data)}")
    schema = SCHEMA[name]
    unknown = sorted(set(data) - set(schema))
    if unknown:
        raise SceneError(f"{label}: unknown key {show_value(unknown[0])}; {did_you_mean(unknown[0], schema)}allowed "
                         f"keys are {', '.join(schema)}")
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
            raise SceneError(f"{label} {k} = {show_value(data[k])}: only for {key.only[0]} = \"{key.only[1]}\" "
                             f"({key.only[0]} is \"{out[key.only[0]]}\")")
    return out


def _check_rise(a: dict[str, Any], label: str = "[arch]") -> float:
    span, rise, shape = a["span"], a["rise"], a["shape"]
    if shape == "semicircular":
        if rise is not None and not math.isclose(rise, span / 2, rel_tol=1e-6):
            raise SceneError(f"{label} rise = {rise!r}: allowed for a semicircular arch is rise = span/2 = "
                             f"{span / 2:g} m (omit rise, or use shape = \"segmental\" / \"elliptical\")")
        return span / 2
    if rise is None:
        raise SceneError(f"{label} rise: missing; required for shape = \"{shape}\" "
                         f"({SCHEMA['arch']['rise'].allowed(span)})")
    key = SCHEMA["arch"]["rise"]
    limits = {"segmental": (rise <= span / 2, f"rise from {key.low:g} x span to span/2 = {span / 2:g} m"),
              "pointed": (rise >= span / 2, f"rise from span/2 = {span / 2:g} m to {key.high:g} x span")}
    ok, allowed = limits.get(shape, (True, ""))
    if not ok:
        raise SceneError(f"{label} rise = {rise!r}: for shape = \"{shape}\" allowed is {allowed}")
    return rise


def _check_rings(a: dict[str, Any], rings_given: bool, label: str = "[arch]") -> dict[str, Any]:
    """``rings`` and ``ring_thicknesses`` agreed: the list has 2 to ``MAX_RINGS`` numbers, each at least 1e-3 of
    ``thickness``, summing to it (to 1e-6); ``rings``, when given with it, is its length."""
    given = a["ring_thicknesses"]
    if given is None:
        return {}
    allowed = (f"allowed is a list of 2 to {MAX_RINGS} thicknesses in m, each at least 1e-3 x thickness, summing to "
               f"thickness = {a['thickness']:.9g} m")
    if not isinstance(given, list) or not 2 <= len(given) <= MAX_RINGS or any(
            isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t)
            or t < 1e-3 * a["thickness"] for t in given):
        raise SceneError(f"{label} ring_thicknesses = {show_value(given)}: {allowed}")
    if abs(sum(given) - a["thickness"]) > 1e-6 * a["thickness"]:
        raise SceneError(f"{label} ring_thicknesses = {show_value(given)}: they sum to {sum(given):.9g} m; {allowed}")
    if rings_given and a["rings"] != len(given):
        raise SceneError(f"{label} rings = {a['rings']!r}: ring_thicknesses has {len(given)} rings; allowed is "
                         f"rings = {len(given)} or no rings key")
    return {"ring_thicknesses": tuple(float(t) for t in given), "rings": len(given)}


def _arch(raw: Any, label: str, scales: dict[str, float]) -> dict[str, Any]:
    """An ``[arch]`` table (or a ``[[span]]`` table, with its ``label``) checked, its rise and rings agreed."""
    a = _section(raw, "arch", label, scales)
    a["rise"] = _check_rise(a, label)
    a.update(_check_rings(a, "rings" in raw, label))
    return a


def _spans(data: dict[str, Any], scales: dict[str, float]) -> list[dict[str, Any]]:
    """The arches of the scene: its ``[arch]``, or its 2 to ``MAX_SPANS`` ``[[span]]`` tables (each checked as an
    ``[arch]``, its relative ranges against its own span; one width for the whole bridge); ``scales`` gets the
    first span's."""
    if "span" not in data:
        if "pier" in data:
            raise SceneError("[[pier]]: piers stand between spans; allowed with [[span]] tables (2 or more), not "
                             "with [arch]")
        return [_arch(data["arch"], "[arch]", scales)]
    raw = data["span"]
    if "arch" in data:
        raise SceneError("[arch] and [[span]]: give one, [arch] for a bridge of one span or [[span]] tables for "
                         "several")
    if not isinstance(raw, list) or not 2 <= len(raw) <= MAX_SPANS:
        raise SceneError(f"[[span]] = {show_value(raw)}: expected 2 to {MAX_SPANS} [[span]] tables, left to right "
                         "(one span: [arch])")
    spans = [_arch(raw[0], "[[span]] #1", scales)]
    for k, table in enumerate(raw[1:], start=2):
        a = _arch(table, f"[[span]] #{k}", dict(scales))
        if a["width"] != spans[0]["width"]:
            raise SceneError(f"[[span]] #{k} width = {a['width']!r}: allowed is the bridge's width, that of "
                             f"[[span]] #1 ({spans[0]['width']:g} m)")
        spans.append(a)
    return spans


def _piers(data: dict[str, Any], spans: list[dict[str, Any]], scales: dict[str, float]) -> tuple[Pier, ...]:
    """The ``[[pier]]`` tables of a bridge of these ``spans``: one between each two spans, its relative ranges
    against the longer of its two spans."""
    raw, n = data.get("pier", []), len(spans)
    if n == 1:
        return ()
    if not isinstance(raw, list) or len(raw) != n - 1:
        raise SceneError(f"[[pier]] = {show_value(raw)}: expected {n - 1} [[pier]] tables, one between each "
                         f"two of the {n} spans, left to right")
    return tuple(Pier(**_section(table, "pier", f"[[pier]] #{k + 1}",
                                 {**scales, "span": max(spans[k]["span"], spans[k + 1]["span"])}))
                 for k, table in enumerate(raw))


def scene_from_dict(data: dict[str, Any], default_name: str = "scene") -> Scene:
    """Validate a parsed TOML document and build a :class:`Scene`."""
    arrays = {"load": "[[load]]", "span": "[[span]]", "pier": "[[pier]]"}
    unknown = sorted(set(data) - set(SCHEMA) - set(arrays))
    if unknown:
        hint = did_you_mean(unknown[0], list(SCHEMA) + ["span"], lambda s: arrays.get(s, f"[{s}]"))
        raise SceneError(f"[{show_value(unknown[0])[1:-1]}]: unknown section; {hint}allowed sections are "
                         + ", ".join(f"[{s}]" for s in SCHEMA if s not in arrays) + ", " + ", ".join(arrays.values()))
    for name in _REQUIRED_SECTIONS:
        if name not in data and not (name == "arch" and "span" in data):
            raise SceneError(f"[{name}]: missing section; expected the sections "
                             + ", ".join(f"[{n}]" for n in _REQUIRED_SECTIONS) + " (and others as needed; "
                             "[[span]] tables instead of [arch] for several spans)")
    scales: dict[str, float] = {}
    sec: dict[str, dict[str, Any]] = {}
    spans: list[dict[str, Any]] = []
    for section in SCHEMA:
        if section in arrays or (section not in data and section in _OPTIONAL_SECTIONS):
            continue
        if section == "arch":
            spans = _spans(data, scales)
            sec["arch"] = spans[0]
            continue
        sec[section] = _section(data.get(section, {}), section, f"[{section}]", scales)
        if section == "masonry":
            scales["ring weight"] = sum(ring_weight(a, sec["masonry"]["density"], sec["scene"]["gravity"])
                                        for a in spans)
    piers = _piers(data, spans, scales)
    name = check_name(sec["scene"]["name"], "[scene] name") if sec["scene"]["name"] is not None else default_name
    preset = sec["solver"]["preset"]
    plastic_fill = "fill" in sec and sec["fill"]["material"] == "mohr-coulomb"
    for (section, key), value in (FILL_PRESETS if plastic_fill else PRESETS)[preset].items():
        if key not in data.get(section, {}):
            sec[section][key] = value
    a = sec["arch"]
    arches = tuple(Arch(**x) for x in spans)
    reach = span_ranges(arches, piers)
    raw_loads = data.get("load", [])
    if not isinstance(raw_loads, list):
        raise SceneError(f"[[load]] = {show_value(raw_loads)}: expected [[load]] tables (none: self-weight only)")
    if len(raw_loads) > MAX_LOADS:
        raise SceneError(f"[[load]]: {len(raw_loads)} tables; allowed are at most {MAX_LOADS}")
    loads = []
    for i, raw in enumerate(raw_loads):
        label = f"[[load]] #{i + 1}"
        ld = Load(**_placed(_section(raw, "load", label, {**scales, "span": reach[-1][1] - reach[0][0]}), label,
                            a["span"]))
        if ld.kind == "point" and ld.length:
            raise SceneError(f"{label} length = {ld.length!r}: a point load has no length (use kind = \"patch\")")
        if ld.kind == "patch" and ld.length == 0:
            patch = replace(SCHEMA["load"]["length"], zero=False).allowed(a["span"])
            raise SceneError(f"{label} length = {ld.length!r}: a patch load needs a length; allowed is {patch}")
        lo, hi = ld.x_range(a["span"])
        slack = RANGE_RTOL * a["span"] / 2
        if lo < reach[0][0] - slack or hi > reach[-1][1] + slack:
            where = ("the span" if len(reach) == 1
                     else "the bridge, from the first span's left springing to the last's right")
            raise SceneError(f"{label} position = {ld.position!r}, length = {ld.length!r}: the load spans "
                             f"x = {lo + a['span'] / 2:g}..{hi + a['span'] / 2:g} m from the left springing; allowed "
                             f"is a load within {where}, x = 0..{reach[-1][1] + a['span'] / 2:g} m")
        loads.append(ld)
    solver = {**sec["solver"], "petsc": check_petsc(sec["solver"]["petsc"])}
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
                 solver=SolverOptions(**solver), document=copy.deepcopy(data),
                 spans=arches if len(arches) > 1 else (), piers=piers)


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
            raise SceneError(f"[vehicle] {given} = {show_value(v[given])}: standard = \"{v['standard']}\" sets the "
                             "axles and their spacing; allowed is standard or axles and spacing, not both")
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
        raise SceneError(f"[vehicle] axles = {show_value(axles)}: allowed is a list of 1 to {MAX_AXLES} axle loads "
                         "in N")
    for a in axles:
        if isinstance(a, bool) or not isinstance(a, (int, float)) or not math.isfinite(a) \
                or not 1e-6 * weight <= a <= 1e6 * weight:
            raise SceneError(f"[vehicle] axles = {show_value(axles)}: allowed are axle loads in N from 1e-6 to 1e6 x "
                             f"the ring's weight ({1e-6 * weight:.4g} to {1e6 * weight:.4g} N in this scene)")
    if len(spacing) != len(axles) - 1:
        raise SceneError(f"[vehicle] spacing = {show_value(spacing)}: allowed is a list of {len(axles) - 1} distances "
                         f"in m (one between each two consecutive axles of the {len(axles)})")
    for d in spacing:
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not math.isfinite(d) \
                or not contact < d <= 10 * span:
            raise SceneError(f"[vehicle] spacing = {show_value(spacing)}: allowed are distances in m longer than the "
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


def scene_scales(scene: Scene) -> dict[str, float]:
    """What the scene's relative ranges are multiples of (:data:`~bridgefem.scene.keys.SCALES`): its span (m) and
    its ring's weight (N)."""
    return {"span": scene.arch.span,
            "ring weight": ring_weight(asdict(scene.arch), scene.masonry.density, scene.gravity)}


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
            lines.append(f"{k} = {toml_value(value)}{note}")
        lines.append("")

    for section in SCHEMA:
        if section == "load":
            for ld in scene.loads:
                table("[[load]]", "load", ld)
        elif section == "arch" and scene.spans:
            for a in scene.spans:
                table("[[span]]", "arch", a)
        elif section == "pier":
            for pier in scene.piers:
                table("[[pier]]", "pier", pier)
        elif objects[section] is not None:
            table(f"[{section}]", section, objects[section])
    if scene.solver.petsc:
        lines += ["[solver.petsc]"] + [f"{k} = {toml_value(v)}" for k, v in scene.solver.petsc.items()] + [""]
    return "\n".join(lines)
