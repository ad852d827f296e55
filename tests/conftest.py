"""Shared helpers: reference scenes as dictionaries, and running the command line (serial or mpirun -n 2)."""
from __future__ import annotations

import copy
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from bridgefem.petsc_start import start as _start_petsc


def pytest_configure(config):
    """Start PETSc without rc files (:func:`bridgefem.petsc_start.start`) in every process that runs tests, before a
    test module imports DOLFINx. Not in pytest-xdist's controller, which runs none: the MPI library PETSc starts
    there would set its singleton environment (OMPI_*, PMIX_*), the workers would inherit it, and an ``mpirun``
    started from a worker would take itself for part of that job and fail (exit 1, nothing printed)."""
    if getattr(config.option, "numprocesses", None) and not hasattr(config, "workerinput"):
        return
    _start_petsc()

ROOT = Path(__file__).resolve().parents[1]

REFERENCE_ARCH = {
    "arch": {"shape": "semicircular", "span": 9.0, "rise": 4.5, "thickness": 1.0, "width": 1.0, "voussoirs": 16},
    "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0},
    "joints": {"friction": 0.6},
    "load": [{"kind": "point", "position": 0.22222}],
}


def scene_dict(**sections) -> dict:
    """The issue's reference arch (centreline radius 5 m, t = 1 m) with sections updated key by key."""
    d = copy.deepcopy(REFERENCE_ARCH)
    for name, values in sections.items():
        if isinstance(values, dict):
            d.setdefault(name, {}).update(values)
        else:
            d[name] = values
    return d


def campaign_module():
    """benchmarks/campaign.py as a module."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("campaign", ROOT / "benchmarks" / "campaign.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def campaign_scene(index: int, thickness: float, seed: int = 1) -> dict:
    """Scene ``index`` of the random campaign of ``seed`` (benchmarks/campaign.py) as a scene dictionary, at the
    ``thickness`` (m) the campaign gave it (its LP's least thickness and the draw decide it)."""
    campaign = campaign_module()
    return campaign.scene_dict(campaign.draw(seed, index), thickness)


SMALL_RING = {"arch": {"shape": "semicircular", "span": 6.0, "thickness": 0.4, "voussoirs": 8},
              "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0},
              "joints": {"friction": 0.6},
              "load": [{"kind": "point", "position": 0.3}]}
"""A small semicircular ring (8 voussoirs, a point load at 0.3 of the span) whose limit analysis takes about a second
on a coarse mesh: the ring of the joint-law tests."""


def trap_the_analysis(monkeypatch, parent: Path, error: type[Exception] = AssertionError) -> Path:
    """An empty working folder ``parent/work`` as the cwd, and the analysis replaced by a trap that raises ``error``
    if it is reached (by default failing the test: a refusal must come before it)."""
    import bridgefem.analysis.runner

    def reached(*args, **kwargs):
        raise error("the analysis was reached")

    monkeypatch.setattr(bridgefem.analysis.runner, "run_analysis", reached)
    work = parent / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    return work


def write_toml(path: Path, d: dict) -> Path:
    """A minimal TOML writer for scene dictionaries (tables, arrays of tables, scalars, lists, inline tables;
    strings escaped, nan and inf as TOML writes them)."""
    def key(k):
        return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)

    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, float) and not math.isfinite(v):
            return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
        if isinstance(v, list):
            return "[" + ", ".join(map(value, v)) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{key(k)} = {value(x)}" for k, x in v.items()) + "}"
        return repr(v)

    lines = []
    for name, sec in d.items():
        if not isinstance(sec, (dict, list)) or (isinstance(sec, list) and not all(isinstance(t, dict) for t in sec)):
            lines.insert(0, f"{key(name)} = {value(sec)}")  # a top-level value: before the first table
            continue
        for table in (sec if isinstance(sec, list) else [sec]):
            lines.append(f"[[{key(name)}]]" if isinstance(sec, list) else f"[{key(name)}]")
            lines += [f"{key(k)} = {value(v)}" for k, v in table.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def bridgefem(*args, ranks: int = 1, timeout: int = 600, cwd: Path = ROOT, env: dict | None = None
              ) -> subprocess.CompletedProcess:
    """Run the installed command line in ``cwd``, optionally under mpirun, with the test's environment updated by
    ``env``."""
    cmd = [sys.executable, "-m", "bridgefem.io.cli", *map(str, args)]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", **(env or {})}
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=cwd)


MPI_BRACKET_SCRIPT = """
import json, sys
from mpi4py import MPI
import bridgefem
r = bridgefem.analyse(bridgefem.load_scene(sys.argv[1]), comm=MPI.COMM_WORLD)
print(json.dumps([MPI.COMM_WORLD.rank, r.status, r.limit_load.lower, r.limit_load.upper]))
"""


def assert_two_ranks_give(path: Path, serial, rel: float = 1e-6) -> None:
    """``mpirun -n 2`` of the scene at ``path`` (the public API on each rank): every rank has the serial analysis'
    status and bracket (``serial``: :func:`bridgefem.analysis.runner.run_analysis` of the same scene), to ``rel``."""
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    proc = subprocess.run(["mpirun", "-n", "2", sys.executable, "-c", MPI_BRACKET_SCRIPT, str(path)],
                          capture_output=True, text=True, timeout=900, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = sorted(json.loads(line) for line in proc.stdout.splitlines() if line.startswith("["))
    total = serial.load_total
    assert [r[:2] for r in rows] == [[0, serial.search.status], [1, serial.search.status]]
    for _, _, lower, upper in rows:
        assert lower == pytest.approx(serial.search.lower * total, rel=rel)
        assert upper == pytest.approx(serial.search.upper * total, rel=rel)


def readme_section(heading: str, next_heading: str) -> str:
    """The README's section from ``heading`` to ``next_heading``."""
    readme = (ROOT / "README.md").read_text()
    return readme[readme.index(heading):readme.index(next_heading)]


def assert_readme_lp(capsys, heading: str, next_heading: str, demo: str) -> str:
    """``bridgefem lp demos/<demo>`` prints the ```text block of the README's section from ``heading`` to
    ``next_heading`` (but the seconds it printed in parentheses); returns the section."""
    from bridgefem.io.cli import main

    def timeless(text: str) -> str:
        return re.sub(r" \(\d+\.\d+ s\)", "", text)

    section = readme_section(heading, next_heading)
    assert main(["lp", str(ROOT / "demos" / demo)]) == 0
    assert timeless(capsys.readouterr().out) == timeless(re.search(r"```text\n(.*?)```", section, re.S).group(1))
    return section


def run_campaign_scene(tmp_path: Path, index: int, thickness: float, seed: int = 1) -> dict:
    """Run campaign scene ``index`` of ``seed`` at ``thickness`` (m) through the command line; assert it ends in a
    limit load that agrees with the LP on the same joints; its results.json."""
    scene = write_toml(tmp_path / "s.toml", campaign_scene(index, thickness, seed))
    proc = bridgefem("run", str(scene), "--out", str(tmp_path / "out"))
    data = json.loads((tmp_path / "out" / "results.json").read_text())
    assert proc.returncode == 0 and data["status"] == "limit load found", data["status"]
    lower, upper, lp = data["limit_load"]["lower"], data["limit_load"]["upper"], data["lp"]["load"]
    assert lower <= 1.005 * lp and upper >= 0.995 * lp  # the evidence rule's agreement with the LP
    return data


@pytest.fixture
def tmp_scene(tmp_path):
    def make(d: dict, name: str = "scene") -> Path:
        return write_toml(tmp_path / f"{name}.toml", d)
    return make


def pytest_collection_modifyitems(items):
    """A case run under ``mpirun -n 2`` is an end-to-end run (two new processes that import DOLFINx): slow."""
    for item in items:
        if item.get_closest_marker("mpi"):
            item.add_marker(pytest.mark.slow)
