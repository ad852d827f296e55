"""Where bridgefem writes, and how: the output policy (docs/output-policy.md).

1. A target folder is written only when it does not exist, is an empty folder, or is an earlier bridgefem results
   folder: it holds the marker file :data:`MARKER`, written by bridgefem, and nothing but the files that marker
   lists. Anything else (a file, a symbolic link, a mount point, a folder holding other files, the current folder
   or one above it) is refused with :class:`OutputError`, before the analysis (:func:`claim`) and again before the
   replacement; so is a target whose replacement would need a write permission that is missing
   (:func:`_write_protected`: the folder that holds it, the target, every folder and file in it).
2. Names are checked before anything is created (:func:`check_names`): no component of the given path may hold a
   control or bidi character or bytes that are not UTF-8 (:func:`bridgefem.scene.schema.unsafe_character`), and every
   name bridgefem creates (its hidden names add up to 25 bytes to the target's, a failed run's folder 7 more) must
   fit the file system's ``NAME_MAX``, every path its ``PATH_MAX``.
3. One run at a time per target: a lock (``flock`` on bridgefem's own file ``.<name>.bridgefem-lock`` beside the
   target, :class:`_Lock`), taken before the analysis and held to the end; a second run on the same target is
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
import fcntl
import json
import os
import re
import shutil
import signal
import stat
import sys
import tempfile
import threading
from importlib import metadata
from pathlib import Path
from typing import Iterable, Iterator

from ..scene.schema import unsafe_character

MARKER = ".bridgefem-results"
"""The file bridgefem writes into every results folder: JSON with its version and the files it wrote."""
TMP_TAG = ".bridgefem-tmp-"  # temporary folder: .<name>.bridgefem-tmp-<random suffix> beside the target
OLD_TAG = ".bridgefem-old-"  # earlier results moved aside where the atomic exchange is not supported
LOCK_TAG = ".bridgefem-lock"  # the lock: .<name>.bridgefem-lock; written as .<name>.bridgefem-lock-<random suffix>
LOCK_HEADER = b"bridgefem lock\n"
"""The first line of every lock file: how a run tells a lock left by a killed run from a user's file."""
_LOCK_TEXT = LOCK_HEADER + b"A bridgefem run writes the folder beside this file and removes this file when it ends.\n"
_SUFFIX = re.compile(r"[a-z0-9_]{8}")  # tempfile's random suffix: what makes a name bridgefem's own
_FAILED = "-failed"
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


# ------------------------------------------------------------------ names
def _shown(text: str, limit: int = 80) -> str:
    """A name for a one-line message: as given when printable and short, else its repr, cut in the middle."""
    if len(text) <= limit and text.isprintable():
        return text
    r = repr(text)
    return r if len(r) <= limit else f"{r[:limit // 2]}...{r[-limit // 4:]}"


def _beside(target: Path, tag: str) -> str:
    """The start of bridgefem's own names beside ``target``: ``.<name><tag>``."""
    return f".{target.name}{tag}"


def _created_beside(target: Path) -> list[str]:
    """Every name bridgefem may create in the target's folder: the target and its own hidden names, their random
    suffix included."""
    random = "x" * 8
    return [target.name, _beside(target, LOCK_TAG), *(_beside(target, tag) + random
                                                       for tag in (TMP_TAG, OLD_TAG, LOCK_TAG + "-"))]


def _existing_ancestor(path: Path) -> Path:
    while not os.path.lexists(path) and path != path.parent:
        path = path.parent
    return path


def _limit(path: Path, name: str, default: int) -> int:
    try:
        value = os.pathconf(path, name)
    except (OSError, ValueError):
        return default
    return value if value > 0 else default


def check_names(target: Path, files: Iterable[str] = (), also: Iterable[Path] = ()) -> None:
    """Raise OutputError, before anything is created, unless every name bridgefem would create for ``target`` (and
    the folders in ``also``) can be shown and created: no component of ``target`` as given holds an
    :func:`~bridgefem.scene.schema.unsafe_character`; the folders to create and the names of :func:`_created_beside` fit
    the file system's NAME_MAX; the deepest path (a file of ``files`` or the marker in a temporary folder) fits its
    PATH_MAX. The hidden names are longer than the target's, so without this check a long name fails only when the
    results are written, after the analysis."""
    files = tuple(files)
    for part in Path(target).parts:
        bad = unsafe_character(part)
        if bad is not None:
            raise OutputError(f"{_shown(os.fspath(target))}: the folder name {_shown(part)} holds {bad}; allowed "
                              "are names of printable characters (UTF-8, no control or bidi characters)")
    paths = [Path(os.path.abspath(p)) for p in (target, *also)]
    shown = _shown(str(paths[0]))
    base = _existing_ancestor(paths[0].parent)
    name_max, path_max = _limit(base, "PC_NAME_MAX", 255), _limit(base, "PC_PATH_MAX", 4096)
    for path in paths:
        for part in path.relative_to(_existing_ancestor(path.parent)).parts[:-1]:  # the folders to create above it
            if len(os.fsencode(part)) > name_max:
                raise OutputError(f"{shown}: the folder name {_shown(part)} is {len(os.fsencode(part))} bytes; this "
                                  f"file system allows at most {name_max} bytes in a name")
    where, longest = max(((p, n) for p in paths for n in _created_beside(p)), key=lambda c: len(os.fsencode(c[1])))
    size = len(os.fsencode(longest))
    if size > name_max:
        raise OutputError(f"{shown}: the name {_shown(paths[0].name)} is too long for this file system: bridgefem "
                          f"creates {_shown(longest)} beside it, {size} bytes, and at most {name_max} are allowed in "
                          f"a name; give a name at least {size - name_max} bytes shorter")
    deepest = where.parent / longest / max((MARKER, *files), key=lambda n: len(os.fsencode(n)))
    if len(os.fsencode(deepest)) >= path_max:  # PATH_MAX counts the terminating NUL
        raise OutputError(f"{shown}: too long a path: bridgefem writes {_shown(str(deepest))}, "
                          f"{len(os.fsencode(deepest))} bytes, and this file system allows paths of at most "
                          f"{path_max - 1} bytes; give a shorter --out")


# ------------------------------------------------------------------ which targets may be replaced
def _listing(folder: Path) -> set[str]:
    """Every file and folder below ``folder``, as relative paths (OSError when a folder cannot be read)."""
    out = set()
    for root, dirs, files in os.walk(folder, onerror=_raise):
        rel = Path(root).relative_to(folder)
        out.update(str(rel / name) for name in dirs + files)
    return out


def _raise(err: OSError) -> None:
    raise err


_ACCESS = {"effective_ids": os.access in os.supports_effective_ids}


def _write_protected(path: str | Path, st: os.stat_result) -> str | None:
    """Why bridgefem may not change ``path`` (a folder's entries, or a file it would remove), or None. Write-protected
    means: the running user has no write permission (for a folder also no search permission), it is on a read-only
    file system, or, when running as root, whom permission bits do not bind, its owner has no write permission: a
    folder or file made read-only (``chmod -R a-w``, ``chmod u-w``) says "keep this", and bridgefem honours it for
    every user."""
    folder = stat.S_ISDIR(st.st_mode)
    if not os.access(path, os.W_OK | (os.X_OK if folder else 0), **_ACCESS):
        with contextlib.suppress(OSError):
            if os.statvfs(path).f_flag & os.ST_RDONLY:
                return "on a read-only file system"
        return "you have no write permission" if os.geteuid() else "it cannot be written, e.g. immutable (chattr +i)"
    if os.geteuid() == 0 and not st.st_mode & stat.S_IWUSR:
        return "its owner has no write permission, which bridgefem honours even when run as root"
    return None


def _check_writable(target: Path) -> None:
    """Raise OutputError unless the replacement of ``target`` can be done in full: the folder that holds it (or the
    nearest one that exists, to create it in) takes new names; an existing target, every folder and every file in
    it can be removed (:func:`_write_protected`; a sticky folder, like /tmp, lets only the owner of an entry
    remove it). So the replacement never stops halfway, after the new results are in place."""
    base = _existing_ancestor(target.parent)
    why = _write_protected(base, os.stat(base)) if base.is_dir() else None  # a file: creating in it fails anyway
    if why:
        raise OutputError(f"{base}: is write-protected ({why}); bridgefem creates {_shown(target.name)}, its temporary "
                          "folder and its lock in it: make it writable or give another --out")
    if not target.is_dir():
        return
    st, above = os.lstat(target), os.stat(target.parent)
    if above.st_mode & stat.S_ISVTX and os.geteuid() not in (0, st.st_uid, above.st_uid):
        raise OutputError(f"{target}: belongs to another user in a sticky folder (like /tmp), where only its owner may "
                          "replace it; give another --out")
    why = _write_protected(target, st)
    if why:
        raise OutputError(f"{target}: is write-protected ({why}); bridgefem replaces earlier results by removing "
                          f"them: make it writable (chmod -R u+w {target}) or give another --out")
    for root, dirs, files in os.walk(target, onerror=_raise):
        for name in dirs + files:
            path = os.path.join(root, name)
            st = os.lstat(path)
            why = None if stat.S_ISLNK(st.st_mode) else _write_protected(path, st)
            if why:
                raise OutputError(f"{target}: holds {_shown(os.path.relpath(path, target))}, which is "
                                  f"write-protected ({why}); bridgefem replaces earlier results by removing them: "
                                  f"make them writable (chmod -R u+w {target}) or give another --out")


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
    if os.path.ismount(target):
        raise OutputError(f"{target}: is a mount point, which cannot be replaced; give a folder inside it")
    if target.exists() and not target.is_dir():
        raise OutputError(f"{target}: exists and is not a folder; bridgefem writes only into a new folder, an "
                          "empty folder or an earlier bridgefem results folder (it never touches this file)")
    try:
        found = _listing(target) if target.exists() else set()
        if found:
            written = _marker_files(target)
            if written is None:
                raise OutputError(f"{target}: holds files bridgefem did not write (e.g. {sorted(found)[0]!r}); "
                                  "bridgefem writes only into a new folder, an empty folder or an earlier bridgefem "
                                  "results folder")
            foreign = sorted(found - written - {MARKER})
            if foreign:
                raise OutputError(f"{target}: holds {foreign[0]!r}, which bridgefem did not write; move it out or "
                                  "give another folder (bridgefem replaces a results folder only when it holds "
                                  "nothing else)")
        _check_writable(target)
    except OSError as err:
        raise OutputError(f"{target}: cannot read {err.filename} ({err.strerror})") from None


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


# ------------------------------------------------------------------ the lock
_HELD: dict[Path, "_Lock"] = {}  # the locks this process holds: claim() around results_folder() on one target


class _Lock:
    """An exclusive ``flock`` on bridgefem's own lock file ``.<name>.bridgefem-lock`` beside a target.

    The file appears only complete: it is written and locked under a new random name (created with O_EXCL, so never
    a user's file) and then hard-linked to the lock's name, which fails when that name exists. An existing file of
    that name is therefore either a run's lock, starting with :data:`LOCK_HEADER` (locked by a live run; or free,
    left by a killed run, and then taken over), or not bridgefem's: refused, never written. After the ``flock`` is
    taken the name is checked to be still this file (a run that ended may have removed it meanwhile), and it is
    removed at the end only while it still is."""

    def __init__(self, target: Path):
        self.target = target
        self.path = target.with_name(_beside(target, LOCK_TAG))
        self.fd: int | None = None

    def acquire(self) -> bool:
        """Take the lock without waiting: True when taken, False when another process holds it."""
        while True:
            fd = self._open_existing()
            if fd is None:
                if self._create():
                    return True
                continue  # another run created it meanwhile
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                return False
            if self._names(fd):
                self.fd = fd
                return True
            os.close(fd)

    def _not_mine(self, what: str) -> OutputError:
        return OutputError(f"{self.path}: {what}, not a lock bridgefem wrote; bridgefem never touches it: move it "
                           "away or give another --out")

    def _open_existing(self) -> int | None:
        """The existing lock file opened for reading, None when there is none; OutputError when the name holds
        anything but a bridgefem lock."""
        try:
            st = os.lstat(self.path)
        except FileNotFoundError:
            return None
        if not stat.S_ISREG(st.st_mode):
            raise self._not_mine("exists and is not a regular file")
        try:
            fd = os.open(self.path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
        except FileNotFoundError:
            return None
        try:
            ours = stat.S_ISREG(os.fstat(fd).st_mode) and os.read(fd, len(LOCK_HEADER)) == LOCK_HEADER
        except BaseException:
            os.close(fd)
            raise
        if not ours:
            os.close(fd)
            raise self._not_mine("exists")
        return fd

    def _create(self) -> bool:
        """Write a new lock file, locked, and link it to the lock's name: False when that name exists by then."""
        fd, stage = tempfile.mkstemp(prefix=_beside(self.target, LOCK_TAG + "-"), dir=self.target.parent)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX)  # at most a moment: another run's _clean_stale testing it
                os.write(fd, _LOCK_TEXT)
                os.fchmod(fd, 0o644)  # other users' runs on a shared folder can read and test it
                os.link(stage, self.path)
            finally:
                os.unlink(stage)  # while locked: no run takes it for a killed run's
        except BaseException as err:
            os.close(fd)
            if isinstance(err, FileExistsError):
                return False
            raise
        self.fd = fd
        return True

    def _names(self, fd: int) -> bool:
        """Whether the lock's name still refers to the file open as ``fd``."""
        try:
            st, mine = os.stat(self.path, follow_symlinks=False), os.fstat(fd)
        except FileNotFoundError:
            return False
        return (st.st_dev, st.st_ino) == (mine.st_dev, mine.st_ino)

    def release(self) -> None:
        if self.fd is None:
            return
        try:
            if self._names(self.fd):
                with contextlib.suppress(OSError):
                    os.unlink(self.path)
        finally:
            os.close(self.fd)
            self.fd = None
            _HELD.pop(self.path, None)


def _take_lock(target: Path) -> _Lock | None:
    """The target's lock, taken (and what interrupted runs left cleaned up), or None when this process already
    holds it; OutputError when another process does."""
    lock = _Lock(target)
    if lock.path in _HELD:
        return None
    try:
        taken = lock.acquire()
    except OSError as err:
        raise OutputError(f"{target}: cannot take the lock {lock.path.name} beside it ({err.strerror})") from None
    if not taken:
        raise OutputError(f"{target}: another bridgefem run is writing this folder (lock {lock.path}); "
                          "wait for it or give another --out")
    _HELD[lock.path] = lock
    try:
        _clean_stale(target)
    except BaseException:
        lock.release()
        raise
    return lock


# ------------------------------------------------------------------ what interrupted runs left
def _own_entries(target: Path, tag: str) -> list[Path]:
    """bridgefem's own names beside ``target`` with ``tag``: ``.<name><tag>`` and a random suffix, exactly."""
    prefix = _beside(target, tag)
    return [target.parent / n for n in sorted(os.listdir(target.parent))
            if n.startswith(prefix) and _SUFFIX.fullmatch(n[len(prefix):])]


def _own_folder(path: Path) -> bool:
    """A folder bridgefem wrote: a real folder (no link) holding a valid marker."""
    return path.is_dir() and not path.is_symlink() and _marker_files(path) is not None


def _remove_own(folder: Path) -> None:
    """Remove a folder bridgefem wrote, its marker last: a removal stopped halfway leaves a folder the next run
    still recognises as bridgefem's (and removes)."""
    for entry in os.scandir(folder):
        if entry.name != MARKER:
            shutil.rmtree(entry.path) if entry.is_dir(follow_symlinks=False) else os.unlink(entry.path)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(folder / MARKER)
    os.rmdir(folder)


def _note(line: str) -> None:
    print(f"bridgefem: {line}", file=sys.stderr, flush=True)


def _remove_or_report(folder: Path, what: str) -> bool:
    """Remove one of bridgefem's own folders: True when done; one it cannot remove is reported, not raised, for it
    must never stop a run (its name is random, so no later run needs it gone)."""
    try:
        _remove_own(folder)
    except OSError as err:
        _note(f"warning: could not remove {folder}, {what} ({err.filename}: {err.strerror}); bridgefem tries again "
              "on the next run on this folder, or remove it yourself")
        return False
    return True


def _clean_stale(target: Path) -> None:
    """Deal with what interrupted runs on ``target`` left beside it (called under its lock): earlier results moved
    aside are put back when the target is missing, else removed; temporary folders are removed, and lock files
    still under their random name (a run killed while it wrote its lock). Only bridgefem's own names
    (:func:`_own_entries`) holding its marker or lock header are touched."""
    left = "left by an interrupted run"
    for entry in _own_entries(target, OLD_TAG):
        if not _own_folder(entry):
            continue
        if not os.path.lexists(target):
            try:
                os.rename(entry, target)
                _note(f"restored {target} from {entry.name}, {left}")
                continue
            except OSError:
                pass
        if _remove_or_report(entry, left):
            _note(f"removed {entry}, {left}")
    for entry in _own_entries(target, TMP_TAG):
        if _own_folder(entry) and _remove_or_report(entry, left):
            _note(f"removed {entry}, {left}")
    for entry in _own_entries(target, LOCK_TAG + "-"):  # a run killed while it wrote its lock file
        with contextlib.suppress(OSError):
            fd = os.open(entry, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # held: a live run's, being written
                if stat.S_ISREG(os.fstat(fd).st_mode) and os.read(fd, len(LOCK_HEADER)) == LOCK_HEADER:
                    os.unlink(entry)
            finally:
                os.close(fd)


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


def _prepare(target: Path, also: tuple[Path, ...] = (), files: Iterable[str] = ()) -> _Lock | None:
    """Check ``target`` and the folders in ``also`` (names, then the policy), create the folders above the target
    and take its lock (rank 0)."""
    check_names(target, files, also)
    for t in (target, *also):
        check_target(t)
    target = Path(os.path.abspath(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    return _take_lock(target)


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
            tmp = Path(tempfile.mkdtemp(prefix=_beside(target, TMP_TAG), dir=target.parent))
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
        if comm.rank == 0 and os.path.lexists(tmp):
            _remove_or_report(tmp, "the temporary folder of this run")
        raise
    finally:
        if lock is not None:
            lock.release()


def _commit(tmp: Path, target: Path) -> None:
    """Mark ``tmp`` as bridgefem's, check the target again and put ``tmp`` in its place (signals held back); then
    remove the earlier results. Their removal was checked possible (:func:`check_target`); should it fail all the
    same, the new results stay in place, and what is left of the earlier ones is reported and removed by a later
    run (:func:`_remove_or_report`)."""
    _write_marker(tmp, [f for f in _listing(tmp) if f != MARKER])
    check_target(target)
    blocked = {signal.SIGTERM, signal.SIGINT}
    signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
    try:
        if not os.path.lexists(target):
            os.rename(tmp, target)
            return
        old = tmp if _exchange(tmp, target) else _move_aside(tmp, target)
        _remove_or_report(old, f"the earlier results of {target}, replaced by the new ones")
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, blocked)


def _move_aside(tmp: Path, target: Path) -> Path:
    """Replace ``target`` by ``tmp`` in two renames where the atomic exchange is not supported: the target moves to
    a new folder of bridgefem's own name (never a user's) and moves back if the second rename fails. Returns where
    the earlier results went."""
    old = Path(tempfile.mkdtemp(prefix=_beside(target, OLD_TAG), dir=target.parent))
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


def failed_target(target: Path) -> Path:
    """Where a run that ends in a solver failure writes its results: ``<target>-failed`` beside the target,
    which keeps the earlier results."""
    target = Path(os.path.abspath(target))
    return target.with_name(target.name + _FAILED)
