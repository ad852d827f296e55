"""What a new user meets first: ``./run --help``, a copied checkout, a mistyped option or scene key (the nearest
name suggested), ``check --json`` and ``python -m bridgefem``."""
import json
import os
import shutil
import subprocess
import sys

import pytest
from conftest import ROOT, scene_dict

from bridgefem.io import cli
from bridgefem.scene.keys import SceneError
from bridgefem.scene.reader import load_scene, scene_from_dict

DEMO = ROOT / "demos" / "bare_arch.toml"


@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_run_script_help_is_its_own_usage(flag):
    """``./run --help`` prints how to use ./run (not bash's exec help), before any set-up, and exits 0."""
    proc = subprocess.run([str(ROOT / "run"), flag], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.startswith("usage: ./run demo")
    assert "./run test" in proc.stdout and "exec" not in proc.stdout


@pytest.mark.slow
def test_a_copied_checkout_runs_its_own_code(tmp_path):
    """A checkout copied with its .venv (if it has one): ./run in the copy rebuilds the .venv for the copy and imports
    the copy's bridgefem, not the original's (the editable install names the folder it was made in)."""
    copy = tmp_path / "copy"
    shutil.copytree(ROOT, copy, symlinks=True,
                    ignore=shutil.ignore_patterns(".git", "results", "__pycache__", ".pytest_cache", ".ruff_cache"))
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH")}
    proc = subprocess.run([str(copy / "run"), "python", "-c", "import bridgefem; print(bridgefem.__file__)"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == str(copy / "bridgefem" / "__init__.py")
    assert f"was set up for {ROOT}; rebuilding it for {copy}" in proc.stderr
    assert (copy / ".venv" / ".bridgefem-setup").read_text().splitlines()[1] == str(copy)


@pytest.mark.parametrize("argv, message", [
    (["run", str(DEMO), "--outt", "X"], "unknown option --outt; did you mean --out?"),
    (["run", str(DEMO), "--quite"], "unknown option --quite; did you mean --quiet?"),
    (["lp", str(DEMO), "--jsn"], "unknown option --jsn; did you mean --json?"),
    (["check", str(DEMO), "--frobnicate"], "unknown option --frobnicate; the options are --help, --petsc, --no-size-limit, --json"),
    (["run", str(DEMO), "-bridgefm_ksp_type", "preonly"], "PETSc options must start with -bridgefem_"),
    (["run", str(DEMO), "second.toml"], "unexpected argument second.toml"),
])
def test_an_unknown_option_names_the_nearest_one(capsys, argv, message):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err == f"bridgefem: error: {err.split('error: ', 1)[1]}" and message in err and err.count("\n") == 1


def test_petsc_options_on_the_command_line_still_pass():
    options = ["--help", "--out", "--petsc", "--quiet", "--json", "--no-size-limit"]
    assert cli._petsc_options(["ksp_type=preonly"], ["-bridgefem_pc_type", "lu", "-bridgefem_ksp_view"],
                              options) == {"ksp_type": "preonly", "pc_type": "lu", "ksp_view": ""}


@pytest.mark.parametrize("sections, hint", [
    ({"arch": {"spna": 9.0}}, "[arch]: unknown key 'spna'; did you mean 'span'? allowed keys are shape, span"),
    ({"joints": {"fiction": 0.6}}, "did you mean 'friction'?"),
    ({"fil": {"depth": 0.5}}, "[fil]: unknown section; did you mean [fill]? allowed sections are [scene]"),
    ({"loads": [{"kind": "point", "position": 0.5}]}, "did you mean [[load]]?"),
    ({"arch": {"colour": "red"}}, "[arch]: unknown key 'colour'; allowed keys are shape"),
])
def test_an_unknown_scene_key_names_the_nearest_one(sections, hint):
    with pytest.raises(SceneError) as err:
        scene_from_dict(scene_dict(**sections))
    assert hint in str(err.value)


def test_check_json_is_the_resolved_scene_and_its_size(capsys):
    """``check --json``: one JSON object whose scene reads back as the same scene, with each key's unit and the
    size estimate the text form prints."""
    assert cli.main(["check", str(DEMO), "--json"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1
    data = json.loads(out)
    assert scene_from_dict(data["scene"]) == load_scene(DEMO)
    assert data["units"]["arch"]["span"] == "m" and data["units"]["masonry"]["young"] == "Pa"
    assert cli.main(["check", str(DEMO)]) == 0
    text = capsys.readouterr().out.splitlines()[0]
    size = data["size"]
    assert f"about {size['cells']:,} cells, {size['dofs']:,} unknowns" in text and size["memory_unit"] == "bytes"


@pytest.mark.slow
def test_python_m_bridgefem_is_the_command_line():
    """``python -m bridgefem`` runs the same command line as the ``bridgefem`` script."""
    proc = subprocess.run([sys.executable, "-m", "bridgefem", "lp", str(DEMO), "--json"], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["mechanism"]["hinges"] == [6, 12, 16]
    usage = subprocess.run([sys.executable, "-m", "bridgefem"], capture_output=True, text=True, timeout=300)
    assert usage.returncode == 2 and usage.stderr.startswith("usage: bridgefem")
