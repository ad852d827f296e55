"""Where bridgefem writes, and how: the output policy (docs/output-policy.md). Points 1 and 2 are checked in
:mod:`bridgefem.io.targets`, the lock of 3 and the clean-up of 5 are :mod:`bridgefem.io.lock`; this module claims a
target (:func:`claim`) and replaces it atomically (:func:`results_folder`, point 4).

1. A target folder is written only when it does not exist, is an empty folder, or is an earlier bridgefem results
   folder: it holds the marker file :data:`MARKER`, written by bridgefem, and nothing but the files that marker
   lists. Anything else (a file, a symbolic link, a mount point, a folder holding other files, the current folder
   or one above it) is refused with :class:`OutputError`, before the analysis (:func:`claim`) and again before the
   replacement; so is a target whose replacement would need a write permission that is missing
   (:func:`bridgefem.io.targets.check_target`: the folder that holds it, the target, every folder and file in it).
2. Names are checked before anything is created (:func:`check_names`): no component of the given path may hold a
   control or bidi character or bytes that are not UTF-8 (:func:`bridgefem.scene.names.unsafe_character`), and every
   name bridgefem creates (its hidden names add up to 25 bytes to the target's, a failed run's folder 7 more) must
   fit the file system's ``NAME_MAX``, every path its ``PATH_MAX``.
3. One run at a time per target: a lock (``flock`` on bridgefem's own file ``.<name>.bridgefem-lock`` beside the
   target, :class:`Lock`), taken before the analysis and held to the end; a second run on the same target is
   refused. A file of that name that bridgefem did not write is refused, never opened for writing.
4. The files go to a temporary folder ``.<name>.bridgefem-tmp-*`` beside the target, which replaces the target in
   one atomic exchange (``renameat2(RENAME_EXCHANGE)``) when complete; the earlier results are removed after it,
   their marker last. On any exception, SIGTERM included (:func:`sigterm_raises`), the temporary folder is removed
   and the target is left as it was.
5. What a killed run (SIGKILL) left is removed by the next run on the same target, which says so; only what
   bridgefem recognises as its own (its names with their random suffix, its marker or lock header) is touched, and
   what cannot be removed is reported and left: it never blocks a run.

Under MPI rank 0 alone does the file-system work (except the files the ranks write together into the temporary
folder) and broadcasts every decision, so that all ranks agree.
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import signal
import tempfile
import threading
from pathlib import Path
from typing import Iterable, Iterator

from .lock import Lock, remove_or_report, take_lock
from .targets import MARKER, OLD_TAG, TMP_TAG, OutputError, beside, check_names, check_target, listing, write_marker

_RENAME_EXCHANGE = 2  # renameat2 flag (linux/fs.h)
_AT_FDCWD = -100


class Terminated(BaseException):
    """SIGTERM arrived: raised where the program is, so that the clean-up code runs."""


@contextlib.contextmanager
def sigterm_raises() -> Iterator[None]:
    """Within: SIGTERM raises :class:`Terminated` instead of ending the process at once (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


# ------------------------------------------------------------------ claiming and replacing
class _Serial:
    """The one-process stand-in for an MPI communicator."""

    rank = 0

    @staticmethod
    def bcast(obj, root=0):
        return obj

    @staticmethod
    def barrier():
        pass


def _on_rank0(comm, work):
    """Run ``work()`` on rank 0 and broadcast its result, or its OutputError/OSError as a message raised as
    OutputError on every rank."""
    result, message = None, None
    if comm.rank == 0:
        try:
            result = work()
        except OutputError as err:
            message = str(err)
        except OSError as err:
            message = f"{err.filename}: {err.strerror}" if err.filename else str(err)
    result, message = comm.bcast((result, message), root=0)
    if message is not None:
        raise OutputError(message)
    return result


def _prepare(target: Path, also: tuple[Path, ...] = (), files: Iterable[str] = ()) -> Lock | None:
    """Check ``target`` and the folders in ``also`` (names, then the policy), create the folders above the target
    and take its lock (rank 0)."""
    check_names(target, files, also)
    for t in (target, *also):
        check_target(t)
    target = Path(os.path.abspath(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    return take_lock(target)


@contextlib.contextmanager
def claim(target: Path, comm=None, also: tuple[Path, ...] = (), files: Iterable[str] = ()) -> Iterator[None]:
    """Check ``target`` (and the folders in ``also``, with the names of the ``files`` to be written into them)
    against the policy and hold the target's lock within the block: around an analysis, so that a refused target
    costs nothing and no second run races this one (collective)."""
    comm = comm or _Serial()
    lock = None

    def take():
        nonlocal lock
        lock = _prepare(target, also, files)

    _on_rank0(comm, take)
    try:
        yield
    finally:
        if lock is not None:
            lock.release()


@contextlib.contextmanager
def results_folder(target: Path, comm=None) -> Iterator[Path]:
    """A temporary folder to write results into: on leaving the block it replaces ``target`` atomically; on any
    exception (SIGTERM included) it is removed and ``target`` is left as it was (collective; the ranks may write
    into it together).

    ``with results_folder(Path("results/arch"), comm) as tmp: (tmp / "results.json").write_text(...)``
    """
    comm = comm or _Serial()
    given = target
    target = Path(os.path.abspath(target))
    lock = None

    def start() -> str:
        nonlocal lock
        lock = _prepare(given)
        try:
            tmp = Path(tempfile.mkdtemp(prefix=beside(target, TMP_TAG), dir=target.parent))
            umask = os.umask(0o022)
            os.umask(umask)
            tmp.chmod(0o777 & ~umask)  # a results folder as any other new folder, not mkdtemp's owner-only
            write_marker(tmp, [])
        except BaseException:
            if lock is not None:
                lock.release()
            raise
        return str(tmp)

    tmp = Path(_on_rank0(comm, start))
    try:
        with sigterm_raises():
            yield tmp
            comm.barrier()
            _on_rank0(comm, lambda: _commit(tmp, target))
    except BaseException:
        if comm.rank == 0 and os.path.lexists(tmp):
            remove_or_report(tmp, "the temporary folder of this run")
        raise
    finally:
        if lock is not None:
            lock.release()


def _commit(tmp: Path, target: Path) -> None:
    """Mark ``tmp`` as bridgefem's, check the target again and put ``tmp`` in its place (signals held back); then
    remove the earlier results. Their removal was checked possible (:func:`check_target`); should it fail all the
    same, the new results stay in place, and what is left of the earlier ones is reported and removed by a later
    run (:func:`remove_or_report`)."""
    write_marker(tmp, [f for f in listing(tmp) if f != MARKER])
    check_target(target)
    blocked = {signal.SIGTERM, signal.SIGINT}
    signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
    try:
        if not os.path.lexists(target):
            os.rename(tmp, target)
            return
        old = tmp if _exchange(tmp, target) else _move_aside(tmp, target)
        remove_or_report(old, f"the earlier results of {target}, replaced by the new ones")
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, blocked)


def _move_aside(tmp: Path, target: Path) -> Path:
    """Replace ``target`` by ``tmp`` in two renames where the atomic exchange is not supported: the target moves to
    a new folder of bridgefem's own name (never a user's) and moves back if the second rename fails. Returns where
    the earlier results went."""
    old = Path(tempfile.mkdtemp(prefix=beside(target, OLD_TAG), dir=target.parent))
    try:
        os.rename(target, old)  # replaces the new empty folder
    except BaseException:
        os.rmdir(old)
        raise
    try:
        os.rename(tmp, target)
    except BaseException:
        os.rename(old, target)
        raise
    return old


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux renameat2); False where the system or file system cannot."""
    libc = ctypes.CDLL(None, use_errno=True)
    renameat2 = getattr(libc, "renameat2", None)
    if renameat2 is None:
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))
