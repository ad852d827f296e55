"""PETSc starts without the option files of the folder bridgefem runs in and of the home folder, and without a
petsc.cfg there (bridgefem/petsc_start.py); the user's PETSC_OPTIONS are used, and a bad one stops bridgefem with one
line and exit code 2, nothing written; Ctrl-C under `./run mpirun` exits 130 as a serial run does.

Every hostile file here harms a bridgefem that reads it, each in its own way: the log written over the victim file,
the script run as PETSc's debug terminal (it creates the marker file), the secret's first word printed in PETSc's
error report.
"""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import ROOT, bridgefem, scene_dict, write_toml
from test_output_policy import COARSE, earlier_results, snapshot, strays

from bridgefem.solver.linear import CheckedSolve

SECRET = "TOPSECRET-3f9c"  # the first word of a file that is not an options file
VICTIM = "a line the user wrote\n"

# what each hostile option file holds ({folder}: the folder of the run); -debugger_pause 1: PETSc's 10 s wait for
# the debugger, shortened for a bridgefem that reads the file
ATTACKS = {
    "log_view": "-log_view :{folder}/important.txt\n",
    "debugger": "-start_in_debugger gdb\n-on_error_attach_debugger gdb\n-debug_terminal {folder}/evil.sh\n"
                "-debugger_pause 1\n",
    "options_file": "-options_file {secret}\n",
}
RC_FILES = {"petscrc": "petscrc", ".petscrc": ".petscrc", "~/.petscrc": "home/.petscrc"}


@pytest.fixture
def folder(tmp_path):
    """A folder with a valid scene, the user's file, a script that would mark its running, a secret beside it and
    an empty home folder."""
    work = tmp_path / "work"
    (work / "home").mkdir(parents=True)
    write_toml(work / "s.toml", scene_dict(**COARSE))
    (work / "important.txt").write_text(VICTIM)
    script = work / "evil.sh"
    script.write_text(f"#!/bin/sh\ntouch {work}/MARKER\n")
    script.chmod(0o755)
    (tmp_path / "secret").write_text(f"{SECRET} hash\n")
    return work


def plant(work: Path, attacks: tuple[str, ...], rc_files=RC_FILES.values()) -> None:
    """Write the option files ``rc_files`` (paths in ``work``), each holding ``attacks``."""
    text = "".join(ATTACKS[attack] for attack in attacks).format(folder=work, secret=work.parent / "secret")
    for name in rc_files:
        (work / name).write_text(text)


def in_folder(work: Path, *args, ranks: int = 1, **env) -> subprocess.CompletedProcess:
    """The command line run in ``work`` with ``work/home`` as the home folder and ``env`` set."""
    return bridgefem(*args, ranks=ranks, cwd=work, env={"HOME": str(work / "home"), "PETSC_OPTIONS": "", **env})


def assert_unharmed(work: Path, proc: subprocess.CompletedProcess) -> None:
    assert (work / "important.txt").read_text() == VICTIM
    assert not (work / "MARKER").exists()
    assert SECRET not in proc.stdout + proc.stderr


CHECK_STARTS_PETSC = ("--petsc", "ksp_type=preonly")
"""A PETSc option for ``check``, which then starts PETSc to validate it (without one it loads no PETSc)."""


@pytest.fixture(scope="module")
def clean_check(tmp_path_factory):
    """`bridgefem check` in a folder without rc files: what a hostile folder must not change. With a PETSc option
    (:data:`CHECK_STARTS_PETSC`) check starts PETSc to validate it, as run does."""
    work = tmp_path_factory.mktemp("clean")
    write_toml(work / "s.toml", scene_dict(**COARSE))
    proc = bridgefem("check", "s.toml", *CHECK_STARTS_PETSC, cwd=work)
    assert proc.returncode == 0, proc.stderr
    return proc


# ------------------------------------------------------------------ rc files and petsc.cfg are not read
@pytest.mark.parametrize("rc_file", RC_FILES)
def test_check_reads_no_rc_file(folder, clean_check, rc_file):
    """Each file on its own, with the two attacks that end in exit code 0 (the third stops PETSc's start)."""
    plant(folder, ("log_view", "debugger"), [RC_FILES[rc_file]])
    proc = in_folder(folder, "check", "s.toml", *CHECK_STARTS_PETSC)
    assert_unharmed(folder, proc)
    assert (proc.returncode, proc.stdout, proc.stderr) == (0, clean_check.stdout, "")


@pytest.mark.parametrize("attack", ATTACKS)
def test_lp_reads_no_rc_file(folder, attack):
    plant(folder, (attack,))
    proc = in_folder(folder, "lp", "s.toml", "--json")
    assert_unharmed(folder, proc)
    assert proc.returncode == 0 and json.loads(proc.stdout)["status"] == "limit load found", proc.stderr


@pytest.mark.slow
@pytest.mark.parametrize("attack", ATTACKS)
def test_run_reads_no_rc_file(folder, attack):
    plant(folder, (attack,))
    proc = in_folder(folder, "run", "s.toml", "--out", "out", "--quiet")
    assert_unharmed(folder, proc)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((folder / "out" / "results.json").read_text())["status"] == "limit load found"


@pytest.mark.mpi
def test_two_ranks_read_no_rc_file(folder):
    plant(folder, ("log_view", "debugger"))
    proc = in_folder(folder, "run", "s.toml", "--out", "out", "--quiet", ranks=2)
    assert_unharmed(folder, proc)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((folder / "out" / "results.json").read_text())["mpi_ranks"] == 2


def test_a_petsc_cfg_in_the_folder_chooses_no_petsc(folder, clean_check):
    """petsc4py imports the PETSc of the build a petsc.cfg in the current folder names: here a folder of the
    scene's, whose PETSc.py would mark its import."""
    (folder / "build").mkdir()
    (folder / "build" / "PETSc.py").write_text(f"open({str(folder / 'MARKER')!r}, 'w')\n")
    (folder / "petsc.cfg").write_text("PETSC_ARCH = /proc/self/cwd/build\n")
    proc = in_folder(folder, "check", "s.toml", *CHECK_STARTS_PETSC)
    assert_unharmed(folder, proc)
    assert (proc.returncode, proc.stdout, proc.stderr) == (0, clean_check.stdout, "")


@pytest.mark.parametrize("first", ["bridgefem.fe", "dolfinx"])
def test_a_program_that_starts_petsc_first_is_warned_of_the_rc_files_read(folder, first):
    """A library user whose program loads bridgefem's FE (``bridgefem.analyse`` does) before DOLFINx gets PETSc
    without rc files; one who imports DOLFINx first gets PETSc with them, which bridgefem cannot undo: it says so."""
    plant(folder, ("log_view",), ["petscrc"])
    code = (f"import {first}, bridgefem.fe, dolfinx; from petsc4py import PETSc; "
            "print(PETSc.Options().hasName('log_view'))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=folder, timeout=120,
                          env={**os.environ, "HOME": str(folder / "home"), "PETSC_OPTIONS": ""})
    assert proc.returncode == 0, proc.stderr
    read = first == "dolfinx"
    assert proc.stdout == f"{read}\n" and ("read the option files ['petscrc']" in proc.stderr) == read, proc.stderr


@pytest.mark.slow
def test_the_compilers_and_the_plots_read_no_settings_file_of_the_folder(folder):
    """DOLFINx's and FFCx's parameter files in the folder would give the C compiler a folder of programs of the
    scene's (``-B``: the compiler runs the assembler ``as`` found there, here the marking script); with an empty
    compilation cache (a new home folder) every form is compiled, and none with them. A ``matplotlibrc`` there
    would choose a backend module of the folder's (which marks its import) and typeset with LaTeX."""
    programs = folder / "programs"
    programs.mkdir()
    (programs / "as").symlink_to(folder / "evil.sh")
    flags = {"cffi_extra_compile_args": [f"-B{programs}/"], "cffi_verbose": True}
    (folder / "dolfinx_jit_parameters.json").write_text(json.dumps(flags))
    (folder / "ffcx_parameters.json").write_text(json.dumps({"scalar_type": "float"}))  # a type that fails to compile
    (folder / "evil_backend.py").write_text(f"open({str(folder / 'MARKER')!r}, 'w')\n")
    (folder / "matplotlibrc").write_text("backend: module://evil_backend\ntext.usetex: True\n")
    proc = in_folder(folder, "run", "s.toml", "--out", "out", "--quiet", XDG_CACHE_HOME=str(folder / "cache"))
    assert_unharmed(folder, proc)
    assert proc.returncode == 0, proc.stderr
    assert any((folder / "cache").rglob("*.c")), "no form was compiled: the test did not reach the compiler"


# ------------------------------------------------------------------ the user's PETSC_OPTIONS
MISSING = "/nonexistent-folder-3f9c"
BAD_OPTIONS = {  # PETSC_OPTIONS -> the option the error line names
    f"-options_file {MISSING}/opts": f"-options_file {MISSING}/opts",
    "-options_file {secret}": "-options_file {secret}",
    "-malloc_debug maybe": "-malloc_debug maybe",
    f"-start_in_debugger gdb -debug_terminal {MISSING}/term": f"'{MISSING}/term'",
    f"-on_error_attach_debugger gdb -debug_terminal {MISSING}/term": "-on_error_attach_debugger gdb",
    f"-history {MISSING}/history": f"-history {MISSING}/history",
    f"-log_view :{MISSING}/log.txt": f"-log_view :{MISSING}/log.txt",
    f"-malloc_view {MISSING}/malloc": f"-malloc_view {MISSING}/malloc",
    f"-info {MISSING}/info": f"-info {MISSING}/info",
    "-bridgefem_ksp_type nonsense": "-bridgefem_ksp_type nonsense",
    "-bridgefem_pc_factor_shift_type nonsense": "-bridgefem_pc_factor_shift_type nonsense",
}


@pytest.mark.slow  # an end-to-end run of more than a second
@pytest.mark.parametrize("options", BAD_OPTIONS)
def test_a_bad_petsc_option_gives_one_line_and_exit_2(folder, options):
    named = BAD_OPTIONS[options]
    fill = {"folder": folder, "secret": folder.parent / "secret"}
    before = snapshot(folder.parent)
    proc = in_folder(folder, "run", "s.toml", "--out", "out", PETSC_OPTIONS=options.format(**fill))
    assert proc.returncode == 2 and proc.stdout == "", proc.stderr
    assert proc.stderr.startswith("bridgefem: error: PETSC_OPTIONS: ") and proc.stderr.count("\n") == 1, proc.stderr
    assert named.format(**fill) in proc.stderr, proc.stderr
    assert SECRET not in proc.stderr
    assert snapshot(folder.parent) == before


@pytest.mark.mpi
def test_two_ranks_give_one_line_for_a_bad_petsc_option(folder):
    before = snapshot(folder.parent)
    proc = in_folder(folder, "run", "s.toml", "--out", "out", ranks=2, PETSC_OPTIONS="-malloc_debug maybe")
    assert proc.returncode == 2 and proc.stderr.count("bridgefem: error:") == 1, proc.stderr
    assert "PETSC_OPTIONS: -malloc_debug maybe" in proc.stderr
    assert snapshot(folder.parent) == before


@pytest.mark.slow  # an end-to-end run of more than a second
def test_petsc_options_write_the_files_the_user_asks_for(folder):
    """PETSC_OPTIONS are the user's: PETSc writes its log where they say, and reads their options file."""
    (folder / "opts").write_text(f"-log_view :{folder}/log.txt\n")
    proc = in_folder(folder, "run", "s.toml", "--out", "out", "--quiet", PETSC_OPTIONS=f"-options_file {folder}/opts")
    assert proc.returncode == 0, proc.stderr
    assert "PETSc Performance Summary" in (folder / "log.txt").read_text()


def test_the_contact_solvers_petsc_options_come_after_the_defaults_and_before_the_run_s(monkeypatch):
    """-bridgefem_KEY VALUE in PETSC_OPTIONS replaces bridgefem's default; the scene's and the command line's
    options (``options``) override it. PETSc's options as it started are monkeypatched: PETSC_OPTIONS is read once."""
    from petsc4py import PETSc

    import bridgefem.petsc_start as start

    monkeypatch.setattr(start, "_startup_options", {"bridgefem_pc_factor_mat_solver_type": "petsc",
                                                    "bridgefem_ksp_monitor": "", "ksp_type": "cg"})
    A = PETSc.Mat().createAIJ([2, 2], nnz=1, comm=PETSc.COMM_SELF)
    A.setValue(0, 0, 1.0)
    A.setValue(1, 1, 2.0)
    A.assemble()
    environment = CheckedSolve(A, {})
    assert environment.options["pc_factor_mat_solver_type"] == "petsc" and environment.options["ksp_monitor"] == ""
    assert environment.options["ksp_type"] == "preonly"  # an option without the prefix is not the contact solver's
    assert environment.ksp.getPC().getFactorSolverType() == "petsc"
    run = CheckedSolve(A, {"pc_factor_mat_solver_type": "mumps"})
    assert run.ksp.getPC().getFactorSolverType() == "mumps"


@pytest.mark.slow
def test_a_contact_solver_option_in_petsc_options_is_used(folder):
    """PETSc's own LU cannot factor the contact system (tests/test_output_policy.py): a solver failure, exit 1."""
    proc = in_folder(folder, "run", "s.toml", "--out", "out", "--quiet",
                     PETSC_OPTIONS="-bridgefem_pc_factor_mat_solver_type petsc")
    assert proc.returncode == 1, proc.stderr
    failed = json.loads((folder / "out-failed" / "results.json").read_text())
    assert failed["solver"]["petsc_options"]["pc_factor_mat_solver_type"] == "petsc"


# ------------------------------------------------------------------ Ctrl-C under mpirun
@pytest.mark.mpi
def test_ctrl_c_under_run_mpirun_exits_130_and_keeps_the_earlier_results(tmp_path):
    """Open MPI's mpirun ends the job on SIGINT and exits 1 whatever the ranks return; ./run runs it so that the
    run exits 130, as a serial one does. The ranks are stopped (no final report) and the target keeps the earlier
    results."""
    out = earlier_results(tmp_path / "out")
    before = snapshot(out)
    scene = ROOT / "demos" / "prestwood.toml"  # a plastic fill: load steps for tens of seconds on two ranks
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    # started as a terminal starts a command: SIGINT neither ignored nor blocked, whatever this test process's
    # worker has done to its own (a child inherits both, and a shell cannot trap a signal ignored at its start)
    handler = signal.signal(signal.SIGINT, signal.default_int_handler)
    mask = signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:
        proc = subprocess.Popen([str(ROOT / "run"), "mpirun", "-n", "2", sys.executable, "-m", "bridgefem.io.cli",
                                 "run", str(scene), "--out", str(out)], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    finally:
        signal.signal(signal.SIGINT, handler)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    while (line := proc.stdout.readline()) and not line.startswith("step   1"):
        pass
    assert line, proc.communicate()[1]
    proc.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    rest, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (f"exit {proc.returncode} {time.monotonic() - t0:.1f} s after the signal; "
                                    f"stderr {err[-500:]!r}; the rest of stdout {rest[-800:]!r}; this process's "
                                    f"SIGINT handler {handler!r}, blocked signals {mask!r}")
    assert time.monotonic() - t0 < 10 and "results in" not in rest, rest
    assert snapshot(out) == before
    assert [name for name in strays(tmp_path) if "bridgefem-tmp" in name] == []
