"""Scene validation: every bad value gives one message naming the key, the value and what is allowed."""
import tomllib

import pytest
from conftest import ROOT, scene_dict

from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import load_scene, resolved_toml, scene_from_dict
from bridgefem.scene.schema import keys_markdown


@pytest.mark.parametrize("sections,expected", [
    ({"arch": {"thickness": -1.0}}, ["[arch] thickness", "-1.0", "0.0001 x span", "0.0009 to 9 m"]),
    ({"arch": {"voussoirs": 1}}, ["[arch] voussoirs", "1", "2 to 4096"]),
    ({"arch": {"voussoirs": 16.5}}, ["[arch] voussoirs", "16.5", "int"]),
    ({"arch": {"shape": "gothic"}}, ["[arch] shape", "gothic", "semicircular"]),
    ({"arch": {"shape": "segmental", "rise": 5.0}}, ["[arch] rise", "5.0", "span/2"]),
    ({"arch": {"rise": 3.0}}, ["[arch] rise", "3.0", "semicircular"]),
    ({"arch": {"colour": "red"}}, ["[arch]", "colour", "allowed keys"]),
    ({"joints": {"friction": -0.1}}, ["[joints] friction", "-0.1", "from 0 to"]),
    ({"masonry": {"poisson": 0.5}}, ["[masonry] poisson", "0.5", "< 0.5"]),
    ({"masonry": {"young": "stiff"}}, ["[masonry] young", "stiff", "number"]),
    ({"load": [{"kind": "point", "position": 1.2}]}, ["[[load]] #1 position", "1.2", "0 to 1"]),
    ({"load": [{"kind": "patch", "position": 0.99, "length": 1.0}]}, ["[[load]] #1", "within the span"]),
    ({"load": [{"kind": "point", "position": 0.5, "length": 1.0}]}, ["[[load]] #1 length", "point load"]),
    ({"solver": {"tolerance": 0.0}}, ["[solver] tolerance", "0.0"]),
    ({"mesh": {"degree": 3}}, ["[mesh] degree", "3", "1 or 2"]),
    ({"bridge": {}}, ["[bridge]", "unknown section"]),
])
def test_bad_scene_values_are_named(sections, expected):
    with pytest.raises(SceneError) as err:
        scene_from_dict(scene_dict(**sections))
    for text in expected:
        assert text in str(err.value)


def test_missing_key_and_section_are_named():
    d = scene_dict()
    del d["arch"]["span"]
    with pytest.raises(SceneError, match=r"\[arch\] span: missing"):
        scene_from_dict(d)
    d = scene_dict()
    del d["masonry"]
    with pytest.raises(SceneError, match=r"\[masonry\]: missing section"):
        scene_from_dict(d)


def test_defaults_and_units():
    s = scene_from_dict(scene_dict())
    assert (s.gravity, s.arch.width, s.arch.joint_at_loads, s.mesh.degree, s.model.plane) == (9.81, 1.0, True, 1,
                                                                                              "strain")
    assert s.loads[0].x_range(9.0) == pytest.approx((-2.5, -2.5), abs=1e-4)


def test_docs_scene_keys_is_generated_from_the_schema():
    """docs/scene-keys.md is the schema's table: regenerate it with ./run python -m bridgefem.scene.schema."""
    assert (ROOT / "docs" / "scene-keys.md").read_text() == keys_markdown()


@pytest.mark.parametrize("demo", ["bare_arch", "abutments", "prestwood"])
def test_the_resolved_scene_reads_back_as_the_same_scene(demo):
    """bridgefem check prints every key resolved: read back, it is the same scene (defaults, preset and derived
    values included)."""
    scene = load_scene(ROOT / "demos" / f"{demo}.toml")
    text = resolved_toml(scene)
    assert scene_from_dict(tomllib.loads(text)) == scene
    for section in ("[scene]", "[arch]", "[masonry]", "[joints]", "[[load]]", "[mesh]", "[solver]"):
        assert section in text
    assert "gravity = 9.81  # m/s^2" in text and "max_steps = 200" in text


def test_check_prints_the_resolved_scene(capsys):
    from bridgefem.io import cli

    assert cli.main(["check", str(ROOT / "demos" / "bare_arch.toml")]) == 0
    out = capsys.readouterr().out
    assert out.startswith("# bare_arch: valid; about 5") and "unknowns" in out
    assert "elements_through_thickness = 4" in out and "tolerance = 0.0001" in out


def test_a_preset_sets_the_keys_not_given():
    s = scene_from_dict(scene_dict(solver={"preset": "fast"}))
    assert (s.mesh.elements_through_thickness, s.solver.tolerance) == (2, 0.0005)
    s = scene_from_dict(scene_dict(solver={"preset": "fast", "tolerance": 0.01}))
    assert (s.mesh.elements_through_thickness, s.solver.tolerance) == (2, 0.01)
