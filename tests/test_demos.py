"""The demo scripts run (short settings) and their FE results agree with their own LP check."""
import csv
import subprocess
import sys

import pytest
from conftest import ROOT

pytestmark = pytest.mark.slow  # end-to-end analyses


def run_demo(name: str, args: list[str], out) -> list[dict]:
    """Run demos/NAME.py with ``args`` and ``--out OUT``; check it wrote NAME.csv, .md and .png; its CSV rows."""
    proc = subprocess.run([sys.executable, f"demos/{name}.py", *args, "--out", str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    for suffix in ("csv", "md", "png"):
        assert (out / f"{name}.{suffix}").is_file()
    with open(out / f"{name}.csv") as f:
        return list(csv.DictReader(f))


def test_interface_study_fe_matches_lp_without_sliding(tmp_path):
    rows = run_demo("interface_study", ["--voussoirs", "8", "16", "32", "64", "--friction", "10"], tmp_path)
    assert [int(r["voussoirs"]) for r in rows] == [8, 16, 32, 64]
    for r in rows:
        # mu = 10: a pure hinge mechanism, so the FE bracket must sit within 1 % of the rigid-block LP
        assert 0.99 <= float(r["fe_lp_ratio"]) <= 1.01, r
        assert r["hinges_match"] == "True", r


def _rows_by_kind(rows, case, kind):
    return [r for r in rows if r["case"] == case and r["kind"] == kind]


def test_speed_accuracy_quick_fe_approaches_the_lp_and_bracket_ignores_the_seed(tmp_path):
    rows = run_demo("speed_accuracy", ["--quick"], tmp_path)
    for case in ("semicircular", "segmental"):
        for r in _rows_by_kind(rows, case, "mesh") + _rows_by_kind(rows, case, "seed"):
            assert r["status"] == "limit load found", r
            lower, upper, tol = float(r["fe_lower_kN"]), float(r["fe_upper_kN"]), float(r["tolerance"])
            assert 0 < upper - lower <= tol * lower * (1 + 1e-9), r  # the bracket rule at the tight tolerance
        mesh = sorted(_rows_by_kind(rows, case, "mesh"), key=lambda r: int(r["ett"]))
        errors = [float(r["err_lp"]) for r in mesh]
        # refining the mesh moves the elastic-block FE limit towards the rigid-block LP on the same joints, or the
        # limit is the LP's on every mesh: the static theorem's bound is the LP's level (the meshed voussoirs carry
        # their polygons' weights), and the bracket's midpoint lies half its width below it
        assert all(b <= a + 1e-4 for a, b in zip(errors, errors[1:])), errors
        half = 0.5 * max(float(r["tolerance"]) for r in mesh) * (1 + 1e-9)
        assert errors[-1] < 0.5 * errors[0] or max(errors) <= half, errors
        reference = _rows_by_kind(rows, case, "reference")[0]
        assert abs(float(reference["fe_mid_kN"]) / float(reference["lp_kN"]) - 1) < 1e-3, reference
        # the same configuration seeded with 0.5 x and 2 x the LP and without a seed: the same limit load within
        # the bracket tolerance (the seed only changes the load path)
        seeded = _rows_by_kind(rows, case, "seed")
        assert sorted(r["seed"] for r in seeded) == ["none", "x0.5", "x2"]
        for r in seeded:
            same = next(m for m in mesh if (m["ett"], m["degree"]) == (r["ett"], r["degree"]))  # seeded x1
            assert abs(float(r["fe_mid_kN"]) / float(same["fe_mid_kN"]) - 1) <= float(same["tolerance"]), (r, same)


def test_tutorial_uses_the_public_api_and_brackets_the_rigid_block_collapse_load():
    """demos/tutorial.py imports bridgefem's public API alone; its bracket lies within 0.1 % of the rigid-block
    collapse load of this joint layout (129.627 kN, the LP on the same joints, the load on the voussoir right of
    joint 6), with the LP's hinges among the FE's; along its friction sweep the LP's collapse load grows with the
    friction and every FE bracket lies within the evidence rule's 0.5 % of it."""
    import ast
    import re

    import bridgefem

    source = (ROOT / "demos" / "tutorial.py").read_text()
    tree = ast.parse(source)
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert imported == {"bridgefem", "mpi4py"}, imported
    used = {n.attr for n in ast.walk(tree)
            if isinstance(n, ast.Attribute) and getattr(n.value, "id", "") == "bridgefem"}
    assert used <= set(bridgefem.__all__), used
    proc = subprocess.run([sys.executable, "demos/tutorial.py"], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("limit load found: limit load in ["))
    lower, upper = (float(v) for v in line.split("[")[1].split("]")[0].split(","))
    assert lower <= 129.627 * 1.001 and upper >= 129.627 * 0.999, line
    fe_hinges = set(map(int, line.split("hinges at joints [")[1].split("]")[0].split(",")))
    assert fe_hinges >= {6, 12, 16}, line
    rows = re.findall(r"^ +([0-9.]+) +([0-9.]+) +\[[0-9, ]*\] +\[([0-9.]+), ([0-9.]+)\]", proc.stdout, re.M)
    assert [float(r[0]) for r in rows] == [0.4, 0.5, 0.6, 0.8], proc.stdout
    lp = [float(r[1]) for r in rows]
    assert lp == sorted(lp)
    for (_, lp_kn, fe_lower, fe_upper) in rows:
        assert float(fe_lower) <= 1.005 * float(lp_kn) and float(fe_upper) >= 0.995 * float(lp_kn), rows
