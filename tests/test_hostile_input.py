"""Hostile input: every malformed scene or scene file exits 2 with exactly one line on stderr naming the key or
the file and what is allowed, writes nothing, and shows no traceback.

The cases are generated: each key of a valid scene (every section present) given a value of the wrong type, out
of its range, nan or inf, or an unknown key beside it; plus the cases found by hand (PETSc viewers in the scene,
huge or dangerous names, physical values that overflow, a model far beyond the machine) and bad kinds of file.
They run in-process through ``bridgefem.io.cli.main``: validation comes before any heavy import, and a case that
reached the analysis would fail (it is replaced by a trap). A few run as real subprocesses.
"""
from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

import pytest
from conftest import bridgefem, scene_dict, trap_the_analysis, write_toml

from bridgefem.io import cli
from bridgefem.scene.reader import scene_from_dict, scene_scales
from bridgefem.scene.schema import SCHEMA


def valid_scene() -> dict:
    """The reference arch with every section present: an elastic fill, elastic abutments with a movement."""
    return scene_dict(
        scene={"name": "hostile", "gravity": 9.81},
        fill={"unit_weight": 18000.0, "young": 1e8, "depth": 0.5, "extension": 2.0, "material": "elastic"},
        abutments={"model": "elastic", "height": 2.0, "movement_springing": "right", "movement_horizontal": 1e-4},
        vehicle={"axles": [50e3, 50e3], "spacing": [1.0], "contact_length": 0.2, "dispersion": "boussinesq"},
        mesh={"elements_through_thickness": 2}, model={"plane": "strain"},
        solver={"tolerance": 0.001, "petsc": {"mat_mumps_icntl_14": 100}})


def valid_bridge() -> dict:
    """Two spans of the reference arch on a pier (no fill or vehicle: a bridge of several spans is analysed bare)."""
    d = scene_dict(mesh={"elements_through_thickness": 2})
    d["span"] = [d.pop("arch"), dict(scene_dict()["arch"])]
    d["pier"] = [{"width": 2.0, "height": 3.0, "batter": 0.05, "blocks": 2}]
    return d


def bad_values(key) -> list:
    """Values the key must refuse: wrong types, out of range, nan and inf."""
    if key.kind is dict:
        return ["text", 3]
    if key.kind is list:  # lists of numbers: their entries are checked with the section ([vehicle])
        return ["text", 3, [float("nan")], [-1.0]]
    out = [[1, 2], {"a": 1}]
    if key.kind is str:
        return out + [42, "nonsense" if key.choices else None][:1 + bool(key.choices)]
    if key.kind is bool:
        return out + ["yes", 1]
    out += ["text", True]
    if key.kind is int:
        out.append(2.5)
    else:
        out += [float("nan"), float("inf"), -float("inf")]
    if key.choices:
        out.append(max(key.choices) + 1)
    scale = scale_of(key)
    if key.low is not None and key.zero:  # 0 is allowed: between it and the range
        out.append(key.low * scale / 2)
    elif key.low is not None:
        out.append(key.low - 1 if key.kind is int else key.low * scale - max(1.0, abs(key.low * scale)))
    if key.high is not None:
        out.append(key.high * scale * 10 + 1)
    return [v for v in out if v is not None]


def scale_of(key) -> float:
    """What the key's range is a multiple of in the valid scene (1 for an absolute range)."""
    return scene_scales(scene_from_dict(valid_scene()))[key.per] if key.per else 1.0


def generated_cases() -> list[tuple[str, dict, str]]:
    """(id, scene dict, text the message must hold) for every key of every section."""
    cases = []
    arrays = {"load": "[[load]] #1", "pier": "[[pier]] #1"}
    for section, keys in SCHEMA.items():
        label = arrays.get(section, f"[{section}]")
        valid = valid_bridge if section == "pier" else valid_scene

        def table(d: dict) -> dict:
            return d[section][0] if section in arrays else d.setdefault(section, {})

        for k, key in keys.items():
            if (section, k) == ("scene", "name"):
                continue  # names: the hand-made cases
            for i, v in enumerate(bad_values(key)):
                d = valid()
                table(d)[k] = v
                cases.append((f"{section}.{k}-{i}", d, f"{label} {k}"))
        d = valid()
        table(d)["colour"] = "red"
        cases.append((f"{section}.unknown-key", d, f"{label}: unknown key 'colour'"))
        if section not in arrays:
            d = valid_scene()
            d[section]["nested"] = {"deeper": {"x": 1}}
            cases.append((f"{section}.nested-table", d, f"{label}: unknown key 'nested'"))
    return cases


def hand_cases() -> list[tuple[str, dict, str]]:
    def with_(text, **sections):
        d = valid_scene()
        for name, values in sections.items():
            if isinstance(values, dict) and isinstance(d.get(name), dict):
                d[name].update(values)
            else:
                d[name] = values
        return text, d

    petsc = {
        "ksp_view": ":/tmp/h13-hostile-view.txt", "ksp_view_mat": "binary:/tmp/x.bin", "ksp_monitor": ":/tmp/x",
        "ksp_view_draw": "draw", "options_file": "/etc/passwd", "log_view": "", "viewer_socket_port": 5000,
        "mat_mumps_icntl_1": 6, "mat_mumps_icntl_4": 3, "mat_mumps_icntl_22": 1, "-ksp_type": "preonly",
        "bridgefem_ksp_type": "preonly", "history": "/tmp/x", "pc_factor_mat_solver_type": "nonsense",
        "ksp_type": "nonsense", "pc_type": "draw", "mat_mumps_icntl_14": [1, 2], "mat_mumps_icntl_7": float("nan"),
        "mat_mumps_icntl_6": "2", "mat_mumps_icntl_8": 1.5, "mat_mumps_icntl_13": True,
        "mat_mumps_cntl_1": float("inf"), "mat_mumps_cntl_1 ": 0.1, "ksp_rtol": -1.0, "ksp_max_it": 0,
        "nested": {"ksp_type": "preonly"}, "": 1, "ksp_type\n": "preonly",
        "mat_mumps_icntl_23": 10**7,  # MB of work space: a scene must not ask for the machine's memory
    }
    cases = [with_(f"[solver.petsc] {k if re.fullmatch(r'[a-z0-9_]+', k) else repr(k)}", solver={"petsc": {k: v}})
             for k, v in petsc.items()]
    names = [".", "..", "/", "../../x", "/tmp/abs", "a/b/c", "a\\b", "x\x00y", "line\nbreak", "\x1b[31m", "",
             "   ", " lead", ".hidden", "a" * 101, "a" * 100_000, "arch\u202egpj.exe", "\x9b31m", "a\u2066b",
             "の" * 67]  # 67 characters, 201 bytes
    cases += [with_("[scene] name", scene={"name": n}) for n in names]
    cases += [
        with_("[scene] gravity", scene={"gravity": 1e308}),
        with_("[solver] initial_step", solver={"initial_step": float("inf")}),
        with_("[solver] max_load", solver={"max_load": 1e300}),
        with_("[masonry] density", masonry={"density": 1e300}),
        with_("[masonry] density", masonry={"density": 3.7e-17}),
        with_("[arch] span", arch={"span": 1e300}),
        with_("[fill] cohesion", fill={"cohesion": 5000.0}),  # Mohr-Coulomb keys on an elastic fill
        with_("[fill] friction_angle", fill={"friction_angle": 30.0}),
        with_("[fill] tension_cutoff", fill={"tension_cutoff": 0.0}),
        with_("[abutments] height", abutments={"model": "rigid", "height": 1.0, "movement_springing": "right"}),
        with_("[arch] voussoirs = 4096", arch={"voussoirs": 4096}, mesh={"elements_through_thickness": 64}),
        with_("[arch] thickness", arch={"thickness": 20.0}),
        with_("[arch] rise", arch={"rise": 3.0}),
        with_("[[load]] #1", load=[{"kind": "patch", "position": 0.99, "length": 1.0}]),
        with_("[[load]]: 101 tables", load=[{"kind": "point", "position": 0.5}] * 101),
        with_("[[load]]", load={"kind": "point", "position": 0.5}),
        with_("[[load]] #1: expected a table", load=[1]),
        with_("[arch]: expected a table", arch=[1, 2]),
        with_("[bridge]: unknown section", bridge={"x": 1}),
        with_("[abutments] movement_springing", abutments={"movement_springing": "nowhere"}),
        with_("unknown section", top_level_key=1.0),
    ]
    return [(f"hand-{i}", d, text) for i, (text, d) in enumerate(cases)]


CASES = generated_cases() + hand_cases()


def test_the_valid_scene_reaches_the_analysis(tmp_path, monkeypatch, capsys):
    """The base of the mutations is valid: only the mutation is refused (cli.main reaches the trap)."""
    scene_from_dict(valid_scene())
    scene = write_toml(tmp_path / "s.toml", valid_scene())
    import bridgefem.analysis.runner

    class Reached(Exception):
        pass

    def trap(*args, **kwargs):
        raise Reached()

    monkeypatch.setattr(bridgefem.analysis.runner, "run_analysis", trap)
    with pytest.raises(Reached):
        cli.main(["run", str(scene), "--out", str(tmp_path / "out")])


@pytest.fixture(scope="module")
def cases_root(tmp_path_factory):
    return tmp_path_factory.mktemp("cases")


@pytest.fixture
def case_dir(cases_root):
    """A new empty folder per case (pytest's tmp_path scans every earlier folder of the same test name, which
    grows quadratically over hundreds of cases)."""
    return Path(tempfile.mkdtemp(dir=cases_root))


@pytest.fixture
def trapped(case_dir, monkeypatch):
    """An empty working folder as the cwd, and the analysis replaced by a trap."""
    return trap_the_analysis(monkeypatch, case_dir)


def assert_refused(capsys, argv: list[str], must_name: str, work: Path) -> str:
    code = cli.main(argv)
    captured = capsys.readouterr()
    err = captured.err
    assert code == 2, (code, err)
    assert len(err.splitlines()) == 1 and err.startswith("bridgefem: error: "), err
    assert "Traceback" not in err and must_name in err, err
    assert os.listdir(work) == [], os.listdir(work)
    return err


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_a_malformed_scene_exits_2_with_one_line_and_writes_nothing(case_dir, capsys, trapped, case):
    _, d, must_name = case
    scene = write_toml(case_dir / "scene.toml", d)
    before = sorted(os.listdir(case_dir))
    err = assert_refused(capsys, ["run", str(scene)], must_name, trapped)
    assert "allowed" in err or "expected" in err or "only for" in err, err
    assert len(err) < 1000, len(err)
    assert sorted(os.listdir(case_dir)) == before


def bad_files(tmp: Path) -> list[tuple[str, Path, str]]:
    """(id, path, text the message must hold): files that are no scene."""
    valid = tmp / "valid.toml"
    write_toml(valid, valid_scene())
    (tmp / "binary.toml").write_bytes(bytes(range(256)) * 16)
    (tmp / "utf16.toml").write_bytes(valid.read_text().encode("utf-16"))
    (tmp / "big.toml").write_bytes(b"# " + b"x" * 2_000_000 + b"\n" + valid.read_bytes())
    (tmp / "longname.toml").write_text(valid.read_text().replace('"hostile"', '"' + "n" * 900_000 + '"'))
    (tmp / "nested.toml").write_text("x = " + "[" * 100_000 + "]" * 100_000 + "\n")
    (tmp / "nul.toml").write_bytes(valid.read_bytes().replace(b'"hostile"', b'"ho\x00stile"'))
    (tmp / "empty.toml").write_text("")
    (tmp / "folder.toml").mkdir()
    os.mkfifo(tmp / "fifo.toml")
    (tmp / "loop.toml").symlink_to(tmp / "loop.toml")
    (tmp / "..toml").write_text(valid.read_text().replace('name = "hostile"\n', ""))  # its name would be "."
    return [("binary", tmp / "binary.toml", "not UTF-8"), ("utf-16", tmp / "utf16.toml", "not UTF-8"),
            ("2 MB", tmp / "big.toml", "larger than"), ("900k-character name", tmp / "longname.toml", "[scene] name"),
            ("nested arrays", tmp / "nested.toml", "TOML"), ("NUL in the name", tmp / "nul.toml", "not valid TOML"),
            ("empty", tmp / "empty.toml", "[arch]: missing section"), ("folder", tmp / "folder.toml", "is a folder"),
            ("FIFO", tmp / "fifo.toml", "not a regular file"), ("/dev/zero", Path("/dev/zero"), "not a regular file"),
            ("missing", tmp / "missing.toml", "no such scene file"), ("symlink loop", tmp / "loop.toml", "cannot open"),
            ("file named ..toml", tmp / "..toml", "the file name gives the scene name"),
            ("NUL in the path", Path(str(tmp / "a\x00b.toml")), "NUL")]


FILE_IDS = [
    "binary", "utf-16", "2 MB", "900k-character name", "nested arrays", "NUL in the name", "empty", "folder", "FIFO",
    "/dev/zero", "missing", "symlink loop", "file named ..toml", "NUL in the path"]


@pytest.mark.parametrize("index", range(len(FILE_IDS)), ids=FILE_IDS)
def test_a_file_that_is_no_scene_exits_2_with_one_line(tmp_path, capsys, trapped, index):
    name, path, must_name = bad_files(tmp_path)[index]
    for command in ("run", "check", "lp"):
        assert_refused(capsys, [command, str(path)], must_name, trapped)


def test_an_unreadable_scene_exits_2(tmp_path, capsys, trapped, monkeypatch):
    """A file without read permission. Root reads every file whatever its mode, so the open is made to fail the way
    the kernel fails it for other users (EACCES); without root the mode alone does it."""
    scene = write_toml(tmp_path / "s.toml", valid_scene())
    scene.chmod(0)
    if os.geteuid() == 0:
        real_open = os.open

        def denied(path, *args, **kwargs):
            if os.fspath(path) == str(scene):
                raise PermissionError(13, "Permission denied", str(path))
            return real_open(path, *args, **kwargs)

        monkeypatch.setattr(os, "open", denied)
    assert_refused(capsys, ["run", str(scene)], "permission denied", trapped)


def test_bad_command_line_petsc_options_exit_2(tmp_path, capsys, trapped):
    scene = write_toml(tmp_path / "s.toml", valid_scene())
    for args, text in [(["--petsc", "ksp_type"], "expected KEY=VALUE"), (["-other_ksp_type", "x"], "-bridgefem_")]:
        assert_refused(capsys, ["run", str(scene), *args], text, trapped)


# ------------------------------------------------------------------ a few as real processes
@pytest.mark.parametrize("kind", ["fifo", "dev-zero", "utf-16", pytest.param("petsc-nonsense", marks=pytest.mark.slow),
                                  pytest.param("petsc-mumps-list", marks=pytest.mark.slow)])
def test_subprocess_cases_exit_2_with_one_line(tmp_path, kind):
    """A FIFO must not block (the timeout fails the test); PETSc's own rejection of a command-line value is
    one line too."""
    scene = write_toml(tmp_path / "s.toml", scene_dict(mesh={"elements_through_thickness": 1}))
    args = {"fifo": [tmp_path / "fifo.toml"], "dev-zero": ["/dev/zero"],
            "utf-16": [tmp_path / "u.toml"],
            "petsc-nonsense": [scene, "--petsc", "ksp_type=nonsense"],
            "petsc-mumps-list": [scene, "-bridgefem_mat_mumps_icntl_14", "1,2"]}[kind]
    if kind == "fifo":
        os.mkfifo(tmp_path / "fifo.toml")
    (tmp_path / "u.toml").write_bytes(scene.read_text().encode("utf-16"))
    out = tmp_path / "out"
    proc = bridgefem("run", *args, "--out", out, timeout=60)
    assert proc.returncode == 2 and len(proc.stderr.splitlines()) == 1, proc.stderr
    assert "Traceback" not in proc.stderr and not out.exists()
    if kind.startswith("petsc"):
        assert "rejected by PETSc" in proc.stderr


def test_the_suite_is_large_enough():
    assert len(CASES) + len(FILE_IDS) >= 120
