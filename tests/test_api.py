"""The public API (``import bridgefem``): a cheap import, scenes edited as their files would be, the rigid-block LP
against a published value, ``analyse`` against the LP, the command line's results.json and two MPI ranks, and the
README's example."""
import dataclasses
import json
import os
import re
import subprocess
import sys

import pytest
from conftest import ROOT, bridgefem, scene_dict

import bridgefem as api
from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import load_scene, scene_from_dict

DEMO = ROOT / "demos" / "bare_arch.toml"

LIGHT = """
import sys
import bridgefem
scene = bridgefem.load_scene(sys.argv[1])
bridgefem.lp(bridgefem.edit(scene, arch={"thickness": 0.8}))
print(sorted(m for m in ("dolfinx", "petsc4py", "mpi4py", "gmsh", "ufl") if m in sys.modules))
"""


def test_import_edit_and_lp_load_neither_dolfinx_nor_petsc():
    """``import bridgefem`` stays cheap, and so do scenes and the rigid-block LP: DOLFINx and PETSc load only when
    ``analyse`` runs."""
    proc = subprocess.run([sys.executable, "-c", LIGHT, str(DEMO)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"
    assert set(api.__all__) <= set(dir(api))
    with pytest.raises(AttributeError, match="no attribute 'analyze'"):
        api.analyze


@pytest.mark.parametrize("sections", [
    {"arch": {"thickness": -1.0}},
    {"arch": {"spam": 12.0}},
    {"fil": {"depth": 0.5}},
    {"load": [{"kind": "point", "position": 1.5}]},
    {"solver": {"preset": "quick"}},
])
def test_an_edit_is_refused_with_the_files_message(tmp_scene, sections):
    """A bad value in an edit raises the one-line SceneError the same value in a scene file raises."""
    scene = scene_from_dict(scene_dict())
    with pytest.raises(SceneError) as edited:
        api.edit(scene, **sections)
    with pytest.raises(SceneError) as filed:
        load_scene(tmp_scene(scene_dict(**sections)))
    assert str(edited.value) == str(filed.value)
    assert "\n" not in str(edited.value)


def _without(d: dict, section: str, key: str) -> dict:
    del d[section][key]
    return d


def test_an_edit_means_what_the_same_change_in_the_file_means(tmp_scene):
    """What the schema derives follows the edited values, as in a file: a semicircle's rise (span/2), a preset's
    mesh and tolerance, an elastic abutment's material (the masonry's); a key set to None takes its default
    again, a section set to None is removed."""
    base = _without(scene_dict(arch={"joint_at_loads": False}), "arch", "rise")
    scene = load_scene(tmp_scene(base, "base"))
    edits = [
        ({"arch": {"span": 12.0}}, scene_dict(arch={"span": 12.0, "joint_at_loads": False})),
        ({"solver": {"preset": "fast"}}, scene_dict(arch={"joint_at_loads": False}, solver={"preset": "fast"})),
        ({"arch": {"joint_at_loads": None}}, scene_dict()),
    ]
    for sections, as_file in edits:
        as_file["scene"] = {"name": "base"}
        assert api.edit(scene, **sections) == load_scene(tmp_scene(_without(as_file, "arch", "rise"), "edited"))
    assert api.edit(scene, arch={"span": 12.0}).arch.rise == 6.0
    assert api.edit(scene, solver={"preset": "fast"}).mesh.elements_through_thickness == 2
    elastic = api.edit(scene, abutments={"model": "elastic", "height": 2.0})
    assert elastic.abutments.young == 10e9
    assert api.edit(elastic, masonry={"young": 5e9}).abutments.young == 5e9
    assert api.edit(elastic, abutments=None).abutments.model == "rigid"
    assert api.edit(scene, scene={"name": "other"}).name == "other" and scene.name == "base"


def test_a_scene_changed_outside_the_schema_is_not_edited():
    """dataclasses.replace leaves the scene's document behind: editing it would silently undo the change."""
    scene = dataclasses.replace(scene_from_dict(scene_dict()), gravity=5.0)
    with pytest.raises(ValueError, match="changed outside"):
        api.edit(scene, joints={"friction": 0.5})


# Least thickness of a complete semicircle with radial joints under self-weight: t/R = 0.107426 (Cocchetti & Rizzi
# 2020; Milankovitch 0.1075), R the centreline radius; 100 voussoirs come within 0.3 % of it
# (tests/test_rigid_block.py). A ring 1 % thinner than that does not stand, one 1 % thicker carries a load.
@pytest.mark.parametrize("ratio, status", [(0.107426 * 0.99, "unstable under self-weight"),
                                           (0.107426 * 1.01, "limit load found")])
def test_lp_of_a_thin_semicircle_stands_above_heymans_least_thickness(ratio, status):
    span = 9.0
    scene = scene_from_dict(_without(scene_dict(arch={"voussoirs": 100, "joint_at_loads": False},
                                                joints={"friction": 10.0}), "arch", "rise"))
    thickness = ratio * span / 2 / (1 - ratio / 2)  # t = ratio x R with R = span/2 + t/2
    lp = api.lp(api.edit(scene, arch={"thickness": thickness}))
    assert lp.status == status and lp.unit == "N" and lp.model == "bare ring"
    assert (lp.load is None) == (status != "limit load found")


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The demo scene analysed through the API, and ``bridgefem run --json`` of it: its stdout and results.json."""
    out = tmp_path_factory.mktemp("api") / "test-api-demo"
    proc = bridgefem("run", DEMO, "--out", out, "--json")
    assert proc.returncode == 0, proc.stderr
    return api.analyse(api.load_scene(DEMO)), proc.stdout, json.loads((out / "results.json").read_text())


@pytest.mark.slow
def test_analyse_brackets_the_rigid_block_lp_of_the_scene(demo):
    """The FE bracket (in N, not a load level) lies within the evidence rule's 0.5 % of the rigid-block LP of the
    same scene, solved alone, and the LP's hinges are among the FE's."""
    result = demo[0]
    lp = api.lp(result.scene)
    assert result.status == api.Status.LIMIT and result.lp == lp
    load = result.limit_load
    assert load.unit == "N" and load.width == 1.0
    assert load.lower < load.upper <= load.lower * (1 + load.tolerance)
    assert load.lower <= 1.005 * lp.load and load.upper >= 0.995 * lp.load
    assert set(lp.hinges) <= set(result.hinges)
    assert result.fe_lp_ratio == pytest.approx((load.lower + load.upper) / 2 / lp.load, rel=1e-12)


def _timeless(data):
    """``data`` without wall times and versions (the only entries two runs of one scene may differ in)."""
    if isinstance(data, dict):
        return {k: _timeless(v) for k, v in data.items()
                if not (k in ("seconds", "timings", "versions") or k.startswith("time"))}
    if isinstance(data, list):
        return [_timeless(v) for v in data]
    return data


@pytest.mark.slow
def test_to_json_is_the_results_file_and_run_json_its_summary(demo):
    """result.to_json() holds what ``bridgefem run`` writes to results.json, units included; ``run --json`` prints
    one JSON object on stdout and nothing else (the progress goes to stderr), with the same entries."""
    result, stdout, filed = demo
    data = json.loads(result.to_json())
    assert _timeless(data) == _timeless(filed)
    assert data["limit_load"] == {"lower": result.limit_load.lower, "upper": result.limit_load.upper, "unit": "N",
                                  "tolerance": 1e-4, "width": 1.0}
    assert data["units"]["force"].startswith("N")
    lines = stdout.splitlines()
    assert len(lines) == 1
    printed = json.loads(lines[0])
    assert printed["results"].endswith("test-api-demo")
    assert _timeless({k: v for k, v in printed.items() if k != "results"}) == _timeless(
        {k: filed[k] for k in printed if k != "results"})


MPI_SCRIPT = """
import json, sys
from mpi4py import MPI
import bridgefem
r = bridgefem.analyse(bridgefem.load_scene(sys.argv[1]), comm=MPI.COMM_WORLD)
print(json.dumps([MPI.COMM_WORLD.rank, r.summary["mpi_ranks"], r.status, r.limit_load.lower, r.limit_load.upper,
                  list(r.hinges)]))
"""


@pytest.mark.mpi
def test_two_ranks_give_the_serial_result(demo):
    """Under mpirun -n 2 every rank gets the same result, the serial one up to round-off."""
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    proc = subprocess.run(["mpirun", "-n", "2", sys.executable, "-c", MPI_SCRIPT, str(DEMO)], capture_output=True,
                          text=True, timeout=600, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    rows = sorted(json.loads(line) for line in proc.stdout.splitlines())
    serial = demo[0]
    assert [r[:3] for r in rows] == [[0, 2, "limit load found"], [1, 2, "limit load found"]]
    for _, _, _, lower, upper, hinges in rows:
        assert lower == pytest.approx(serial.limit_load.lower, rel=1e-9)
        assert upper == pytest.approx(serial.limit_load.upper, rel=1e-9)
        assert hinges == list(serial.hinges)


@pytest.mark.slow
def test_the_readme_example_prints_what_the_readme_shows():
    """The README's Python example, run as it stands, prints the output the README shows after it."""
    readme = (ROOT / "README.md").read_text()
    code, shown = re.search(r"```python\n(.*?)```\n.*?```text\n(.*?)```", readme, re.S).groups()
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == shown
