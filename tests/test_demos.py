"""The demo scripts run (short settings) and their FE results agree with their own LP check."""
import csv
import subprocess
import sys

from conftest import ROOT


def test_interface_study_fe_matches_lp_without_sliding(tmp_path):
    out = tmp_path / "study"
    proc = subprocess.run([sys.executable, "demos/interface_study.py", "--voussoirs", "8", "16", "32", "64",
                           "--friction", "10", "--out", str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    for name in ("interface_study.csv", "interface_study.md", "interface_study.png"):
        assert (out / name).is_file()
    with open(out / "interface_study.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["voussoirs"]) for r in rows] == [8, 16, 32, 64]
    for r in rows:
        # mu = 10: a pure hinge mechanism, so the FE bracket must sit within 1 % of the rigid-block LP
        assert 0.99 <= float(r["fe_lp_ratio"]) <= 1.01, r
        assert r["hinges_match"] == "True", r
