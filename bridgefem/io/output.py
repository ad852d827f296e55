"""Where bridgefem writes, and how: the output policy (docs/output-policy.md).

1. A target folder is written only when it does not exist, is an empty folder, or is an earlier bridgefem results
   folder: it holds the marker file :data:`MARKER`, written by bridgefem, and nothing but the files that marker
   lists. Anything else (a file, a symbolic link, a mount point, a folder holding other files, the current folder
   or one above it) is refused with :class:`OutputError`, before the analysis (:func:`claim`) and again before the replacement.
2. One run at a time per target: a lock (``flock`` on ``.<name>.lock`` beside the target, removed when done),
   taken before the analysis and held to the end; a second run on the same target is refused.
3. The files go to a temporary folder ``.<name>.bridgefem-tmp-*`` beside the target, which replaces the target in
   one atomic exchange (``renameat2(RENAME_EXCHANGE)``) when complete; the earlier results are removed after it.
   On any exception, SIGTERM included (:func:`sigterm_raises`), the temporary folder is removed and the target is
   left as it was.
4. A temporary folder left by a killed run (SIGKILL) is removed by the next run on the same target, which says so.

Under MPI rank 0 alone does the file-system work (except the files the ranks write together into the temporary
folder) and broadcasts every decision, so that all ranks agree.
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import json
import os
import shutil
import signal
import sys
import tempfile
import threading
from importlib import metadata
from pathlib import Path
from typing import Iterator

MARKER = ".bridgefem-results"
"""The file bridgefem writes into every results folder: JSON with its version and the files it wrote."""
TMP_TAG = ".bridgefem-tmp-"  # temporary folder: .<name>.bridgefem-tmp-<random suffix> beside the target
OLD_TAG = ".bridgefem-old-"  # earlier results moved aside where the atomic exchange is not supported
_RENAME_EXCHANGE = 2  # renameat2 flag (linux/fs.h)
_AT_FDCWD = -100


def version() -> str:
    """The installed bridgefem version, or "source tree" when it runs from an uninstalled checkout."""
    try:
        return metadata.version("bridgefem")
    except metadata.PackageNotFoundError:
        return "source tree"


class OutputError(Exception):
    """A target bridgefem must not write into, or a run already writing it; the message says why (exit 2)."""


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


def _listing(folder: Path) -> set[str]:
    """Every file and folder below ``folder``, as relative paths."""
    out = set()
    for root, dirs, files in os.walk(folder):
        rel = Path(root).relative_to(folder)
        out.update(str(rel / name) for name in dirs + files)
    return out


def check_target(target: Path) -> None:
    """Raise OutputError unless bridgefem may replace ``target`` (policy point 1; rank-local)."""
    target = Path(os.path.abspath(target))
    cwd = Path.cwd()
    if not target.name:
        raise OutputError(f"{target}: refusing to write the file system's root")
    if target == cwd or target in cwd.parents:
        raise OutputError(f"{target}: refusing to write the current folder or a folder above it; "
                          "give a new folder, e.g. --out results/NAME")
    if target.is_symlink():
        raise OutputError(f"{target}: is a symbolic link; bridgefem writes only into a new folder, an empty "
                          "folder or an earlier bridgefem results folder")
    if not target.exists():
        return
    if os.path.ismount(target):
        raise OutputError(f"{target}: is a mount point, which cannot be replaced; give a folder inside it")
    if not target.is_dir():
        raise OutputError(f"{target}: exists and is not a folder; bridgefem writes only into a new folder, an "
                          "empty folder or an earlier bridgefem results folder (it never touches this file)")
    try:
        found = _listing(target)
    except OSError as err:
        raise OutputError(f"{target}: cannot read the folder ({err.strerror})") from None
    if not found:
        return
    written = _marker_files(target)
    if written is None:
        raise OutputError(f"{target}: holds files bridgefem did not write (e.g. {sorted(found)[0]!r}); bridgefem "
                          "writes only into a new folder, an empty folder or an earlier bridgefem results folder")
    foreign = sorted(found - written - {MARKER})
    if foreign:
        raise OutputError(f"{target}: holds {foreign[0]!r}, which bridgefem did not write; move it out or give "
                          "another folder (bridgefem replaces a results folder only when it holds nothing else)")


def _marker_files(folder: Path) -> set[str] | None:
    """The files bridgefem wrote into ``folder``, from its marker; None without a (valid) marker."""
    try:
        data = json.loads((folder / MARKER).read_text())
        files = data["files"]
        if data.get("bridgefem") and isinstance(files, list) and all(isinstance(f, str) for f in files):
            return set(files)
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return None


def _write_marker(folder: Path, files: list[str]) -> None:
    (folder / MARKER).write_text(json.dumps({"bridgefem": version(), "files": sorted(files)}, indent=1) + "\n")


class _Lock:
    """An exclusive ``flock`` on ``.<name>.lock`` beside a target, holding the owner's process id."""

    def __init__(self, target: Path):
        self.path = target.with_name(f".{target.name}.lock")
        self.fd: int | None = None

    def acquire(self) -> bool:
        """Take the lock without waiting: True when taken, False when another process holds it."""
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                return False
            try:
                st, mine = os.stat(self.path, follow_symlinks=False), os.fstat(fd)
                same = (st.st_dev, st.st_ino) == (mine.st_dev, mine.st_ino)
            except FileNotFoundError:
                same = False
            if same:  # not a file an earlier owner removed after we opened it
                os.ftruncate(fd, 0)
                os.write(fd, str(os.getpid()).encode())
                self.fd = fd
                return True
            os.close(fd)

    def held_by_this_process(self) -> bool:
        try:
            return self.path.read_text() == str(os.getpid())
        except OSError:
            return False

    def release(self) -> None:
        if self.fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path)
            os.close(self.fd)
            self.fd = None


def _take_lock(target: Path) -> _Lock | None:
    """The target's lock, taken (and the stale temporary folders cleaned up), or None when this process already
    holds it; OutputError when another process does."""
    lock = _Lock(target)
    try:
        taken = lock.acquire()
    except OSError as err:
        raise OutputError(f"{target}: cannot take the lock {lock.path.name} beside it ({err.strerror})") from None
    if not taken:
        if lock.held_by_this_process():
            return None
        raise OutputError(f"{target}: another bridgefem run is writing this folder (lock {lock.path}); "
                          "wait for it or give another --out")
    _clean_stale(target)
    return lock


def _clean_stale(target: Path) -> None:
    """Remove the temporary folders of interrupted runs on ``target`` (called under its lock); put earlier results
    moved aside back in place when the target is missing."""
    for entry in sorted(target.parent.glob(f".{target.name}{OLD_TAG}*")):
        if entry.is_dir() and not entry.is_symlink() and _marker_files(entry) is not None:
            if not os.path.lexists(target):
                os.rename(entry, target)
                print(f"bridgefem: restored {target} from {entry.name}, left by an interrupted run", file=sys.stderr)
            else:
                shutil.rmtree(entry)
                print(f"bridgefem: removed {entry}, left by an interrupted run", file=sys.stderr)
    for entry in sorted(target.parent.glob(f".{target.name}{TMP_TAG}*")):
        if entry.is_dir() and not entry.is_symlink() and (MARKER in os.listdir(entry) or not os.listdir(entry)):
            shutil.rmtree(entry)
            print(f"bridgefem: removed {entry}, left by an interrupted run", file=sys.stderr)


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


@contextlib.contextmanager
def claim(target: Path, comm=None, also: tuple[Path, ...] = ()) -> Iterator[None]:
    """Check ``target`` (and the folders in ``also``) against the policy and hold the target's lock within the
    block: around an analysis, so that a refused target costs nothing and no second run races this one
    (collective)."""
    comm = comm or _Serial()
    target = Path(os.path.abspath(target))
    lock = None

    def take():
        nonlocal lock
        for t in (target, *also):
            check_target(t)
        target.parent.mkdir(parents=True, exist_ok=True)
        lock = _take_lock(target)

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
    target = Path(os.path.abspath(target))
    lock = None

    def start() -> str:
        nonlocal lock
        check_target(target)
        target.parent.mkdir(parents=True, exist_ok=True)
        lock = _take_lock(target)
        try:
            tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}{TMP_TAG}", dir=target.parent))
            umask = os.umask(0o022)
            os.umask(umask)
            tmp.chmod(0o777 & ~umask)  # a results folder as any other new folder, not mkdtemp's owner-only
            _write_marker(tmp, [])
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
        if comm.rank == 0:
            shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        if lock is not None:
            lock.release()


def _commit(tmp: Path, target: Path) -> None:
    """Mark ``tmp`` as bridgefem's, check the target again and put ``tmp`` in its place (signals held back)."""
    _write_marker(tmp, [f for f in _listing(tmp) if f != MARKER])
    check_target(target)
    blocked = {signal.SIGTERM, signal.SIGINT}
    signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
    try:
        if not os.path.lexists(target):
            os.rename(tmp, target)
        elif _exchange(tmp, target):
            shutil.rmtree(tmp)  # the earlier results, now at tmp
        else:
            old = target.with_name(f".{target.name}{OLD_TAG}{os.getpid()}")
            os.rename(target, old)
            os.rename(tmp, target)
            shutil.rmtree(old)
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, blocked)


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


def failed_target(target: Path) -> Path:
    """Where a run that ends in a solver failure writes its results: ``<target>-failed`` beside the target,
    which keeps the earlier results."""
    target = Path(os.path.abspath(target))
    return target.with_name(target.name + "-failed")
