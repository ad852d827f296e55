"""Which targets bridgefem may write, and the names it creates: points 1 and 2 of the output policy
(docs/output-policy.md, :mod:`bridgefem.io.output`).

1. A target folder is written only when it does not exist, is an empty folder, or is an earlier bridgefem results
   folder: it holds the marker file :data:`MARKER`, written by bridgefem, and nothing but the files that marker
   lists (:func:`check_target`). Anything else is refused with :class:`OutputError`; so is a target whose
   replacement would need a write permission that is missing (:func:`_write_protected`).
2. Every name bridgefem would create is checked before anything is created (:func:`check_names`): printable, and
   within the file system's ``NAME_MAX`` and ``PATH_MAX``, the hidden names beside the target (:func:`beside`:
   the temporary folder, the lock, earlier results moved aside) included.
"""
from __future__ import annotations

import contextlib
import json
import os
import stat
from importlib import metadata
from pathlib import Path
from typing import Iterable

from ..scene.names import unsafe_character

MARKER = ".bridgefem-results"
"""The file bridgefem writes into every results folder: JSON with its version and the files it wrote."""
TMP_TAG = ".bridgefem-tmp-"  # temporary folder: .<name>.bridgefem-tmp-<random suffix> beside the target
OLD_TAG = ".bridgefem-old-"  # earlier results moved aside where the atomic exchange is not supported
LOCK_TAG = ".bridgefem-lock"  # the lock: .<name>.bridgefem-lock; written as .<name>.bridgefem-lock-<random suffix>
_FAILED = "-failed"


def version() -> str:
    """The installed bridgefem version, or "source tree" when it runs from an uninstalled checkout."""
    try:
        return metadata.version("bridgefem")
    except metadata.PackageNotFoundError:
        return "source tree"


class OutputError(Exception):
    """A target bridgefem must not write into, or a run already writing it; the message says why (exit 2)."""


# ------------------------------------------------------------------ names
def shown_name(text: str, limit: int = 80) -> str:
    """A name for a one-line message: as given when printable and short, else its repr, cut in the middle."""
    if len(text) <= limit and text.isprintable():
        return text
    r = repr(text)
    return r if len(r) <= limit else f"{r[:limit // 2]}...{r[-limit // 4:]}"


def beside(target: Path, tag: str) -> str:
    """The start of bridgefem's own names beside ``target``: ``.<name><tag>``."""
    return f".{target.name}{tag}"


def _created_beside(target: Path) -> list[str]:
    """Every name bridgefem may create in the target's folder: the target and its own hidden names, their random
    suffix included."""
    random = "x" * 8
    return [target.name, beside(target, LOCK_TAG), *(beside(target, tag) + random
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
    :func:`~bridgefem.scene.names.unsafe_character`; the folders to create and the names of :func:`_created_beside` fit
    the file system's NAME_MAX; the deepest path (a file of ``files`` or the marker in a temporary folder) fits its
    PATH_MAX. The hidden names are longer than the target's, so without this check a long name fails only when the
    results are written, after the analysis."""
    files = tuple(files)
    for part in Path(target).parts:
        bad = unsafe_character(part)
        if bad is not None:
            raise OutputError(f"{shown_name(os.fspath(target))}: the folder name {shown_name(part)} holds {bad}; "
                              "allowed are names of printable characters (UTF-8, no control or bidi characters)")
    paths = [Path(os.path.abspath(p)) for p in (target, *also)]
    shown = shown_name(str(paths[0]))
    base = _existing_ancestor(paths[0].parent)
    name_max, path_max = _limit(base, "PC_NAME_MAX", 255), _limit(base, "PC_PATH_MAX", 4096)
    for path in paths:
        for part in path.relative_to(_existing_ancestor(path.parent)).parts[:-1]:  # the folders to create above it
            if len(os.fsencode(part)) > name_max:
                raise OutputError(f"{shown}: the folder name {shown_name(part)} is {len(os.fsencode(part))} bytes; "
                                  f"this file system allows at most {name_max} bytes in a name")
    where, longest = max(((p, n) for p in paths for n in _created_beside(p)), key=lambda c: len(os.fsencode(c[1])))
    size = len(os.fsencode(longest))
    if size > name_max:
        raise OutputError(f"{shown}: the name {shown_name(paths[0].name)} is too long for this file system: bridgefem "
                          f"creates {shown_name(longest)} beside it, {size} bytes, and at most {name_max} are allowed "
                          f"in a name; give a name at least {size - name_max} bytes shorter")
    deepest = where.parent / longest / max((MARKER, *files), key=lambda n: len(os.fsencode(n)))
    if len(os.fsencode(deepest)) >= path_max:  # PATH_MAX counts the terminating NUL
        raise OutputError(f"{shown}: too long a path: bridgefem writes {shown_name(str(deepest))}, "
                          f"{len(os.fsencode(deepest))} bytes, and this file system allows paths of at most "
                          f"{path_max - 1} bytes; give a shorter --out")


# ------------------------------------------------------------------ which targets may be replaced
def listing(folder: Path) -> set[str]:
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
        raise OutputError(f"{base}: is write-protected ({why}); bridgefem creates {shown_name(target.name)}, its "
                          "temporary folder and its lock in it: make it writable or give another --out")
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
                raise OutputError(f"{target}: holds {shown_name(os.path.relpath(path, target))}, which is "
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
        found = listing(target) if target.exists() else set()
        if found:
            written = marker_files(target)
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


def marker_files(folder: Path) -> set[str] | None:
    """The files bridgefem wrote into ``folder``, from its marker; None without a (valid) marker."""
    try:
        data = json.loads((folder / MARKER).read_text())
        files = data["files"]
        if data.get("bridgefem") and isinstance(files, list) and all(isinstance(f, str) for f in files):
            return set(files)
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return None


def write_marker(folder: Path, files: list[str]) -> None:
    (folder / MARKER).write_text(json.dumps({"bridgefem": version(), "files": sorted(files)}, indent=1) + "\n")


def failed_target(target: Path) -> Path:
    """Where a run that ends in a solver failure writes its results: ``<target>-failed`` beside the target,
    which keeps the earlier results."""
    target = Path(os.path.abspath(target))
    return target.with_name(target.name + _FAILED)
