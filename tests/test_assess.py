"""The assessment (issue 40): vehicles, loads placed by x, the LP screen against a finer LP sweep, symmetry, the FE
at the critical position, the line of thrust, bad input, the report in a browser, MPI."""
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bridgefem
from bridgefem.assess.sweep import assess, lp_at
from bridgefem.assess.vehicle import axle_loads, place
from bridgefem.io.cli import main
from bridgefem.limit.collapse import collapse_load

ROOT = Path(__file__).resolve().parents[1]
BARE = ROOT / "demos" / "bare_arch.toml"


def _vehicle_scene(**vehicle):
    scene = bridgefem.load_scene(BARE)
    return bridgefem.edit(scene, load=[], vehicle=vehicle)


def test_x_places_a_load_as_position_does():
    """A load given by x (m from the left springing) is the load given by position = x / span."""
    scene = bridgefem.load_scene(BARE)
    by_x = bridgefem.edit(scene, load=[{"kind": "patch", "x": 3.0, "length": 0.5}])
    by_pos = bridgefem.edit(scene, load=[{"kind": "patch", "position": 3.0 / 9.0, "length": 0.5}])
    assert by_x.loads[0].x_range(9.0) == pytest.approx(by_pos.loads[0].x_range(9.0), abs=1e-12)
    assert by_x.loads[0].x_range(9.0)[0] == pytest.approx(3.0 - 4.5 - 0.25)


@pytest.mark.parametrize("vehicle, words", [
    ({"axles": [1e5, 1e5]}, "[vehicle] spacing = []"),
    ({"axles": [1e5], "standard": "EN1991-2-LM2"}, "[vehicle] axles"),
    ({"standard": "HA"}, "[vehicle] standard = 'HA'"),
    ({"axles": [1e5, 1e5], "spacing": [0.2], "contact_length": 0.3}, "longer than the contact length"),
    ({"axles": [-1.0]}, "[vehicle] axles = [-1.0]"),
    ({"spacing": [1.0]}, "[vehicle] axles: missing"),
])
def test_bad_vehicle_one_line(vehicle, words):
    """A bad [vehicle] is refused with one line naming the key, the value and what is allowed."""
    with pytest.raises(bridgefem.SceneError) as err:
        _vehicle_scene(**vehicle)
    text = str(err.value)
    assert words in text and "\n" not in text and ("allowed" in text or "expected" in text)


def test_x_and_position_must_agree():
    scene = bridgefem.load_scene(BARE)
    with pytest.raises(bridgefem.SceneError, match=r"\[\[load\]\] #1 x = 3.0.*allowed"):
        bridgefem.edit(scene, load=[{"kind": "point", "x": 3.0, "position": 0.5}])


def test_standard_vehicle_and_axles_off_the_span():
    """A library vehicle resolves to its source's axles; axles off the span carry nothing; a patch axle half on the
    span carries half its load."""
    s = _vehicle_scene(standard="EN1991-2-LM2", contact_length=0.4)
    assert s.vehicle.axles == (400e3,)
    assert axle_loads(s, -0.5) == [] and axle_loads(s, 9.5) == []
    [half] = axle_loads(s, 0.0)
    assert half["share"] == pytest.approx(0.5) and half["length"] == pytest.approx(0.2)
    pl = place(s, 0.0)
    assert pl.load == pytest.approx(200e3)


def test_every_library_vehicle_is_documented_with_its_numbers():
    """docs/assessment.md's library table has a row for every standard vehicle, giving its axle loads (kN), spacings
    and tyre contact (m) as the library has them; CS 454's tonnes are 9.80665 kN; each resolves in a scene."""
    import re

    from bridgefem.scene.vehicles import VEHICLES

    rows = {m.group(1): m.group(2) for m in re.finditer(r"^\| `([^`]+)` \| ([^|]+) \|", (ROOT / "docs" /
                                                                                        "assessment.md").read_text(),
                                                        re.M)}
    assert set(rows) == set(VEHICLES)
    assert VEHICLES["CS454-single-11.5t"]["axles"] == (pytest.approx(11.5 * 9.80665e3),)
    for name, v in VEHICLES.items():
        numbers = [float(x) for x in re.findall(r"\d+(?:\.\d+)?", rows[name])]
        for value in [a / 1e3 for a in v["axles"]] + list(v["spacing"]) + [v["contact_length"]] * (
                v["contact_length"] > 0):
            assert any(abs(n - value) <= 0.005 for n in numbers), (name, value, rows[name])
        assert (v["contact_length"] > 0) == ("contact not given" not in rows[name]), rows[name]
        s = _vehicle_scene(standard=name, contact_length=v["contact_length"] or 0.3)
        assert s.vehicle.axles == v["axles"] and s.vehicle.spacing == v["spacing"]


def test_assess_refuses_a_scene_without_vehicle(tmp_path, capsys):
    """bridgefem assess on a scene without [vehicle]: exit 2, one line, nothing written."""
    out = tmp_path / "out"
    assert main(["assess", str(BARE), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "[vehicle]: missing" in err[0]
    assert not out.exists()


@pytest.mark.slow
def test_two_axles_against_a_finer_lp_sweep():
    """The assessment's LP critical factor (screen span/40, refined) is within 1 % of the rigid-block LP swept on a
    grid 10 times finer than the screen (and is never below it by more than the sweep's own resolution)."""
    s = _vehicle_scene(axles=[100e3, 60e3], spacing=[1.5])
    [a] = assess([s], fe=False)
    fine = [lp_at(s, float(x)).factor for x in np.arange(-1.5, 9.0, 9.0 / 400)]
    least = min(f for f in fine if f is not None)
    assert a.lp_factor == pytest.approx(least, rel=0.01)
    assert a.lp_factor >= least * (1 - 0.01)
    # the LP factor is the collapse load over the vehicle: check one position by hand, through collapse_load
    pl = place(s, a.lp_critical_x)
    assert collapse_load(pl.scene).load / pl.load == pytest.approx(a.lp_factor, rel=1e-9)


@pytest.mark.slow
def test_single_axle_on_a_symmetric_arch_gives_a_symmetric_curve():
    """One point axle on a semicircular arch: the LP factor at x0 equals the factor at span - x0."""
    s = _vehicle_scene(axles=[100e3])
    xs = np.arange(0.45, 9.0, 0.45)
    f = np.array([lp_at(s, float(x)).factor for x in xs])
    assert np.allclose(f, f[::-1], rtol=1e-6)


@pytest.fixture(scope="module")
def assessed(tmp_path_factory):
    """``bridgefem assess --json`` of a two-axle vehicle on the default arch (one run for the tests below)."""
    folder = tmp_path_factory.mktemp("assess")
    scene = folder / "two_axles.toml"
    text = BARE.read_text().split("[[load]]")[0]
    scene.write_text(text + "\n[vehicle]\naxles = [100e3, 100e3]\nspacing = [1.2]\n")
    out = folder / "out"
    run = subprocess.run([sys.executable, "-m", "bridgefem", "assess", str(scene), "--out", str(out), "--json"],
                         capture_output=True, text=True, cwd=folder, timeout=600)
    assert run.returncode == 0, run.stderr
    return scene, out, json.loads(run.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_fe_at_the_critical_position_agrees_with_the_lp(assessed):
    """The FE adequacy factor at the critical position is within the usual FE/LP agreement (0.98..1.01) of the
    LP there, and the two axles' symmetric minima give the same factor."""
    _, out, verdict = assessed
    data = json.loads((out / "assessment.json").read_text())
    assert verdict["adequacy_factor"] == data["adequacy_factor"]["lower"]
    assert verdict["lp_adequacy_factor"] == data["lp_adequacy_factor"]
    crit = next(c for c in data["confirmations"] if c["x0"] == data["critical_x"])
    mid = (crit["adequacy"]["lower"] + crit["adequacy"]["upper"]) / 2
    assert 0.98 <= mid / crit["lp_factor"] <= 1.01
    limits = [c["adequacy"]["lower"] for c in data["confirmations"] if c["adequacy"]]
    if len(limits) == 2:  # the vehicle's two mirror positions on a symmetric arch
        assert limits[0] == pytest.approx(limits[1], rel=2e-3)


@pytest.mark.slow
def test_line_of_thrust_touches_the_faces_at_the_hinges(assessed):
    """The line of thrust of the last converged state lies within every joint (|e| <= t/2) and touches the face at
    each of the FE's hinges, on the side the hinge is."""
    _, out, _ = assessed
    res = json.loads((out / "assessment.json").read_text())["critical"]["results"]
    pts = {p["joint"]: p for p in res["line_of_thrust"]["points"]}
    assert all(abs(p["relative"]) <= 1 + 1e-6 for p in pts.values())
    for jid, where in res["mechanism"]["hinge_positions"].items():
        assert pts[int(jid)]["touches"] == where
    for p in pts.values():  # the crossing point is on the joint
        jt = res["joints"][p["joint"]]
        a, b = np.array(jt["intrados"]), np.array(jt["extrados"])
        q = np.array([p["x"], p["y"]])
        assert abs(np.cross(b - a, q - a)) <= 1e-9 * np.linalg.norm(b - a) ** 2


CHROMIUM = shutil.which("chromium")


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (./run installs it)")
def test_report_in_a_real_browser(assessed, tmp_path):
    """report.html opens in headless Chromium, every picture loads, and its numbers are assessment.json's."""
    _, out, _ = assessed
    data = json.loads((out / "assessment.json").read_text())
    page = tmp_path / "check.html"
    probe = ("<script>window.addEventListener('load',()=>{const im=[...document.images];"
             "document.body.setAttribute('data-images',im.length);"
             "document.body.setAttribute('data-loaded',im.filter(i=>i.complete&&i.naturalWidth>0).length);"
             "for(const id of ['adequacy-lower','adequacy-upper','lp-factor','critical-x'])"
             "{document.body.setAttribute('data-'+id,document.getElementById(id).textContent)}});</script>")
    page.write_text((out / "report.html").read_text().replace("</body>", probe + "</body>"))
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={tmp_path / 'profile'}"]
    dom = subprocess.run([CHROMIUM, *flags, "--virtual-time-budget=5000", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    import re

    attrs = dict(re.findall(r'data-([a-z-]+)="([^"]*)"', dom.split("<body", 1)[1].split(">", 1)[0]))
    assert int(attrs["images"]) == 4 and attrs["loaded"] == attrs["images"]
    assert float(attrs["adequacy-lower"]) == pytest.approx(data["adequacy_factor"]["lower"], abs=5e-5)
    assert float(attrs["adequacy-upper"]) == pytest.approx(data["adequacy_factor"]["upper"], abs=5e-5)
    assert float(attrs["lp-factor"]) == pytest.approx(data["lp_adequacy_factor"], abs=5e-5)
    assert float(attrs["critical-x"]) == pytest.approx(data["critical_x"], abs=5e-4)


@pytest.mark.slow
def test_mpi_two_ranks_same_answer(assessed, tmp_path):
    """mpirun -n 2 bridgefem assess gives the serial answer."""
    scene, _, serial = assessed
    env = {**os.environ, "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    run = subprocess.run(["mpirun", "-n", "2", sys.executable, "-m", "bridgefem", "assess", str(scene), "--out",
                          str(tmp_path / "mpi"), "--json"], capture_output=True, text=True, timeout=600, env=env)
    assert run.returncode == 0, run.stderr
    parallel = json.loads(run.stdout.strip().splitlines()[-1])
    assert parallel["critical_x"] == serial["critical_x"]
    assert parallel["lp_adequacy_factor"] == serial["lp_adequacy_factor"]
    assert parallel["adequacy_bracket"] == serial["adequacy_bracket"]  # the same FE run on one rank: every digit
    assert not math.isnan(parallel["adequacy_factor"])


BOARD = """
import json, math
from mpi4py import MPI
from bridgefem.assess.sweep import _Board
comm = MPI.COMM_WORLD
board = _Board(comm, 2)
taken = []
while (k := board.take()) < 50:
    taken.append(k)
board.lower(comm.rank % 2, 2.0 + comm.rank)
board.lower(1, 5.0)
comm.Barrier()
seen = [board.ceiling(0), board.ceiling(1)]
board.free()
parts = comm.gather((taken, seen))
if comm.rank == 0:
    print(json.dumps(parts))
"""


@pytest.mark.mpi
def test_the_ranks_share_one_queue_and_one_ceiling_per_scene(tmp_path):
    """The window the groups of ranks share (bridgefem.assess.sweep._Board), two ranks taking from it at once: every
    confirmation is taken exactly once, and each scene's ceiling is the least upper end any rank gave it, read the
    same on every rank."""
    script = tmp_path / "board.py"
    script.write_text(BOARD)
    env = {**os.environ, "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    run = subprocess.run(["mpirun", "-n", "2", sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120, env=env)
    assert run.returncode == 0, run.stderr
    parts = json.loads(run.stdout.strip().splitlines()[-1])
    assert sorted(k for taken, _ in parts for k in taken) == list(range(50))
    assert [seen for _, seen in parts] == [[2.0, 3.0], [2.0, 3.0]]


def test_each_scenes_first_confirmation_is_taken_first():
    """With several scenes the confirmations are queued each scene's least-screened position first, then each one's
    second (module docstring of bridgefem.assess.sweep, *Parallel*, step 2): the runs whose brackets give the
    ceilings start first."""
    from bridgefem.assess.sweep import Assessment, PositionLP, _queue

    scene = _vehicle_scene(axles=[100e3, 100e3], spacing=[1.2])
    xs, factors = [1.0, 3.5, 4.4, 5.25, 6.0], [0.9, 0.62, 0.9, 0.61, 0.9]
    a, b = (Assessment(scene, 0.225, [PositionLP(x, f, "limit load found") for x, f in zip(xs, factors)], 0.61, 5.25)
            for _ in range(2))
    assert [(i, m.x0) for i, m, _ in _queue([a, b], 2)] == [(0, 5.25), (1, 5.25), (0, 3.5), (1, 3.5)]


@pytest.mark.slow
def test_a_pruned_position_carries_its_ceiling_without_one():
    """A confirmation that stops at the ceiling of an earlier bracket (step 4 of bridgefem.assess.sweep) is not
    critical: the FE run at that position without a ceiling carries more than that ceiling. Two positions of the
    two-axle vehicle are handed to the confirmation step as the screen's two least minima, the critical one first."""
    from mpi4py import MPI

    from bridgefem.analysis.runner import run_analysis
    from bridgefem.assess.sweep import Assessment, PositionLP, _confirm, brief

    scene = _vehicle_scene(axles=[100e3, 100e3], spacing=[1.2])
    # the critical position (first axle 5.25 m, LP 0.6116) and a stronger one (3.5 m), as the screen's two minima
    xs, factors = [1.0, 3.5, 4.4, 5.25, 6.0], [0.9, 0.62, 0.9, 0.61, 0.9]
    a = Assessment(scene, 0.225, [PositionLP(x, f, "limit load found") for x, f in zip(xs, factors)], 0.61, 5.25)
    _confirm([a], MPI.COMM_WORLD, 2, brief, lambda line: None)
    first, second = a.confirmations
    assert first.ceiling is None and first.adequacy is not None
    assert second.ceiling == first.adequacy[1] and second.pruned and second.adequacy is None
    assert a.critical_x == 5.25 and a.adequacy == first.adequacy
    whole = run_analysis(place(scene, 3.5).scene, MPI.COMM_WORLD)
    assert whole.search.status == "limit load found"
    assert whole.search.lower * whole.load_total / second.load >= second.ceiling


@pytest.mark.slow
def test_a_ceiling_above_the_limit_leaves_the_bracket_as_it_is():
    """The ceiling of a pruned confirmation ends a search, never steers it: a run asked to stop once it carries a
    load just above its own limit gets exactly the bracket of the run without it (the load steps approach the limit
    as they do without one), so the confirmations below their ceilings do not depend on how the positions were
    shared among ranks."""
    from mpi4py import MPI

    from bridgefem.analysis.runner import run_analysis

    pl = place(_vehicle_scene(axles=[100e3, 100e3], spacing=[1.2]), 2.545)
    free = run_analysis(pl.scene, MPI.COMM_WORLD)
    total = free.load_total
    lower, upper = free.search.lower * total, free.search.upper * total
    capped = run_analysis(pl.scene, MPI.COMM_WORLD, enough=upper * (1 + 1e-4))
    assert (capped.search.status, capped.search.lower * total, capped.search.upper * total) == \
        (free.search.status, lower, upper)
    # asked for less than its limit, a run ends once it carries that (no bracket), or with the same bracket when the
    # step that carries it also closes the bracket (here the static theorem's bound does), never later
    below = run_analysis(pl.scene, MPI.COMM_WORLD, enough=0.4 * lower)
    found = (below.search.status, below.search.lower * total, below.search.upper)
    assert found[0].startswith("no collapse") and 0.4 * lower <= found[1] < lower and found[2] is None or \
        found == (free.search.status, lower, free.search.upper)
    assert len(below.search.steps) <= len(free.search.steps)


@pytest.mark.slow
def test_a_ceiling_that_falls_during_a_run_ends_it_on_the_free_runs_path():
    """A ceiling given as a function is asked before every load step (the ceiling another group of ranks lowers while
    this run goes on, bridgefem.assess.sweep step 4): none at first, then one below the limit; the run ends as
    carried at the first step after the ceiling fell whose level carries it, its steps those of the run without a
    ceiling up to there."""
    from mpi4py import MPI

    from bridgefem.analysis.runner import run_analysis

    pl = place(_vehicle_scene(axles=[100e3, 100e3], spacing=[1.2]), 3.5)
    free = run_analysis(pl.scene, MPI.COMM_WORLD)
    total, lower = free.load_total, free.search.lower * free.load_total
    asked = []

    def ceiling() -> float:
        asked.append(len(asked))
        return math.inf if len(asked) <= 3 else 0.5 * lower

    capped = run_analysis(pl.scene, MPI.COMM_WORLD, enough=ceiling)
    assert capped.search.status.startswith("no collapse") and capped.search.upper is None
    assert 0.5 * lower <= capped.search.lower * total < lower and len(asked) > 3
    steps = [(s.level, s.converged) for s in capped.search.steps]
    assert steps == [(s.level, s.converged) for s in free.search.steps][:len(steps)]
