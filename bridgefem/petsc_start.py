"""PETSc's start-up, made independent of the folder bridgefem runs in.

At its start PETSc reads the option files ``~/.petscrc``, ``./.petscrc`` and ``./petscrc``, and petsc4py imports the
PETSc build that a file ``petsc.cfg`` in the current folder names. A folder of scenes that people exchange could so
make bridgefem overwrite a file (``-log_view :notes.txt``), run a program (``-start_in_debugger gdb -debug_terminal
./x.sh``), print a line of a file that is not an options file (``-options_file /etc/shadow``) or import Python code
of its own (``PETSC_ARCH = /proc/self/cwd/x``). :func:`start`, which the subpackages that use PETSc or DOLFINx call as they are imported (before any of their
modules imports ``petsc4py.PETSc``), starts PETSc with ``-skip_petscrc`` and the build that petsc4py's own installation names;
every later import of ``petsc4py.PETSc`` then finds PETSc started (DOLFINx's too: its first import would start PETSc
with no options, rc files read).

PETSc's options are then those bridgefem sets (the scene's ``[solver.petsc]``, the command line's) and the user's
environment variables PETSC_OPTIONS and PETSC_OPTIONS_YAML: set by the person who runs bridgefem, they are theirs,
like the command line, and PETSc writes the files they ask for (``-log_view :log.txt``: at the end of every run, a
refused one included). A bad option in them stops bridgefem with one line on stderr and exit code 2 before anything
is written (PETSc's own report is a traceback, a crash, or a run that ends as if nothing were wrong):

- an option PETSc rejects as it starts (an options file it cannot open or read, a malformed value): its message,
  never the content of a file, which PETSc quotes when it cannot read a line as options;
- ``-start_in_debugger`` or ``-on_error_attach_debugger`` in PETSC_OPTIONS whose debugger or terminal program is
  not installed (PETSc starts it from a forked copy of bridgefem, which prints a line and exits, and the run goes on
  with no debugger);
- ``-history`` in PETSC_OPTIONS, ``-log_view`` or ``-malloc_view`` (wherever set) naming a file in a folder that
  does not exist or cannot be written (PETSc 3.18 crashes at its start for ``-history``; for the others it fails
  after the run, the results written).

Options of the contact solver (``-bridgefem_*``) in PETSC_OPTIONS are tried with the run's own before the analysis
(:func:`bridgefem.solver.linear.check_environment_options`).

A program that imports ``petsc4py.PETSc`` or DOLFINx before bridgefem has started PETSc itself, and the rc files
were read: :func:`start` cannot undo that and warns when there were any.
"""
from __future__ import annotations

import contextlib
import os
import re
import shutil
import sys
import warnings
from typing import Callable, Iterator

START_ARGS = ["-skip_petscrc"]
"""PETSc's command line at its start: no rc files (module docstring)."""
RC_FILES = ("~/.petscrc", ".petscrc", "petscrc")
"""The option files PETSc reads at its start unless told ``-skip_petscrc``."""
ENVIRONMENT = ("PETSC_OPTIONS", "PETSC_OPTIONS_YAML")
"""The environment variables PETSc reads its options from: the user's."""

# As PETSc's PetscSetDebuggerFromString reads a -start_in_debugger value (src/sys/error/adebug.c): the debuggers it
# may name, in the order PETSc looks for them (the last one named wins; gdb when none is), and those that open their
# own window instead of running in the terminal (-debug_terminal, "xterm -e" by default; "noxterm" in the value: none).
DEBUGGERS = ("xdb", "dbx", "xldb", "gdb", "idb", "xxgdb", "ddd", "kdbg", "ups", "workshop", "pgdbg", "pathdb", "lldb")
OWN_WINDOW = ("xxgdb", "ups", "ddd", "kdbg", "xldb", "workshop")
DEBUGGER_OPTIONS = ("start_in_debugger", "on_error_attach_debugger")


class PetscStartError(SystemExit):
    """PETSc cannot start with the user's options (module docstring): the one line is on stderr (rank 0) and the
    exit code is 2, as for any bad input, both for the command line and for a program that imports bridgefem (no
    part of bridgefem can run without PETSc)."""

    def __init__(self, message: str):
        super().__init__(2)
        self.message = message


_startup_options: dict[str, str] = {}


def start() -> None:
    """Start PETSc without rc files (module docstring), once; raise :class:`PetscStartError` for a bad option in the
    user's environment."""
    started = sys.modules.get("petsc4py.PETSc")
    if started is not None and started.Sys.isInitialized():
        _warn_started_elsewhere(started)
        _keep_options(started)
        return
    options = petsc_options_variable()
    for problem in (_missing_program(options), _unwritable_file(options)):
        if problem:
            _fail(problem)
    import petsc4py
    import petsc4py.lib

    # the build named by petsc4py's own petsc.cfg (or the user's PETSC_ARCH), never by a petsc.cfg in this folder
    lib = os.path.dirname(petsc4py.lib.__file__)
    arch = petsc4py.lib.getPathArch(lib, None, "PETSC_ARCH", os.path.join(lib, "petsc.cfg"))[1]
    PETSc = petsc4py.lib.ImportPETSc(arch)
    # a debugger PETSc starts inherits the standard error, which must stay the terminal's
    with _stderr_captured(capture=not any(key in DEBUGGER_OPTIONS for key, _ in options)) as captured:
        try:
            petsc4py.init(START_ARGS, arch=arch)
            failure = None
        except PETSc.Error as err:
            failure = err
    if failure is not None:
        reason = _petsc_message(captured.text) or f"PETSc error code {failure.ierr}"
        named = _named(options, reason)
        _fail(f"{named}: PETSc cannot start with it ({reason})" if named else f"PETSc cannot start ({reason})",
              end_mpi=True)
    sys.stderr.write(captured.text)  # whatever PETSc printed while starting (normally nothing)
    _keep_options(PETSc)
    for key, value in _startup_options.items():  # also the options of options files and of PETSC_OPTIONS_YAML
        problem = _unwritable_file([(key, value)])
        if problem:
            PETSc.Options().delValue(key)  # PETSc would otherwise fail again as it ends
            _fail(problem)


def startup_options() -> dict[str, str]:
    """PETSc's options as it started (the user's environment's, :data:`ENVIRONMENT`, and the options files they
    name), without the dash; a flag's value is ""."""
    return dict(_startup_options)


def _keep_options(PETSc) -> None:
    _startup_options.update({key: "" if value is None else str(value)
                             for key, value in PETSc.Options().getAll().items() if key != START_ARGS[0][1:]})



def petsc_options_variable() -> list[tuple[str, str]]:
    """The options in PETSC_OPTIONS as (key without the dash, value; "" for none), in order, split as PETSc splits
    them (white space; double quotes hold a value with spaces)."""
    tokens = [m.group(1) if m.group(1) is not None else m.group(2)
              for m in re.finditer(r'"([^"]*)"|(\S+)', os.environ.get("PETSC_OPTIONS", ""))]
    options: list[tuple[str, str]] = []
    for token in tokens:
        if _is_key(token):
            options.append((token.lstrip("-"), ""))
        elif options and not options[-1][1]:
            options[-1] = (options[-1][0], token)
    return options


def _is_key(token: str) -> bool:
    """A PETSc option name: a dash and not a negative number."""
    if not token.startswith("-") or token == "-":
        return False
    try:
        float(token)
    except ValueError:
        return True
    return False


def _show(key: str, value: str) -> str:
    return f"PETSC_OPTIONS: -{key}" + (f" {value}" if value else "")


def _named(options: list[tuple[str, str]], reason: str) -> str | None:
    """The option of PETSC_OPTIONS that PETSc's message is about (its value or name quoted in it), else the
    environment variables that hold options, else None."""
    for key, value in options:
        if (value and value in reason) or f"-{key}" in reason:
            return _show(key, value)
    given = [f"{name}={os.environ[name]!r}" for name in ENVIRONMENT if os.environ.get(name)]
    return " ".join(given) or None


def _missing_program(options: list[tuple[str, str]]) -> str | None:
    """Why a debugger option cannot work (a program PETSc would start is not installed), or None."""
    values = dict(options)
    terminal = values.get("debug_terminal", "xterm -e").split()
    for key in DEBUGGER_OPTIONS:
        if key not in values:
            continue
        for program in debugger_programs(values[key], terminal[0] if terminal else ""):
            if not shutil.which(program):
                return (f"{_show(key, values[key])}: PETSc would start {program!r}, which is not an installed "
                        "program (give an installed debugger, and 'noxterm' or an installed -debug_terminal)")
    return None


def debugger_programs(value: str, terminal: str) -> list[str]:
    """The programs PETSc 3.18 starts for ``-start_in_debugger VALUE`` (or ``-on_error_attach_debugger``): the
    terminal (``terminal``: the first word of ``-debug_terminal``), unless ``value`` says ``noxterm`` or the debugger
    opens its own window, and the debugger (:data:`DEBUGGERS`; ``value`` itself when it is an executable file that
    names one)."""
    debugger = "gdb"
    for name in DEBUGGERS:
        if name in value:
            debugger = value if os.path.isfile(value) and os.access(value, os.X_OK) else name
    in_terminal = "noxterm" not in value and "ddd" not in value and debugger not in OWN_WINDOW
    return ([terminal] if in_terminal and terminal else []) + [debugger]


def written_file(key: str, value: str) -> str | None:
    """The file PETSc writes for option ``-key value`` outside bridgefem's solvers and its own start-up check:
    ``-history FILE`` (as it starts), ``-malloc_view FILE`` and ``-log_view [ascii]:FILE[:format]`` (after the run);
    None for other options and for the standard streams."""
    if key in ("history", "malloc_view"):
        path = value
    elif key == "log_view" and ":" in value:
        kind, path = value.split(":")[:2]
        path = path if kind in ("", "ascii") else ""
    else:
        return None
    return path if path and path not in ("stdout", "stderr") else None


def _unwritable_file(options: list[tuple[str, str]]) -> str | None:
    """Why a file an option asks PETSc to write (:func:`written_file`) cannot be written, or None."""
    for key, value in options:
        path = written_file(key, value)
        if path is None:
            continue
        folder = os.path.dirname(os.path.abspath(path))
        if os.path.isdir(path):
            why = "which is a folder"
        elif not os.path.isdir(folder):
            why = f"and its folder {folder} does not exist"
        elif not os.access(folder, os.W_OK | os.X_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
            why = "which cannot be written"
        else:
            continue
        return f"{_show(key, value)}: PETSc would write {path}, {why} (give a file in a folder you can write)"
    return None


def _petsc_message(report: str) -> str | None:
    """The message of PETSc's error report (the line before its "See https://petsc.org/..." line), without the text
    of an options-file line it quotes (the file may hold anything, e.g. a password hash)."""
    lines = [line.split("PETSC ERROR: ", 1)[1].strip() for line in report.splitlines() if "PETSC ERROR: " in line]
    for before, line in zip(lines, lines[1:]):
        if line.startswith("See "):
            return re.sub(r"( line \d+): .*", r"\1", before)
    return None


def _fail(message: str, end_mpi: bool = False) -> None:
    """Print ``message`` as bridgefem's one line (rank 0) and exit with code 2; ``end_mpi``: PETSc failed to start
    after it started MPI, and nothing else will end MPI (mpirun then reports the exit code, not a crash)."""
    if launcher_rank() == 0:
        print(f"bridgefem: error: {' '.join(message.split())}", file=sys.stderr, flush=True)
    if end_mpi:
        from mpi4py import MPI

        if MPI.Is_initialized() and not MPI.Is_finalized():
            MPI.Finalize()
    raise PetscStartError(message)


def launcher_rank() -> int:
    """This process's MPI rank as mpirun tells it (no MPI start-up needed)."""
    for name in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"):
        if os.environ.get(name, "").isdigit():
            return int(os.environ[name])
    return 0


class _Captured:
    text = ""


@contextlib.contextmanager
def _stderr_captured(capture: bool = True) -> Iterator[_Captured]:
    """Within: what the process writes to its standard error (file descriptor 2, PETSc's C code included) is
    collected in memory instead, in ``.text`` on leaving (a memory file: no length limit, nothing on disk). With
    ``capture`` false the standard error is left alone (``.text`` empty)."""
    captured = _Captured()
    if not capture:
        yield captured
        return
    sys.stderr.flush()
    memory, saved = os.memfd_create("bridgefem-petsc-start"), os.dup(2)
    os.dup2(memory, 2)
    try:
        yield captured
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.lseek(memory, 0, os.SEEK_SET)
        chunks = []
        while chunk := os.read(memory, 65536):
            chunks.append(chunk)
        os.close(memory)
        captured.text = b"".join(chunks).decode(errors="replace")


def _warn_started_elsewhere(PETSc) -> None:
    """PETSc was started before bridgefem (a program imported petsc4py.PETSc or DOLFINx first): warn when it read rc
    files, which :func:`start` exists to prevent."""
    if PETSc.Options().hasName("skip_petscrc"):
        return
    found = [name for name in RC_FILES if os.path.isfile(os.path.expanduser(name))]
    if found:
        warnings.warn(f"PETSc was started before bridgefem was imported, and read the option files {found}; import "
                      "bridgefem before petsc4py.PETSc and DOLFINx so that PETSc starts without them", RuntimeWarning,
                      stacklevel=3)


def ignore_folder_jit_parameters() -> None:
    """Make DOLFINx's and FFCx's just-in-time compilers ignore the parameter files of the current folder.

    Both read ``dolfinx_jit_parameters.json`` / ``ffcx_parameters.json`` from the current folder at their first
    compilation, and a compiler flag there (``cffi_extra_compile_args = ["-B<dir>/"]``) makes the C compiler run
    programs of that folder. Their readers (``_load_parameters``, returning the user's and the folder's parameters)
    are replaced by ones that return the user's own file (``~/.config/dolfinx``, ``~/.config/ffcx``), read once from
    an empty temporary folder, and no folder's; a user's file that cannot be opened (a home folder this user may not
    read) counts as none, as a missing one does."""
    import tempfile

    import dolfinx.jit
    import ffcx.parameters

    here = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="bridgefem-jit-") as empty:
        os.chdir(empty)
        try:
            for module in (dolfinx.jit, ffcx.parameters):
                module._load_parameters = _users_parameters_only(module._load_parameters)
        finally:
            os.chdir(here)


def _users_parameters_only(load: Callable[[], tuple[dict, dict]]) -> Callable[[], tuple[dict, dict]]:
    """A reader of (user's, folder's) parameters that gives the user's as ``load`` reads them now (from an empty
    folder: no folder's file) and never a folder's."""
    try:
        user = load()[0]
    except OSError:
        user = {}
    return lambda: (user, {})
