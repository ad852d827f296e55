"""The commands that write besides `run` follow the output policy: `converge --out` writes only into a new or an
earlier bridgefem results folder, `bounds --plot` never overwrites a file; a refusal is one line, exit 2, before any
computation, and the user's files are untouched."""
from __future__ import annotations

from conftest import ROOT

from bridgefem.io import cli

DEMO = ROOT / "demos" / "bare_arch.toml"


def test_converge_refuses_a_folder_holding_the_users_files(tmp_path, capsys):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "notes.txt").write_text("my notes")
    assert cli.main(["converge", str(DEMO), "--levels", "1,2,4", "--out", str(folder)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "notes.txt" in err[0]
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt"]
    assert (folder / "notes.txt").read_text() == "my notes"


def test_bounds_plot_never_overwrites_a_file(tmp_path, capsys):
    png = tmp_path / "drawing.png"
    png.write_bytes(b"mine")
    scene = ROOT / "demos" / "prestwood.toml"
    assert cli.main(["bounds", str(scene), "--plot", str(png)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "drawing.png" in err[0] and "exists" in err[0]
    assert png.read_bytes() == b"mine" and sorted(p.name for p in tmp_path.iterdir()) == ["drawing.png"]
