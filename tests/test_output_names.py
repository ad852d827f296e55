"""Names bridgefem prints and creates (bridgefem/io/targets.py ``check_names``, bridgefem/scene/names.py
``check_name``): refused before the analysis, with one line that shows the offending character escaped or names the
component that is too long, exit 2, nothing written.

The families are generated: every control character (C0, DEL, C1), every bidi control and both separators, in a
scene name, in the scene file's name that gives the default name, and in an --out component; name lengths at the
file system's limit, which the longest name a run creates (``.<out>-failed.bridgefem-lock-XXXXXXXX``, 32 bytes
more than ``<out>``) sets.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest
from conftest import scene_dict, trap_the_analysis, write_toml

from bridgefem.io import cli, output
from bridgefem.io.output import claim, results_folder
from bridgefem.io.targets import OutputError, failed_target
from bridgefem.scene.names import MAX_NAME, MAX_NAME_BYTES, unsafe_character

UNSAFE = [*range(0x00, 0x20), 0x7F, *range(0x80, 0xA0), 0x061C, 0x200E, 0x200F, *range(0x202A, 0x202F),
          *range(0x2066, 0x206A), 0x2028, 0x2029]
NAME_MAX = os.pathconf(tempfile.gettempdir(), "PC_NAME_MAX")
LONGEST = len(".-failed.bridgefem-lock-xxxxxxxx")  # the bytes a run's longest name adds to <out>
LIMIT = NAME_MAX - LONGEST  # the longest --out name a run accepts


class Reached(Exception):
    """The analysis was reached: everything before it was accepted."""


@pytest.fixture
def work(tmp_path, monkeypatch):
    """An empty working folder as the cwd, and the analysis replaced by a trap that raises :class:`Reached`."""
    return trap_the_analysis(monkeypatch, tmp_path, Reached)


def tree(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def refused(capsys, argv: list[str]) -> str:
    """cli.main on arguments that must be refused: exit 2 and one line on stderr, which is returned (without its
    newline)."""
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.endswith("\n") and err.startswith("bridgefem: error: "), err
    return err[:-1]


def toml_string(text: str) -> str:
    """A TOML basic string holding ``text`` exactly: every character but letters and digits as a \\u escape."""
    return '"' + "".join(c if c.isascii() and c.isalnum() else f"\\u{ord(c):04x}" for c in text) + '"'


def test_exactly_the_documented_characters_are_unsafe():
    """Controls, bidi controls and the separators are refused; every other character is not (accents, CJK, emoji,
    zero-width and other format characters included); lone surrogates (bytes that are not UTF-8) are."""
    for code in range(0x30000):
        found = unsafe_character(f"a{chr(code)}b")
        if 0xD800 <= code <= 0xDFFF:
            assert found is not None and "not UTF-8" in found, hex(code)
        elif code in UNSAFE:
            assert found is not None and found.startswith(f"U+{code:04X} ("), hex(code)
        else:
            assert found is None, hex(code)


@pytest.mark.parametrize("code", UNSAFE, ids=lambda c: f"U+{c:04X}")
def test_a_scene_name_with_a_control_or_bidi_character_is_refused(tmp_path, work, capsys, code):
    scene = tmp_path / "s.toml"
    scene.write_text(write_toml(tmp_path / "base.toml", scene_dict()).read_text()
                     + f"[scene]\nname = {toml_string(f'arch{chr(code)}gpj.exe')}\n")
    for command in ("run", "check"):
        err = refused(capsys, [command, str(scene)])
        assert "[scene] name" in err and f"U+{code:04X}" in err and chr(code) not in err, err
    assert tree(work) == []


@pytest.mark.parametrize("code", [c for c in UNSAFE if c != 0], ids=lambda c: f"U+{c:04X}")
def test_a_scene_file_name_with_a_control_or_bidi_character_is_refused(tmp_path, work, capsys, code):
    """Without a name key the file's name gives the scene name: the same characters are refused in it."""
    scene = write_toml(tmp_path / f"arch{chr(code)}gpj.toml", scene_dict())
    err = refused(capsys, ["run", str(scene)])
    assert "the file name gives the scene name" in err and f"U+{code:04X}" in err and chr(code) not in err, err
    assert tree(work) == []


@pytest.mark.parametrize("code", UNSAFE, ids=lambda c: f"U+{c:04X}")
def test_an_out_component_with_a_control_or_bidi_character_is_refused(tmp_path, work, capsys, code):
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    for out in (f"arch{chr(code)}gpj", f"results/arch{chr(code)}gpj/out", str(tmp_path / f"a{chr(code)}b" / "out")):
        err = refused(capsys, ["run", str(scene), "--out", out])
        assert f"U+{code:04X}" in err and chr(code) not in err, err
    assert tree(work) == [] and sorted(os.listdir(tmp_path)) == ["s.toml", "work"]


def test_names_that_are_not_utf8_are_refused(tmp_path, work, capsys):
    """A byte that is not UTF-8 reaches Python as a lone surrogate, which cannot be printed: refused by its value."""
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    err = refused(capsys, ["run", str(scene), "--out", os.fsdecode(b"arch\xffout")])
    assert "byte 0xFF (not UTF-8)" in err
    named = os.fsdecode(os.fsencode(str(tmp_path)) + b"/arch\x9b.toml")
    Path(named).write_text(scene.read_text())
    err = refused(capsys, ["run", named])
    assert "byte 0x9B (not UTF-8)" in err and "the file name gives the scene name" in err
    assert tree(work) == []


# ------------------------------------------------------------------ lengths
def name_of(size: int, char: str = "n") -> str:
    """A name of ``size`` bytes in UTF-8 (``char`` repeated, topped up with "n")."""
    width = len(char.encode())
    return char * (size // width) + "n" * (size % width)


SIZES = sorted({LIMIT - 1, LIMIT, LIMIT + 1, 231, 232, 249, 255, 256})


@pytest.mark.parametrize("char", ["n", "é", "の"])
@pytest.mark.parametrize("size", SIZES)
def test_an_out_name_is_accepted_up_to_the_limit_and_refused_beyond_it_before_the_analysis(tmp_path, work, capsys,
                                                                                         size, char):
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    out = tmp_path / name_of(size, char)
    if size <= LIMIT:
        with pytest.raises(Reached):
            cli.main(["run", str(scene), "--out", str(out)])
    else:
        err = refused(capsys, ["run", str(scene), "--out", str(out)])
        assert "too long for this file system" in err and f"at most {NAME_MAX} are allowed" in err, err
        assert f"at least {size - LIMIT} bytes shorter" in err, err
    assert sorted(os.listdir(tmp_path)) == ["s.toml", "work"]


def test_the_longest_accepted_name_is_written_with_every_name_a_run_makes(tmp_path):
    """At the limit every name is created for real: the lock, a temporary folder, the failed run's folder and its
    own, the two-rename replacement's moved-aside folder. One byte more would fail when written, after the
    analysis, without the check."""
    out = tmp_path / name_of(LIMIT)
    for run in range(2):
        with claim(out, also=(failed_target(out),), files=["results.json"]):
            for target in (out, failed_target(out)):
                with results_folder(target) as tmp:
                    (tmp / "results.json").write_text(str(run))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(output, "_exchange", lambda a, b: False)  # the two renames, through .<out>.bridgefem-old-*
        with results_folder(out) as tmp:
            (tmp / "results.json").write_text("2")
    assert (out / "results.json").read_text() == "2" and (failed_target(out) / "results.json").read_text() == "1"
    longer = tmp_path / name_of(LIMIT + 1)
    with pytest.raises(OutputError, match="too long"):
        with claim(longer, also=(failed_target(longer),)):
            pass
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(output, "check_names", lambda *args, **kwargs: None)
        with pytest.raises(OutputError, match="File name too long"):
            with results_folder(failed_target(longer)):
                pass
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([out.name, failed_target(out).name])


def test_a_folder_name_to_create_above_the_target_is_checked_too(tmp_path, work, capsys):
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    err = refused(capsys, ["run", str(scene), "--out", str(tmp_path / name_of(NAME_MAX + 1) / "out")])
    assert f"is {NAME_MAX + 1} bytes; this file system allows at most {NAME_MAX}" in err, err
    assert sorted(os.listdir(tmp_path)) == ["s.toml", "work"]


def test_a_path_beyond_the_file_systems_limit_is_refused(tmp_path, work, capsys):
    path_max = os.pathconf(tmp_path, "PC_PATH_MAX")
    deep = Path(tmp_path, *[name_of(200)] * (path_max // 200), "out")
    scene = write_toml(tmp_path / "s.toml", scene_dict())
    err = refused(capsys, ["run", str(scene), "--out", str(deep)])
    assert "too long a path" in err and f"paths of at most {path_max - 1} bytes" in err, err
    assert sorted(os.listdir(tmp_path)) == ["s.toml", "work"]


@pytest.mark.parametrize("name,ok", [("é" * (MAX_NAME_BYTES // 2), True),
                                     ("é" * (MAX_NAME_BYTES // 2 - 1) + "の", False)], ids=["MAX_NAME_BYTES", "one more"])
def test_a_scene_names_bytes_are_checked_by_check_and_run_alike(tmp_path, work, capsys, name, ok):
    """The longest scene name check accepts is one a run can write under its default folder, results/<name>."""
    scene = write_toml(tmp_path / "s.toml", scene_dict(scene={"name": name}))
    assert len(name) <= MAX_NAME and (len(name.encode()) <= MAX_NAME_BYTES) == ok
    if ok:
        assert cli.main(["check", str(scene)]) == 0
        with pytest.raises(Reached):
            cli.main(["run", str(scene)])
        assert tree(work) == ["results"]  # the folder that holds the target, created with its lock
    else:
        for command in ("check", "run"):
            assert "[scene] name" in refused(capsys, [command, str(scene)])
        assert tree(work) == []
