"""The output policy (bridgefem/io/output.py, targets.py and lock.py; docs/output-policy.md): a user's files are
never touched.

bridgefem writes only into a new folder, an empty one or an earlier bridgefem results folder that it may remove
(a write-protected one is refused: as the running user, and for root by its mode bits), checked before the
analysis; replaces it atomically; removes its temporary folder on any error or SIGTERM (the next run removes one
left by SIGKILL, and one it cannot remove stops no run); refuses a second run on the same folder by a lock file
of its own; never writes, reuses or removes a user's file named like its own; a failed run keeps the earlier
results. Names and their lengths: tests/test_output_names.py.
"""
from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from conftest import ROOT, bridgefem, scene_dict, write_toml

from bridgefem.io import cli, output
from bridgefem.io.lock import LOCK_HEADER
from bridgefem.io.output import claim, results_folder
from bridgefem.io.targets import MARKER, OutputError, check_target, failed_target

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
    with claim(out):  # free again once the holder is gone (its lock file stays until this run takes it over)
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
    assert len(left) == 2 and left[0] == ".out.bridgefem-lock" and left[1].startswith(".out.bridgefem-tmp-")
    with results_folder(out) as tmp:
        (tmp / "results.json").write_text('{"next": true}')
    assert "removed" in capsys.readouterr().err
    assert strays(tmp_path) == [] and json.loads((out / "results.json").read_text()) == {"next": True}


def test_a_lock_left_by_a_killed_run_is_taken_over_and_removed(tmp_path):
    out = earlier_results(tmp_path / "out")
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(out)], stdout=subprocess.PIPE, text=True, env=ENV)
    assert holder.stdout.readline().strip() == "holding"
    holder.kill()
    holder.wait()
    lock = tmp_path / ".out.bridgefem-lock"
    assert lock.read_bytes().startswith(LOCK_HEADER)
    with results_folder(out) as tmp:
        (tmp / "results.json").write_text('{"next": true}')
    assert strays(tmp_path) == [] and json.loads((out / "results.json").read_text()) == {"next": True}


RACE = """
import os, sys, time
from pathlib import Path
from bridgefem.io.output import claim
from bridgefem.io.targets import OutputError
target = Path(sys.argv[1])
inside, taken, refused = target.parent / "inside", 0, 0
print("ready", flush=True)
until = float(sys.stdin.readline())
while time.time() < until:
    try:
        with claim(target):
            os.mkdir(inside)  # FileExistsError when another process holds the lock too
            taken += 1
            os.rmdir(inside)
    except OutputError as err:
        assert "another bridgefem run" in str(err), err
        refused += 1
print(taken, refused)
"""


@pytest.mark.slow
def test_concurrent_runs_on_one_folder_hold_its_lock_one_at_a_time(tmp_path):
    """Three processes take and release the lock of one target as fast as they can for half a second: never two
    at once (the lock file is created, taken over and removed under races), never another error, nothing left
    behind."""
    procs = [subprocess.Popen([sys.executable, "-c", RACE, str(tmp_path / "out")], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV) for _ in range(3)]
    assert [p.stdout.readline() for p in procs] == ["ready\n"] * 3
    until = f"{time.time() + 0.5}\n"
    for p in procs:
        p.stdin.write(until)
        p.stdin.flush()
    results = [p.communicate(timeout=60) for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], [err for _, err in results]
    taken, refused = (sum(int(out.split()[i]) for out, _ in results) for i in (0, 1))
    assert taken > 0 and refused > 0, (taken, refused)  # the lock changed hands under contention
    assert sorted(os.listdir(tmp_path)) == []


LOOKALIKES = {".out.lock": "a user's own lock", ".out.bridgefem-tmp-abcdefgh": "mine",
              ".out.bridgefem-old-abcdefgh": "mine", ".out.bridgefem-lock-abcdefgh": "mine",
              ".out.bridgefem-tmp-ijklmnop/notes.txt": "mine", ".out.bridgefem-old-qrstuvwx/notes.txt": "mine",
              ".out.bridgefem-tmp-mine/notes.txt": "mine"}


def test_a_users_files_named_like_bridgefems_own_are_never_touched(tmp_path):
    """Files and folders a user made with the names bridgefem gives its lock, temporary and moved-aside folders:
    none is written, reused or removed, by runs that succeed, fail or are interrupted."""
    for name, text in LOOKALIKES.items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    (tmp_path / ".out.bridgefem-tmp-stuvwxyz").mkdir()  # an empty folder is a user's too
    before = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in tmp_path.rglob("*")}
    contents = snapshot(tmp_path)
    out = earlier_results(tmp_path / "out")
    with pytest.raises(RuntimeError):
        with results_folder(out) as tmp:
            (tmp / "results.json").write_text("half")
            raise RuntimeError("disk full")
    with claim(out, also=(failed_target(out),)):
        with results_folder(out) as tmp:
            (tmp / "results.json").write_text('{"new": true}')
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in before} == before
    assert {k: v for k, v in snapshot(tmp_path).items() if not k.startswith("out")} == contents
    assert strays(tmp_path) == sorted({n.split("/")[0] for n in LOOKALIKES} | {".out.bridgefem-tmp-stuvwxyz"})


@pytest.mark.parametrize("kind", ["text", "empty", "symlink", "folder", "fifo"])
def test_a_file_at_the_locks_name_that_bridgefem_did_not_write_is_refused_untouched(tmp_path, capsys, never_analyse,
                                                                                      kind):
    out = earlier_results(tmp_path / "out")
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    lock = tmp_path / ".out.bridgefem-lock"
    (tmp_path / "mine.txt").write_text("mine")
    if kind == "text":
        lock.write_text("my notes")
    elif kind == "empty":
        lock.touch()
    elif kind == "symlink":
        lock.symlink_to(tmp_path / "mine.txt")
    elif kind == "folder":
        lock.mkdir()
        (lock / "notes.txt").write_text("mine")
    else:
        os.mkfifo(lock)
    before, st = snapshot(tmp_path), os.lstat(lock)
    err = run_refused(capsys, scene, "--out", out)
    assert f"{lock}: " in err and "not a lock bridgefem wrote" in err
    with pytest.raises(OutputError, match="not a lock bridgefem wrote"):
        with results_folder(out):
            pass
    after = os.lstat(lock)
    assert snapshot(tmp_path) == before and (after.st_ino, after.st_mtime_ns) == (st.st_ino, st.st_mtime_ns)


# ------------------------------------------------------------------ write-protected targets
def protect(*paths: Path) -> None:
    """chmod a-w: what a user marks "keep this"."""
    for p in paths:
        p.chmod(stat.S_IMODE(p.stat().st_mode) & ~0o222)


@pytest.fixture
def unprotect_afterwards(tmp_path):
    """Give the owner its write permission back after the test (so that the temporary folder can be removed)."""
    yield
    for p in [tmp_path, *tmp_path.rglob("*")]:
        if not p.is_symlink():
            p.chmod(stat.S_IMODE(p.stat().st_mode) | stat.S_IWUSR)


# what is write-protected -> which folder the message names, and the name it quotes inside it
PROTECTIONS = {
    "chmod -R a-w": (lambda p: [p / "out", *(p / "out").rglob("*")], "out", None),
    "the folder's owner bit (chmod u-w)": (lambda p: [], "out", None),
    "one file in it": (lambda p: [p / "out" / "results.json"], "out", "results.json"),
    "a folder in it": (lambda p: [p / "out" / "sub"], "out", "sub"),
    "the folder that holds it": (lambda p: [p], "", None),
    "the failed run's folder": (lambda p: [p / "out-failed"], "out-failed", None),
}
WHY = ("its owner has no write permission, which bridgefem honours even when run as root" if os.geteuid() == 0
       else "you have no write permission")


@pytest.mark.parametrize("what", PROTECTIONS)
def test_a_write_protected_target_is_refused_before_the_analysis(tmp_path, capsys, never_analyse,
                                                                 unprotect_afterwards, what):
    """Everything the replacement needs is checked, as the running user, and for root by the mode bits: a folder
    or file made read-only stays as it is, and no hidden folder is left (which would block every later run)."""
    parent = tmp_path / "p"
    out = parent / "out"
    with results_folder(out) as tmp:
        (tmp / "results.json").write_text('{"earlier": true}')
        (tmp / "sub").mkdir()
        (tmp / "sub" / "a.txt").write_text("1")
    earlier_results(parent / "out-failed")
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    paths, folder, inside = PROTECTIONS[what]
    protect(*paths(parent))
    if what.startswith("the folder's owner bit"):
        out.chmod(stat.S_IMODE(out.stat().st_mode) & ~stat.S_IWUSR)
    before = snapshot(tmp_path)
    err = run_refused(capsys, scene, "--out", out)
    named = parent / folder if folder else parent
    assert f"{named}: " in err and "write-protected" in err and WHY in err, err
    assert inside is None or f"holds {inside}, which is write-protected" in err, err
    assert snapshot(tmp_path) == before and strays(parent) == []


def test_an_immutable_file_in_the_target_is_refused(tmp_path, capsys, never_analyse):
    """A file the file system itself keeps (chattr +i) cannot be removed, by root either: refused before the
    analysis."""
    out = earlier_results(tmp_path / "out")
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(out / "results.json")],
                                                        capture_output=True).returncode != 0:
        pytest.skip("chattr +i is not available here (it needs root and a file system with the attribute); a "
                    "write-protected results.json is refused all the same in "
                    "test_a_write_protected_target_is_refused_before_the_analysis")
    try:
        err = run_refused(capsys, scene, "--out", out)
    finally:
        subprocess.run(["chattr", "-i", str(out / "results.json")], check=True)
    assert f"{out}: holds results.json, which is write-protected (it cannot be written" in err, err
    assert json.loads((out / "results.json").read_text()) == {"earlier": True} and strays(tmp_path) == []


def test_a_removal_that_fails_after_the_exchange_keeps_the_new_results_and_blocks_no_later_run(tmp_path, capsys,
                                                                                                 monkeypatch):
    """Should the earlier results resist removal all the same (a change during the run, a file system error), the
    new results stay in place, what is left is named on stderr, later runs are not stopped by it, and the first
    run that can remove it does."""
    out = earlier_results(tmp_path / "out")
    unlink = os.unlink

    def failing(path, *args, **kwargs):
        if ".out.bridgefem-tmp-" in str(path) and Path(path).name == "results.json":
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return unlink(path, *args, **kwargs)

    monkeypatch.setattr(os, "unlink", failing)
    for run in ("new", "newer"):
        with results_folder(out) as tmp:
            (tmp / "results.json").write_text(json.dumps({run: True}))
        assert json.loads((out / "results.json").read_text()) == {run: True}
    err = capsys.readouterr().err
    left = strays(tmp_path)  # each run's earlier results, the first one's tried twice
    assert len(left) == 2 and all(n.startswith(".out.bridgefem-tmp-") for n in left), left
    assert [err.count(f"could not remove {tmp_path / n}") for n in left] in ([2, 1], [1, 2]), err
    monkeypatch.setattr(os, "unlink", unlink)
    with results_folder(out) as tmp:
        (tmp / "results.json").write_text('{"last": true}')
    assert "removed" in capsys.readouterr().err
    assert strays(tmp_path) == [] and json.loads((out / "results.json").read_text()) == {"last": True}


def test_without_the_atomic_exchange_a_failed_second_rename_puts_the_earlier_results_back(tmp_path, monkeypatch):
    """Where renameat2's exchange is missing the target moves aside, to a new folder of bridgefem's own, and back
    when the new results cannot take its place."""
    out = earlier_results(tmp_path / "out")
    monkeypatch.setattr(output, "_exchange", lambda a, b: False)
    with results_folder(out) as tmp:
        (tmp / "results.json").write_text('{"new": true}')
    assert json.loads((out / "results.json").read_text()) == {"new": True} and strays(tmp_path) == []
    rename = os.rename

    def failing(src, dst, *args, **kwargs):
        if Path(src).name.startswith(".out.bridgefem-tmp-"):
            raise OSError(errno.EXDEV, "Invalid cross-device link", str(dst))
        return rename(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "rename", failing)
    with pytest.raises(OutputError, match="Invalid cross-device link"):
        with results_folder(out) as tmp:
            (tmp / "results.json").write_text('{"newer": true}')
    assert json.loads((out / "results.json").read_text()) == {"new": True} and strays(tmp_path) == []


# ------------------------------------------------------------------ as a user whom permission bits bind
NOBODY = 65534


def as_normal_user() -> list[str]:
    """The command prefix that runs a process as a user whom permission bits bind: nobody (setpriv) when the suite
    runs as root, else the suite's own user."""
    if os.geteuid() != 0:
        return []
    assert shutil.which("setpriv"), "the suite runs as root and setpriv (util-linux, on every Debian) is missing"
    return ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups"]


@pytest.fixture
def shared_dir():
    """A folder that user can write into (pytest's own temporary folders are private to the suite's user)."""
    folder = Path(tempfile.mkdtemp(prefix="bridgefem-test-"))
    folder.chmod(0o777)
    yield folder
    subprocess.run(["chmod", "-R", "u+w", str(folder)], check=True)
    shutil.rmtree(folder)


AS_USER = """
import json, os, sys
from pathlib import Path
from bridgefem.io.output import results_folder
from bridgefem.io.targets import OutputError
root, seen = Path(sys.argv[1]), {}
def attempt(name, target):
    try:
        with results_folder(target) as tmp:
            (tmp / "results.json").write_text(json.dumps({name: True}))
        seen[name] = "written"
    except OutputError as err:
        seen[name] = str(err)
attempt("own", root / "own")
for p in [root / "own", *(root / "own").iterdir()]:
    p.chmod(p.stat().st_mode & ~0o222)  # chmod -R a-w
attempt("protected", root / "own")
attempt("beside a leftover", root / "left")
attempt("again beside it", root / "left")
if (root / "sticky").exists():
    attempt("in a sticky folder", root / "sticky" / "theirs")
print(json.dumps(seen))
"""


def test_as_a_user_whom_permission_bits_bind(shared_dir):
    """Run as such a user (nobody when the suite runs as root): the user's own earlier results are replaced; made
    read-only, they are refused untouched; a temporary folder of bridgefem's that this user cannot remove stops no
    run; another user's results folder in a sticky folder (like /tmp) is refused, not half replaced."""
    left = shared_dir / ".left.bridgefem-tmp-abcdefgh"
    left.mkdir()
    (left / MARKER).write_text(json.dumps({"bridgefem": "0", "files": ["results.json"]}))
    (left / "results.json").write_text("{}")
    if os.geteuid() == 0:  # root's folders: nobody may change them
        (shared_dir / "sticky").mkdir(mode=0o777)
        (shared_dir / "sticky").chmod(0o1777)
        theirs = earlier_results(shared_dir / "sticky" / "theirs")
        for p in [theirs, *theirs.iterdir()]:
            p.chmod(0o777)
    else:
        protect(left)
    proc = subprocess.run([*as_normal_user(), sys.executable, "-c", AS_USER, str(shared_dir)], capture_output=True,
                          text=True, timeout=60, env={**ENV, "PYTHONDONTWRITEBYTECODE": "1"}, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    seen = json.loads(proc.stdout)
    assert seen["own"] == "written"
    assert seen["protected"].startswith(f"{shared_dir / 'own'}: is write-protected (you have no write permission)")
    assert json.loads((shared_dir / "own" / "results.json").read_text()) == {"own": True}
    assert seen["beside a leftover"] == seen["again beside it"] == "written"
    assert proc.stderr.count(f"could not remove {left}") == 2 and (left / "results.json").exists()
    if os.geteuid() == 0:
        assert "sticky folder" in seen["in a sticky folder"]
        assert json.loads((shared_dir / "sticky" / "theirs" / "results.json").read_text()) == {"earlier": True}
    assert sorted(n for n in os.listdir(shared_dir) if n.startswith(".")) == [left.name]


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


@pytest.mark.slow
def test_the_cli_writes_the_longest_name_and_refuses_bad_outs_before_the_analysis(tmp_path, unprotect_afterwards):
    """End to end: a run writes every file under an --out name at the file system's limit; made read-only, that
    folder is refused before the analysis (no progress line, one error line), as are a name one byte longer and a
    name holding a bidi override; nothing changes."""
    from test_output_names import LIMIT as limit

    from bridgefem.io.results import FILES

    scene = write_toml(tmp_path / "s.toml", scene_dict(**COARSE))
    out = tmp_path / ("n" * limit)
    proc = bridgefem("run", scene, "--out", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert sorted(os.listdir(out)) == sorted([MARKER, *FILES]) and strays(tmp_path) == []
    protect(out, *out.iterdir())
    before = snapshot(tmp_path)
    for target, text in [(out, f"{out}: is write-protected"), (tmp_path / ("n" * (limit + 1)), "at least 1 bytes"),
                         (tmp_path / "arch\u202egpj", "U+202E")]:
        proc = bridgefem("run", scene, "--out", target)
        assert proc.returncode == 2 and proc.stdout == "" and len(proc.stderr.splitlines()) == 1, proc.stderr
        assert text in proc.stderr and "\u202e" not in proc.stderr, proc.stderr
    assert snapshot(tmp_path) == before and strays(tmp_path) == []


@pytest.mark.slow
def test_the_cli_as_a_user_whom_permission_bits_bind_refuses_a_write_protected_folder(shared_dir):
    """End to end as nobody (when the suite runs as root) or the suite's user: that user's read-only results are
    refused before the analysis, one line naming the folder, exit 2, nothing changed."""
    scene = write_toml(shared_dir / "s.toml", scene_dict(**COARSE))
    out = earlier_results(shared_dir / "out")
    if os.geteuid() == 0:
        for p in [out, *out.iterdir()]:
            os.chown(p, NOBODY, NOBODY)
    protect(out, *out.iterdir())
    before = snapshot(shared_dir)
    proc = subprocess.run([*as_normal_user(), sys.executable, "-m", "bridgefem.io.cli", "run", str(scene), "--out",
                           str(out)], capture_output=True, text=True, timeout=120,
                          env={**ENV, "PYTHONDONTWRITEBYTECODE": "1"}, cwd=ROOT)
    assert proc.returncode == 2 and proc.stdout == "" and len(proc.stderr.splitlines()) == 1, proc.stderr
    assert proc.stderr.startswith(f"bridgefem: error: {out}: is write-protected (you have no write permission)")
    assert snapshot(shared_dir) == before and strays(shared_dir) == []
