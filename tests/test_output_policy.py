"""The output policy (bridgefem/output.py, docs/output-policy.md): a user's files are never touched.

bridgefem writes only into a new folder, an empty one or an earlier bridgefem results folder, checked before the
analysis; replaces it atomically; removes its temporary folder on any error or SIGTERM (and the next run removes
one left by SIGKILL); refuses a second run on the same folder; a failed run keeps the earlier results.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT, bridgefem, scene_dict, write_toml

from bridgefem.io import cli
from bridgefem.io.output import MARKER, OutputError, check_target, claim, results_folder

ENV = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
       "OMPI_MCA_rmaps_base_oversubscribe": "1"}
COARSE = {"mesh": {"elements_through_thickness": 1}, "solver": {"tolerance": 0.01}}  # an analysis of ~1 s


def snapshot(folder: Path) -> dict[str, bytes | None]:
    """Every path below ``folder`` with its content (None for folders)."""
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None) for p in folder.rglob("*")}


def earlier_results(out: Path) -> Path:
    """A results folder as an earlier run leaves it."""
    with results_folder(out) as tmp:
        (tmp / "results.json").write_text('{"earlier": true}')
    return out


def strays(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


@pytest.fixture
def never_analyse(monkeypatch):
    """In-process runs that must be refused before the analysis: reaching it fails the test."""
    import bridgefem.analysis.runner

    def reached(*args, **kwargs):
        raise AssertionError("the analysis was reached")

    monkeypatch.setattr(bridgefem.analysis.runner, "run_analysis", reached)


def run_refused(capsys, *args) -> str:
    """cli.main on arguments that must be refused: exit 2 and one line on stderr, which is returned."""
    code = cli.main(["run", *map(str, args)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("bridgefem: error: "), err
    return err


# ------------------------------------------------------------------ which targets bridgefem writes
def test_a_new_an_empty_and_an_earlier_results_folder_are_written(tmp_path):
    for out in (tmp_path / "new" / "deeper", tmp_path / "empty"):
        (tmp_path / "empty").mkdir(exist_ok=True)
        with results_folder(out) as tmp:
            (tmp / "a.txt").write_text("1")
        assert sorted(os.listdir(out)) == [MARKER, "a.txt"]
        with results_folder(out) as tmp:  # its own results folder: replaced
            (tmp / "b.txt").write_text("2")
        assert sorted(os.listdir(out)) == [MARKER, "b.txt"]
        assert json.loads((out / MARKER).read_text())["files"] == ["b.txt"]
    assert strays(tmp_path) == [] and strays(tmp_path / "new") == []


def test_foreign_targets_are_refused_and_untouched(tmp_path):
    user = tmp_path / "user"
    (user / "drawings").mkdir(parents=True)
    (user / "notes.txt").write_text("mine")
    added = earlier_results(tmp_path / "added")
    (added / "my.toml").write_text("mine")  # a user's file put into a results folder
    (tmp_path / "file.txt").write_text("mine")
    (tmp_path / "link").symlink_to(user)
    before = snapshot(tmp_path)
    for target, reason in [(user, "did not write"), (added, "'my.toml', which bridgefem did not write"),
                           (tmp_path / "file.txt", "is not a folder"), (tmp_path / "link", "symbolic link")]:
        with pytest.raises(OutputError, match=reason):
            check_target(target)
        with pytest.raises(OutputError, match=reason):
            with results_folder(target) as tmp:
                (tmp / "results.json").write_text("new")
    assert snapshot(tmp_path) == before


def test_the_current_folder_and_above_are_refused(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")
    for target in (".", "..", "/", tmp_path):
        with pytest.raises(OutputError, match="current folder|root"):
            check_target(Path(target))


@pytest.mark.skipif(not os.path.ismount("/proc"), reason="needs /proc mounted")
def test_a_mount_point_is_refused():
    with pytest.raises(OutputError, match="mount point"):
        check_target(Path("/proc"))


def test_an_error_while_writing_keeps_the_earlier_results(tmp_path):
    out = earlier_results(tmp_path / "out")
    before = snapshot(tmp_path)
    with pytest.raises(RuntimeError):
        with results_folder(out) as tmp:
            (tmp / "results.json").write_text("half")
            raise RuntimeError("disk full")
    assert snapshot(tmp_path) == before


def test_a_file_put_into_the_target_during_the_run_stops_the_replacement(tmp_path):
    out = earlier_results(tmp_path / "out")
    with pytest.raises(OutputError, match="notes.txt"):
        with results_folder(out) as tmp:
            (tmp / "results.json").write_text("new")
            (out / "notes.txt").write_text("written by the user meanwhile")
    assert sorted(os.listdir(out)) == sorted([MARKER, "results.json", "notes.txt"]) and strays(tmp_path) == []


# ------------------------------------------------------------------ the command line, before any analysis
def test_cli_refuses_a_foreign_out_before_the_analysis(tmp_path, capsys, never_analyse):
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    user = tmp_path / "user"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    (tmp_path / "existing_file.txt").write_text("mine")
    before = snapshot(tmp_path)
    assert "did not write" in run_refused(capsys, scene, "--out", user)
    assert "never touches this file" in run_refused(capsys, scene, "--out", tmp_path / "existing_file.txt")
    assert snapshot(tmp_path) == before


def test_cli_refuses_a_foreign_failed_folder_before_the_analysis(tmp_path, capsys, never_analyse):
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    (tmp_path / "out-failed").mkdir()
    (tmp_path / "out-failed" / "x").write_text("mine")
    assert "out-failed" in run_refused(capsys, scene, "--out", tmp_path / "out")


@pytest.mark.parametrize("name", [".", "..", "../../x", "/tmp/x", "a/b/c", "a\\b", "x\x00y", "tab\there", "a" * 101])
def test_a_scene_name_that_is_not_a_file_name_touches_nothing(tmp_path, monkeypatch, capsys, never_analyse, name):
    work = tmp_path / "work"
    (work / "results" / "earlier").mkdir(parents=True)
    (work / "results" / "earlier" / "results.json").write_text("{}")
    scene = write_toml(tmp_path / "s.toml", scene_dict(scene={"name": name}))
    monkeypatch.chdir(work)
    before = snapshot(tmp_path)
    assert "[scene] name" in run_refused(capsys, scene)
    assert snapshot(tmp_path) == before


# ------------------------------------------------------------------ locks, signals, stale folders
HOLD = """
import sys, time
from pathlib import Path
from bridgefem.io.output import claim
with claim(Path(sys.argv[1])):
    print("holding", flush=True)
    time.sleep(60)
"""


def test_a_second_run_on_the_same_folder_is_refused(tmp_path, capsys, never_analyse):
    out = earlier_results(tmp_path / "out")
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(out)], stdout=subprocess.PIPE, text=True, env=ENV)
    try:
        assert holder.stdout.readline().strip() == "holding"
        assert "another bridgefem run" in run_refused(capsys, scene, "--out", out)
        with pytest.raises(OutputError, match="another bridgefem run"):
            with results_folder(out) as tmp:
                (tmp / "results.json").write_text("new")
    finally:
        holder.kill()
        holder.wait()
    assert json.loads((out / "results.json").read_text()) == {"earlier": True}
    with claim(out):  # free again once the holder is gone (its lock file stays, harmlessly)
        pass
    assert strays(tmp_path) == []


WRITE_SLOWLY = """
import sys, time
from pathlib import Path
from bridgefem.io.output import results_folder
with results_folder(Path(sys.argv[1])) as tmp:
    (tmp / "results.json").write_text('{"new": true}')
    print("writing", flush=True)
    time.sleep(60)
"""


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_a_signal_while_writing_keeps_the_earlier_results(tmp_path, capsys, sig):
    """SIGTERM: the temporary folder is removed at once. SIGKILL: it stays, and the next run removes it."""
    out = earlier_results(tmp_path / "out")
    proc = subprocess.Popen([sys.executable, "-c", WRITE_SLOWLY, str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV)
    assert proc.stdout.readline().strip() == "writing"
    proc.send_signal(sig)
    proc.wait(timeout=30)
    assert json.loads((out / "results.json").read_text()) == {"earlier": True}
    left = strays(tmp_path)
    if sig == signal.SIGTERM:
        assert left == []
        return
    assert len(left) == 2 and left[0].startswith(".out.bridgefem-tmp-") and left[1] == ".out.lock"
    with results_folder(out) as tmp:
        (tmp / "results.json").write_text('{"next": true}')
    assert "removed" in capsys.readouterr().err
    assert strays(tmp_path) == [] and json.loads((out / "results.json").read_text()) == {"next": True}


# ------------------------------------------------------------------ end to end (an analysis each)
@pytest.mark.slow
def test_sigterm_during_the_cli_write_exits_143_and_keeps_the_earlier_results(tmp_path):
    out = earlier_results(tmp_path / "out")
    scene = write_toml(tmp_path / "s.toml", scene_dict(**COARSE))
    script = """
import sys, time
import bridgefem.io.results as results
from bridgefem.io import cli
write = results._write_fields
def slow(*args):
    write(*args)
    print("writing", flush=True)
    time.sleep(60)
results._write_fields = slow
sys.exit(cli.main(sys.argv[1:]))
"""
    proc = subprocess.Popen([sys.executable, "-c", script, "run", str(scene), "--out", str(out), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=ROOT)
    while (line := proc.stdout.readline()) and line.strip() != "writing":
        pass
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and len(err.splitlines()) == 1 and "SIGTERM" in err, err
    assert json.loads((out / "results.json").read_text()) == {"earlier": True}
    assert strays(tmp_path) == []


@pytest.mark.slow
def test_a_failed_run_keeps_the_earlier_results(tmp_path):
    """PETSc's own LU cannot factor the contact system: a solver failure (exit 1), written to out-failed."""
    out = earlier_results(tmp_path / "out")
    scene = write_toml(tmp_path / "s.toml", scene_dict(**COARSE))
    proc = bridgefem("run", scene, "--out", out, "--quiet", "--petsc", "pc_factor_mat_solver_type=petsc")
    assert proc.returncode == 1, proc.stderr
    assert json.loads((out / "results.json").read_text()) == {"earlier": True}
    failed = json.loads((tmp_path / "out-failed" / "results.json").read_text())
    assert failed["status"].startswith("solver failure")
    assert f"{tmp_path / 'out-failed'}/" in proc.stderr and strays(tmp_path) == []


@pytest.mark.slow
@pytest.mark.mpi
def test_two_ranks_refuse_a_foreign_out_with_one_line(tmp_path):
    scene = write_toml(tmp_path / "s.toml", scene_dict(**COARSE))
    out = tmp_path / "user"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    proc = bridgefem("run", scene, "--out", out, ranks=2)
    assert proc.returncode == 2 and proc.stderr.count("bridgefem: error:") == 1, proc.stderr
    assert snapshot(out) == {"notes.txt": b"mine"} and strays(tmp_path) == []
