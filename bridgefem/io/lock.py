"""One run at a time per target, and what interrupted runs left beside it: point 3 and 5 of the output policy
(docs/output-policy.md, :mod:`bridgefem.io.output`).

A run takes an exclusive ``flock`` on bridgefem's own lock file ``.<name>.bridgefem-lock`` beside the target
(:class:`Lock`, :func:`take_lock`) before the analysis and holds it to the end; a second run on the same target
is refused, and a file of that name that bridgefem did not write is refused, never opened for writing. Under the
lock, what a killed run left (earlier results moved aside, temporary folders, half-written lock files) is put back
or removed (:func:`_clean_stale`); only bridgefem's own names, holding its marker or lock header, are touched, and
what cannot be removed is reported and left (:func:`remove_or_report`): it never blocks a run.
"""
from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shutil
import stat
import sys
import tempfile
from pathlib import Path

from .targets import LOCK_TAG, MARKER, OLD_TAG, TMP_TAG, OutputError, beside, marker_files

LOCK_HEADER = b"bridgefem lock\n"
"""The first line of every lock file: how a run tells a lock left by a killed run from a user's file."""
_LOCK_TEXT = LOCK_HEADER + b"A bridgefem run writes the folder beside this file and removes this file when it ends.\n"
_SUFFIX = re.compile(r"[a-z0-9_]{8}")  # tempfile's random suffix: what makes a name bridgefem's own


# ------------------------------------------------------------------ the lock
_HELD: dict[Path, "Lock"] = {}  # the locks this process holds: claim() around results_folder() on one target


class Lock:
    """An exclusive ``flock`` on bridgefem's own lock file ``.<name>.bridgefem-lock`` beside a target.

    The file appears only complete: it is written and locked under a new random name (created with O_EXCL, so never
    a user's file) and then hard-linked to the lock's name, which fails when that name exists. An existing file of
    that name is therefore either a run's lock, starting with :data:`LOCK_HEADER` (locked by a live run; or free,
    left by a killed run, and then taken over), or not bridgefem's: refused, never written. After the ``flock`` is
    taken the name is checked to be still this file (a run that ended may have removed it meanwhile), and it is
    removed at the end only while it still is."""

    def __init__(self, target: Path):
        self.target = target
        self.path = target.with_name(beside(target, LOCK_TAG))
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
        fd, stage = tempfile.mkstemp(prefix=beside(self.target, LOCK_TAG + "-"), dir=self.target.parent)
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


def take_lock(target: Path) -> Lock | None:
    """The target's lock, taken (and what interrupted runs left cleaned up), or None when this process already
    holds it; OutputError when another process does."""
    lock = Lock(target)
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
    prefix = beside(target, tag)
    return [target.parent / n for n in sorted(os.listdir(target.parent))
            if n.startswith(prefix) and _SUFFIX.fullmatch(n[len(prefix):])]


def _own_folder(path: Path) -> bool:
    """A folder bridgefem wrote: a real folder (no link) holding a valid marker."""
    return path.is_dir() and not path.is_symlink() and marker_files(path) is not None


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


def remove_or_report(folder: Path, what: str) -> bool:
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
        if remove_or_report(entry, left):
            _note(f"removed {entry}, {left}")
    for entry in _own_entries(target, TMP_TAG):
        if _own_folder(entry) and remove_or_report(entry, left):
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
