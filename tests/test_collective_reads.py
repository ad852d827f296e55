"""Nothing MPI-collective hides behind an attribute of an analysis (issue 38, item 5): whatever needs the other ranks
(the fill's conic bounds, the ring under the transmitted loads, the collapse mode, the warnings that read them) is
computed once on every rank inside run_analysis (bridgefem.analysis.runner, step 6), so that one rank alone can read
every attribute of the result, and summarise it, while the other rank has finished."""
import json
import os
import signal
import subprocess
import sys

import pytest
from conftest import ROOT, scene_dict

# an elastic fill (its ring check gathers the interface forces of both ranks; its conic bounds are rank 0's, broadcast)
# whose search stops after two steps at a maximum load below the first step
SCENE = scene_dict(fill={"depth": 0.5, "extension": 1.0, "unit_weight": 18000.0, "young": 5e7},
                   load=[{"kind": "patch", "position": 0.25, "length": 0.5}],
                   mesh={"elements_through_thickness": 2}, solver={"max_load": 1e4})
WORKER = """
import dataclasses, json, sys
from mpi4py import MPI
from bridgefem.analysis.runner import run_analysis
from bridgefem.io.results import summary
from bridgefem.scene.reader import scene_from_dict

an = run_analysis(scene_from_dict(json.loads(open(sys.argv[1]).read())))
if MPI.COMM_WORLD.rank == 1:  # rank 0 has finished: a read that needed it would wait for ever
    names = ["warnings", "fill_bounds", "ring_check", "collapse_mode"]
    names += [f.name for f in dataclasses.fields(an)]
    names += [n for n, v in vars(type(an)).items() if isinstance(v, property)]
    read = {n: getattr(an, n) for n in names}
    data = summary(an)
    print("READ", json.dumps({"names": sorted(set(names)), "status": data["status"],
                              "ring_check": read["ring_check"] is not None, "fill_bounds": read["fill_bounds"],
                              "warnings": read["warnings"], "mpi_ranks": data["mpi_ranks"]}), flush=True)
"""
TIMEOUT = 300  # s: the analysis takes seconds; a read that waits for the finished rank never ends


@pytest.mark.mpi
@pytest.mark.slow
def test_one_rank_reads_every_attribute_of_an_analysis_alone(tmp_path):
    """Under mpirun -n 2, rank 0 ends right after run_analysis while rank 1 reads every field and property of the
    Analysis and summarises it as results.json does: the program ends, and rank 1 saw the checks (a ring check, the
    fill's bounds entry and the warnings) that collective properties used to compute on first read."""
    (tmp_path / "scene.json").write_text(json.dumps(SCENE))
    (tmp_path / "worker.py").write_text(WORKER)
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    proc = subprocess.Popen(["mpirun", "-n", "2", sys.executable, tmp_path / "worker.py", tmp_path / "scene.json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # mpirun and both ranks
        proc.communicate()
        pytest.fail(f"a read of the analysis on one rank waited for the other: no end within {TIMEOUT} s")
    assert proc.returncode == 0, err
    (line,) = [line for line in out.splitlines() if line.startswith("READ ")]
    seen = json.loads(line[len("READ "):])
    assert {"warnings", "fill_bounds", "ring_check", "collapse_mode", "fe_lp_ratio", "n_dofs"} <= set(seen["names"])
    assert seen["mpi_ranks"] == 2 and seen["ring_check"]
    assert seen["fill_bounds"]["status"].startswith('[fill] material = "elastic"')
    assert any("shorter than one element" in w for w in seen["warnings"]), seen["warnings"]
