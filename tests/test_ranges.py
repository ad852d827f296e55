"""Every number of a scene has a range a real bridge can have (``bridgefem/scene/schema.py`` SCHEMA, docs/scene-keys.md).

Generated from the schema: the ends of every numeric key's range are accepted by ``bridgefem check``, and a value
just outside them is refused with one line naming the key, the value and the range (exit code 2, nothing written),
by every command. The values that crashed an analysis or gave a wrong verdict before the ranges existed (issue 37)
are refused the same way. Every scene of the random campaign lies inside the ranges. At the ends of the ranges the
rigid-block LP answers as closed forms say; and the LP's limit load scales with the square of the bridge's size
over the whole span range (its tolerances are relative to the scene's size and weight), the FE's within its
bracket (slow).
"""
from __future__ import annotations

import copy
import math
import os
import tomllib
from dataclasses import asdict

import numpy as np
import pytest
from conftest import REFERENCE_ARCH, campaign_module, scene_dict, trap_the_analysis, write_toml

from bridgefem.io import cli
from bridgefem.limit.collapse import collapse_load
from bridgefem.limit.thickness import min_thickness
from bridgefem.scene.keys import SCALES, SceneError, springing_reach
from bridgefem.scene.reader import resolved_toml, scene_from_dict, scene_scales
from bridgefem.scene.schema import SCHEMA

FILL = {"unit_weight": 18000.0, "young": 1e8, "depth": 0.5, "extension": 2.0}
MOHR_COULOMB = {**FILL, "material": "mohr-coulomb", "friction_angle": 60.0, "cohesion": 5e3}  # every angle allowed
PATCH = [{"kind": "patch", "position": 0.5, "length": 0.5}]
STEP = 1e-6  # "just outside": this fraction of the bound (of the range's width for a bound of 0) beyond it


def numeric_keys() -> list[tuple[str, str]]:
    """(section, key) of every number of a scene (integers and floats, not the choices of a few)."""
    return [(s, k) for s, keys in SCHEMA.items() for k, key in keys.items() if key.kind in (int, float)
            and not key.choices]


def base_scene(section: str, name: str) -> dict:
    """A scene in which ``[section] name`` applies (its ``only`` condition met) and whose model stays small
    with the key at either end of its range; every other value inside its range."""
    if section == "fill":
        if SCHEMA["fill"][name].only:
            return scene_dict(fill=MOHR_COULOMB, load=PATCH)
        if name == "element_size":  # a thin fill: its finest mesh stays within the size limit
            return scene_dict(fill={**FILL, "depth": 0.09, "extension": 0.09})
        return scene_dict(fill=FILL)
    if section == "abutments":
        return scene_dict(abutments={"model": "elastic", "height": 2.0, "movement_springing": "right"})
    if section == "load":
        first = {"kind": "point", "x": 2.0} if name == "x" else {"kind": "point", "position": 0.22222}
        return scene_dict(load=copy.deepcopy(PATCH) if name == "length" else
                          [first, {"kind": "point", "position": 0.6}])
    if section == "vehicle":
        return scene_dict(vehicle={"axles": [1e5]})
    if section == "pier":  # two spans of the reference arch on a pier
        d = scene_dict(mesh={"elements_through_thickness": 1})
        d["span"] = [d.pop("arch"), scene_dict()["arch"]]
        d["pier"] = [{"width": 3.0, "height": 3.0}]
        return d
    if (section, name) == ("arch", "rise"):
        return scene_dict(arch={"shape": "elliptical"})  # the whole range of rise/span, 0.05 to 2
    if (section, name) == ("arch", "thickness"):
        return scene_dict(mesh={"elements_through_thickness": 1})  # the thinnest ring meshed by few elements
    return scene_dict()


def with_value(d: dict, section: str, name: str, value) -> dict:
    """The scene with ``[section] name = value`` (of the first [[load]]; a load of length 0 is a point load; a
    span scales the ring's other lengths with it)."""
    d = scaled(d, value / d["arch"]["span"]) if (section, name) == ("arch", "span") else copy.deepcopy(d)
    (d[section][0] if section in ("load", "pier") else d.setdefault(section, {}))[name] = value
    if (section, name, value) == ("load", "length", 0.0):
        d["load"][0]["kind"] = "point"
    return d


def label(section: str, name: str) -> str:
    return f"[[{section}]] #1 {name}" if section in ("load", "pier") else f"[{section}] {name}"


def edges(section: str, name: str) -> tuple[list, list]:
    """The values at the ends of the key's range in its base scene (accepted) and just outside (refused)."""
    key = SCHEMA[section][name]
    d = base_scene(section, name)
    scale = scene_scales(scene_from_dict(d))[key.per] if key.per else 1.0
    if key.kind is int:
        return [key.low, key.high], [key.low - 1, key.high + 1]
    lo, hi = key.low * scale, key.high * scale
    if (section, name) == ("abutments", "length"):  # from the springing joint's reach, which must rest on it
        reach = springing_reach(asdict(scene_from_dict(d).arch))
        low_in, low_out = reach, reach * (1 - STEP)
    elif (section, name) == ("pier", "width"):  # wider than the two springings' reach, which rest on it
        low_in, low_out = 2 * springing_reach(asdict(scene_from_dict(d).arch)) * (1 + STEP), lo * (1 - STEP)
    elif key.low_open:
        low_in, low_out = lo + STEP * (hi - lo), lo
    else:
        low_in, low_out = lo, lo - (STEP * abs(lo) or STEP * (hi - lo))
    high_in, high_out = (hi * (1 - STEP), hi) if key.high_open else (hi, hi * (1 + STEP))
    return [low_in, high_in] + ([0.0] if key.zero else []), [low_out, high_out]


EDGE_CASES = [(s, k, v, ok) for s, k in numeric_keys() for ok, values in zip((True, False), edges(s, k))
              for v in values]


@pytest.fixture
def trapped(tmp_path, monkeypatch):
    """An empty working folder as the cwd and the analysis replaced by a trap (a refusal comes before it)."""
    return trap_the_analysis(monkeypatch, tmp_path)


def assert_refused(capsys, argv: list[str], must_hold: list[str], work) -> str:
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == 2, (code, err)
    assert len(err.splitlines()) == 1 and err.startswith("bridgefem: error: ") and "Traceback" not in err, err
    for text in must_hold:
        assert text in err, (text, err)
    assert os.listdir(work) == [], os.listdir(work)
    return err


def test_every_number_has_a_range_and_its_reason():
    """Both ends, a reason (docs/scene-keys.md shows it), a known scale for a relative range, and the default
    inside the range."""
    for section, name in numeric_keys():
        key = SCHEMA[section][name]
        assert key.low is not None and key.high is not None and key.low < key.high, (section, name)
        assert key.why, f"[{section}] {name}: no reason for its range"
        assert key.per in ("", *SCALES), key.per
        if isinstance(key.default, (int, float)) and key.default != 0:
            assert key.within(key.default, scene_scales(scene_from_dict(base_scene(section, name)))[key.per]
                              if key.per else 1.0), (section, name, key.default)


@pytest.mark.parametrize("section,name,value,ok", EDGE_CASES,
                         ids=[f"{s}.{k}={v:.6g}-{'accepted' if ok else 'refused'}" for s, k, v, ok in EDGE_CASES])
def test_the_ends_of_each_range_are_accepted_and_just_outside_refused(tmp_path, capsys, trapped, section, name,
                                                                       value, ok):
    scene = write_toml(tmp_path / "s.toml", with_value(base_scene(section, name), section, name, value))
    if ok:
        assert cli.main(["check", str(scene)]) == 0, capsys.readouterr().err
        assert capsys.readouterr().out.startswith("# s: valid")
    else:
        err = assert_refused(capsys, ["check", str(scene)], [f"{label(section, name)} = {value!r}", "allowed"],
                             trapped)
        if SCHEMA[section][name].per and "the springing joint's horizontal reach" not in err:
            assert "in this scene)" in err, err  # the bounds of a relative range in metres or newtons


@pytest.mark.parametrize("density", [SCHEMA["masonry"]["density"].low, SCHEMA["masonry"]["density"].high])
@pytest.mark.parametrize("gravity", [SCHEMA["scene"]["gravity"].low, SCHEMA["scene"]["gravity"].high])
def test_a_derived_default_lies_in_its_range(density, gravity):
    """Elastic abutments weigh the masonry's density x gravity by default: at every corner of those two ranges the
    resolved scene (what check prints, its derived values written out) reads back as the same scene."""
    scene = scene_from_dict(scene_dict(scene={"gravity": gravity}, masonry={"density": density},
                                       abutments={"model": "elastic", "height": 2.0}))
    assert scene.abutments.unit_weight == density * gravity
    assert scene_from_dict(tomllib.loads(resolved_toml(scene))) == scene


def scaled(d: dict, s: float) -> dict:
    """The scene with every length in the plane of the ring times s (the width, moduli and densities kept)."""
    d = copy.deepcopy(d)
    for k in ("span", "rise", "thickness"):
        if k in d["arch"]:
            d["arch"][k] *= s
    for ld in d.get("load", []):
        if "length" in ld:
            ld["length"] *= s
    return d


OUTSIDE = {  # one value outside its range per kind of range: absolute, x span, x ring weight
    "span": {"arch": {"span": 0.0999, "rise": 0.04995, "thickness": 0.01}},
    "thickness": {"arch": {"thickness": 8.9e-4}},
    "max_load": {"solver": {"max_load": 0.9 * SCHEMA["solver"]["max_load"].low
                            * scene_scales(scene_from_dict(scene_dict()))["ring weight"]}},
}


@pytest.mark.parametrize("command", ["run", "check", "lp", "bounds", "min-thickness", "converge"])
@pytest.mark.parametrize("case", sorted(OUTSIDE))
def test_every_command_refuses_a_value_outside_its_range(tmp_path, capsys, trapped, command, case):
    scene = write_toml(tmp_path / "s.toml", scene_dict(**OUTSIDE[case]))
    out = ["--out", str(tmp_path / "out")] if command in ("run", "converge") else []
    assert_refused(capsys, [command, str(scene), *out], [f"{case} = ", "allowed"], trapped)
    assert not (tmp_path / "out").exists()


# issue 37: values the schema accepted that crashed (a traceback, Gmsh's SIGABRT) or gave a wrong verdict (a 0.9 um
# span's "proof" 5.5 % below its limit; a 1e-16 m patch that loaded nothing and was "locked"), and their kin
ABSURD = {
    "span 1e-200": ({"arch": {"span": 1e-200}}, "[arch] span"),
    "span 0.9 um, all lengths scaled": ({"arch": scaled(REFERENCE_ARCH, 1e-7)["arch"]}, "[arch] span"),
    "fill depth 1e-200": ({"fill": {**FILL, "depth": 1e-200}}, "[fill] depth"),
    "fill element size 1e-300": ({"fill": {**FILL, "element_size": 1e-300}}, "[fill] element_size"),
    "elastic abutments 1e-300 high": ({"abutments": {"model": "elastic", "height": 1e-300}}, "[abutments] height"),
    "patch 1e-16 m": ({"load": [{"kind": "patch", "position": 0.3, "length": 1e-16}]}, "[[load]] #1 length"),
    "thickness 1e-300": ({"arch": {"thickness": 1e-300}}, "[arch] thickness"),
    "segmental rise 1e-300": ({"arch": {"shape": "segmental", "rise": 1e-300}}, "[arch] rise"),
    "width 1e-300": ({"arch": {"width": 1e-300}}, "[arch] width"),
    "gravity 1e-300": ({"scene": {"gravity": 1e-300}}, "[scene] gravity"),
    "fill extension 1e-300": ({"fill": {**FILL, "extension": 1e-300}}, "[fill] extension"),
    "abutment length 1e300": ({"abutments": {"model": "elastic", "height": 2.0, "length": 1e300}},
                              "[abutments] length"),
    "load factor 1e-300": ({"load": [{"kind": "point", "position": 0.3, "factor": 1e-300}]}, "[[load]] #1 factor"),
    "max_load 1e-300": ({"solver": {"max_load": 1e-300}}, "[solver] max_load"),
    "initial_step 1e-300": ({"solver": {"initial_step": 1e-300}}, "[solver] initial_step"),
    "cohesion 1e-300 without friction": ({"fill": {**FILL, "material": "mohr-coulomb", "friction_angle": 0.0,
                                                   "cohesion": 1e-300}, "load": PATCH}, "[fill] cohesion"),
    "settlement of 10 spans": ({"abutments": {"movement_springing": "left", "movement_vertical": -90.0}},
                               "[abutments] movement_vertical"),
}


@pytest.mark.parametrize("case", sorted(ABSURD))
def test_absurd_values_are_refused_before_anything_runs(tmp_path, capsys, trapped, case):
    sections, key = ABSURD[case]
    scene = write_toml(tmp_path / "s.toml", scene_dict(**sections))
    for command in ("run", "check"):
        assert_refused(capsys, [command, str(scene), *(["--out", str(tmp_path / "out")] if command == "run" else [])],
                       [key, "allowed"], trapped)
    assert sorted(os.listdir(tmp_path)) == ["s.toml", "work"]


def assert_campaign_inside(seeds: range) -> None:
    """The scenes of benchmarks/campaign.py's seeds, each with its option (the base draw with one more thing a scene
    can ask for), at both ends of the thickness a draw can get (0.05 and 0.4 of its reference length; the least
    thickness that stands, when it is below, is above the schema's: the next test) are valid scenes."""
    campaign = campaign_module()
    for seed in seeds:
        for index in range(300):
            choice = {**campaign.draw(seed, index), "option": campaign.draw_option(seed, index)}
            top = 0.4 * campaign.reference_length(choice, 0.0)
            for thickness in (top / 8, top):
                scene_from_dict(campaign.scene_dict(choice, thickness))


def test_every_campaign_scene_lies_inside_the_ranges():
    assert_campaign_inside(range(1, 2))


@pytest.mark.slow
def test_every_campaign_scene_of_ten_seeds_lies_inside_the_ranges():
    assert_campaign_inside(range(2, 12))


def test_the_thinnest_campaign_ring_is_thicker_than_the_least_allowed():
    """The campaign's flattest segmental ring (its least rise/span) of few voussoirs at its highest friction stands
    on the thinnest ring it can draw: the LP's least thickness, above the schema's least thickness (x span)."""
    campaign = campaign_module()
    span = 3.0
    rise = campaign.RISE_RATIO["segmental"][0] * span
    d = scene_dict(arch={"shape": "segmental", "span": span, "rise": rise, "thickness": 0.1 * rise, "voussoirs": 4},
                   joints={"friction": 10.0}, load=[])
    least = min_thickness(scene_from_dict(d)).thickness
    assert SCHEMA["arch"]["thickness"].low * span < least < 0.01 * span


def test_the_ring_weight_scale_is_the_rings_weight():
    """The scale of the solver's force ranges is the ring's weight: a semicircular ring's is rho g w pi/2 ((R +
    t)^2 - R^2) (R the intrados radius)."""
    d = scene_dict(arch={"width": 2.0})
    exact = 2000.0 * 9.81 * 2.0 * math.pi / 2 * (5.5 ** 2 - 4.5 ** 2)
    assert scene_scales(scene_from_dict(d))["ring weight"] == pytest.approx(exact, rel=1e-4)


def lp_at(section: str, name: str, value):
    return collapse_load(scene_from_dict(with_value(base_scene(section, name), section, name, value)))


@pytest.mark.parametrize("section,name", [("scene", "gravity"), ("masonry", "density"), ("arch", "width")])
def test_the_lp_limit_is_proportional_to_the_weight_over_the_range(section, name):
    """Gravity, density and width multiply every force: the LP's limit load over the value is the same at both
    ends of the range as at the reference value."""
    key = SCHEMA[section][name]
    reference = collapse_load(scene_from_dict(base_scene(section, name)))
    value = {"gravity": 9.81, "density": 2000.0, "width": 1.0}[name]
    for end in (key.low, key.high):
        assert lp_at(section, name, end).load / end == pytest.approx(reference.load / value, rel=1e-9)


def test_the_lp_answers_at_the_ends_of_the_ring_ranges():
    """The ring's own ranges, ends included, give the LP's verdicts that closed forms predict: no friction, no
    arch (the springing joints carry only forces along the centreline); a ring of 1e-4 of its span far below
    the semicircle's least thickness (t/R = 0.1075, Milankovitch) falls under its weight, one nearly as thick as
    its span carries a load; frictionless joints slide, the stiffest do not. The flattest and the tallest rings,
    two voussoirs, loads at the springings, a patch over the whole span and the extreme shares of a load pattern
    give a verdict (a finite positive limit where there is one), not an LP failure."""
    assert lp_at("joints", "friction", 0.0).status == "unstable under self-weight"
    assert not lp_at("joints", "friction", SCHEMA["joints"]["friction"].high).sliding
    span = REFERENCE_ARCH["arch"]["span"]
    assert lp_at("arch", "thickness", SCHEMA["arch"]["thickness"].low * span).status == "unstable under self-weight"
    assert lp_at("arch", "thickness", 0.999 * span).status == "limit load found"
    cases = [("arch", "rise", SCHEMA["arch"]["rise"].low * span), ("arch", "rise", SCHEMA["arch"]["rise"].high * span),
             ("arch", "voussoirs", SCHEMA["arch"]["voussoirs"].low), ("load", "position", 0.0),
             ("load", "position", 1.0), ("load", "length", span), ("load", "factor", SCHEMA["load"]["factor"].low),
             ("load", "factor", SCHEMA["load"]["factor"].high)]
    for section, name, value in cases:
        res = lp_at(section, name, value)
        assert res.status in ("limit load found", "no collapse (unbounded)", "unstable under self-weight"), res
        assert res.load is None or (np.isfinite(res.load) and res.load > 0), (section, name, value, res.load)


@pytest.mark.slow
def test_the_lp_answers_for_the_most_voussoirs():
    res = lp_at("arch", "voussoirs", SCHEMA["arch"]["voussoirs"].high)
    assert res.status == "limit load found" and res.load > 0


SCALED_SCENES = {
    "semicircle, point load on a joint": scene_dict(),
    "segmental, patch": scene_dict(arch={"shape": "segmental", "rise": 2.5, "thickness": 0.6, "voussoirs": 20},
                                   load=[{"kind": "patch", "position": 0.3, "length": 1.5}]),
    "flattest segmental, a ring of 3e-4 x span": scene_dict(
        arch={"shape": "segmental", "rise": 0.45, "thickness": 0.0027, "voussoirs": 8},
        load=[{"kind": "point", "position": 0.3}]),
    "pointed, two loads off the joints": scene_dict(
        arch={"shape": "pointed", "rise": 7.0, "thickness": 0.8, "voussoirs": 24, "joint_at_loads": False},
        joints={"friction": 0.4}, load=[{"kind": "point", "position": 0.3}, {"kind": "point", "position": 0.7,
                                                                             "factor": 0.5}]),
}


SPANS = (SCHEMA["arch"]["span"].low, SCHEMA["arch"]["span"].high)


@pytest.mark.parametrize("span,factor", [(100.0, 1e-3), (1.0, 1e2), (SPANS[0], SPANS[1] / SPANS[0])])
@pytest.mark.parametrize("case", sorted(SCALED_SCENES))
def test_the_lp_limit_scales_with_the_square_of_the_size(case, span, factor):
    """All lengths in the plane times s (the width, densities and moduli kept): every force of the LP per unit
    width scales as s^2, so the limit load does (to 1e-6), with the same mechanism; from a 100 m bridge to its
    0.1 m model (s = 1e-3), from a 1 m model to a 100 m bridge (s = 1e2), across the whole span range."""
    d = SCALED_SCENES[case]
    base = scaled(d, span / d["arch"]["span"])
    small, large = collapse_load(scene_from_dict(base)), collapse_load(scene_from_dict(scaled(base, factor)))
    assert small.status == large.status == "limit load found"
    assert large.load / small.load == pytest.approx(factor ** 2, rel=1e-6)
    assert (large.hinges, large.sliding) == (small.hinges, small.sliding)


@pytest.mark.slow
@pytest.mark.parametrize("young", ["kept", "scaled"])
@pytest.mark.parametrize("span", SPANS)
def test_the_fe_limit_scales_with_the_square_of_the_size(span, young):
    """The reference ring scaled to the ends of the span range, its Young's modulus kept or scaled alike (E ~ s keeps
    the strains, hence the whole discrete problem, the same): the FE bracket divided by s^2 brackets the
    reference's limit within the bracket's tolerance, with the same hinges."""
    from bridgefem.analysis.runner import run_analysis

    d = scene_dict(mesh={"elements_through_thickness": 2})
    s = span / d["arch"]["span"]
    reference = run_analysis(scene_from_dict(d))
    resized = scaled(d, s)
    resized["masonry"]["young"] *= s if young == "scaled" else 1.0
    other = run_analysis(scene_from_dict(resized))
    r, o = reference.search, other.search
    total = reference.load_total
    assert r.status == o.status == "limit load found"
    assert o.lower * total / s ** 2 == pytest.approx(r.lower * total, rel=r.tolerance)
    assert o.upper * total / s ** 2 == pytest.approx(r.upper * total, rel=r.tolerance)
    assert {j.id for j in other.joints if j.hinge} == {j.id for j in reference.joints if j.hinge}


def test_a_patch_load_needs_a_length_in_its_range():
    with pytest.raises(SceneError, match=r"\[\[load\]\] #1 length = 0.0: a patch load needs a length; allowed is a "
                                         r"number from 0.001 x span to span in m \(0.009 to 9 m"):
        scene_from_dict(scene_dict(load=[{"kind": "patch", "position": 0.5}]))
