"""Where the default demo's time goes: the wall time of each phase of ``bridgefem run demos/bare_arch.toml --quiet``
(``./run demo``'s work), each run a fresh process as a user starts it.

1. A child process (this script with ``--child``) times the interpreter's start (from the parent's spawn to its
   first line), then the imports in the command line's order: ``bridgefem.io.cli``, Gmsh's library where the command
   line loads it first (``cli._load_gmsh``; else Gmsh loads at the first mesh, inside the analysis), the FE
   (MPI, PETSc, DOLFINx, UFL, bridgefem's FE modules) and matplotlib; then it runs ``cli.main`` with the analysis,
   the XDMF fields, the two pictures and the report wrapped in timers (their modules' own names, which the command
   line looks up as it calls them).
2. The parent times the whole process: the exit is what follows ``main`` (the interpreter's finalisation, MPI's and
   PETSc's); "other" is what ``main`` spent outside the timed phases (the scene's checks, results.json, the output
   folder).
3. Medians over ``--repeat`` runs after a warm-up.

The phases are the command line's functions, so that two checkouts compare side by side
(``/other/checkout/.venv/bin/python benchmarks/demo_phases.py``). Run:

    ./run python benchmarks/demo_phases.py              # 5 runs (about 15 s)

Writes DIR/demo_phases.md and .csv (default results/demo_phases).
"""
from __future__ import annotations

import argparse
import functools
import importlib
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import machine_line, write_outputs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TIMED = {("bridgefem.analysis.runner", "run_analysis"): "analysis: mesh, FE search, LP checks",
         ("bridgefem.io.results", "_write_fields"): "fields.xdmf/h5",
         ("bridgefem.io.plots", "plot_load_deflection"): "picture: load-deflection",
         ("bridgefem.io.plots", "plot_mechanism"): "picture: mechanism",
         ("bridgefem.io.report", "run_report"): "report.html"}


def child(spawned: float, out: str) -> None:
    """One run of the demo in this process, its phases (s) as one JSON line on stderr (step 1 of the docstring)."""
    phases = {"interpreter start": time.time() - spawned}

    def timed_import(label: str, *modules: str) -> None:
        t = time.perf_counter()
        for m in modules:
            importlib.import_module(m)
        phases[label] = phases.get(label, 0.0) + time.perf_counter() - t

    timed_import("import bridgefem.io.cli", "bridgefem.io.cli")
    cli = sys.modules["bridgefem.io.cli"]
    if hasattr(cli, "_load_gmsh"):
        timed_import("Gmsh's library", "gmsh")
    timed_import("import MPI, PETSc, DOLFINx, UFL, bridgefem's FE", "mpi4py.MPI", "bridgefem.analysis.runner",
                 "bridgefem.io.results")
    timed_import("import matplotlib", "bridgefem.io.plots", "bridgefem.io.report")
    for (module, name), label in TIMED.items():
        mod = sys.modules[module]
        f = getattr(mod, name)

        @functools.wraps(f)
        def wrapper(*a, _f=f, _label=label, **k):
            t = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                phases[_label] = phases.get(_label, 0.0) + time.perf_counter() - t

        setattr(mod, name, wrapper)
    t = time.perf_counter()
    code = cli.main(["run", str(ROOT / "demos" / "bare_arch.toml"), "--out", out, "--quiet"])
    phases["other (checks, results.json, folder)"] = time.perf_counter() - t - sum(phases[v] for v in TIMED.values()
                                                                                 if v in phases)
    print("PHASES " + json.dumps({"phases": phases, "main_end": time.time()}), file=sys.stderr, flush=True)
    if hasattr(cli, "command"):
        import gc

        gc.freeze()  # as the command does before it exits
    sys.exit(code)


def one_run(out: str) -> dict:
    """The phases of one fresh process (s), its exit and its wall time."""
    spawned = time.time()
    proc = subprocess.run([sys.executable, __file__, "--child", str(spawned), out], capture_output=True, text=True,
                          timeout=600)
    ended = time.time()
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-2000:])
    line = next(x for x in proc.stderr.splitlines() if x.startswith("PHASES "))
    got = json.loads(line.split(" ", 1)[1])
    return {**got["phases"], "exit": ended - got["main_end"], "wall": ended - spawned}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--out", type=Path, default=ROOT / "results" / "demo_phases")
    p.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        child(float(args.child[0]), args.child[1])
    with tempfile.TemporaryDirectory() as tmp:
        one_run(f"{tmp}/out")  # warm-up: the file cache, the JIT cache of the forms
        runs = [one_run(f"{tmp}/out") for _ in range(args.repeat)]
    names = list(dict.fromkeys(k for r in runs for k in r))
    rows = [{"phase": n, "median_s": statistics.median(r.get(n, 0.0) for r in runs),
             "min_s": min(r.get(n, 0.0) for r in runs)} for n in names]
    lines = ["# Where the default demo's time goes", "",
             f"{machine_line()}; interpreter {sys.executable}; {args.repeat} runs after a warm-up.", "",
             "| phase | median s (fastest) |", "|---|---|"]
    lines += [f"| {r['phase']} | {r['median_s']:.3f} ({r['min_s']:.3f}) |" for r in rows]
    write_outputs(args.out, "demo_phases", rows, "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
