"""How fast the commands answer: ``bridgefem lp``, ``min-thickness``, ``check`` and ``run`` of the default bridge,
each a fresh process as a user starts it.

1. A warm-up of each command (the file cache, the JIT cache of the forms), then ``--repeat`` runs of each, the
   commands taking turns.
2. Per run: the wall time of the whole command and its CPU time (user + system, all its processes: what a busy
   machine does not inflate), and which of DOLFINx, PETSc, Gmsh, matplotlib and MPI the process loaded.
3. The median and the fastest of each, against the targets: ``lp``, ``check`` and ``min-thickness`` under
   :data:`LIGHT_TARGET` s wall, ``run`` of the default bridge (``./run demo``'s work) under :data:`DEMO_TARGET` s.

The commands run as ``python -m bridgefem`` of the interpreter running this script, so that two checkouts compare
side by side (``/other/checkout/.venv/bin/python benchmarks/startup.py``). Run:

    ./run python benchmarks/startup.py                    # 7 runs of each (about a minute)

Writes DIR/startup.md and .csv (default results/startup).
"""
from __future__ import annotations

import argparse
import ast
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import machine_line, timed, write_outputs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LIGHT_TARGET = 0.5  # s wall: the commands that answer from the rigid-block LP
DEMO_TARGET = 1.5  # s wall: the default bridge's whole run
HEAVY = ("dolfinx", "petsc4py", "gmsh", "matplotlib", "mpi4py")
PROBE = ("import sys, runpy; sys.argv = ['bridgefem'] + sys.argv[1:]\n"
         "try:\n    runpy.run_module('bridgefem', run_name='__main__')\n"
         "finally:\n    print('LOADED', sorted({m.split('.')[0] for m in sys.modules} & set(%r)), file=sys.stderr)\n"
         % (HEAVY,))


def timed_command(args: list[str], cwd: str) -> tuple[float, float, list[str]]:
    """Wall and CPU time (s) of one command in a fresh process started in ``cwd`` (not a checkout: the interpreter's
    own bridgefem answers), and the heavy modules it loaded."""
    wall, cpu, proc = timed([sys.executable, "-c", PROBE, *args], cwd=cwd, timeout=600)
    loaded = next(line for line in proc.stderr.splitlines() if line.startswith("LOADED"))
    return wall, cpu, ast.literal_eval(loaded.split(" ", 1)[1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--out", type=Path, default=ROOT / "results" / "startup")
    args = p.parse_args()
    demo = str(ROOT / "demos" / "bare_arch.toml")
    with tempfile.TemporaryDirectory() as tmp:
        commands = {"lp": ["lp", demo], "min-thickness": ["min-thickness", demo], "check": ["check", demo],
                    "run (default bridge)": ["run", demo, "--out", f"{tmp}/out", "--quiet"]}
        for c in commands.values():
            timed_command(c, tmp)  # warm-up
        runs: dict[str, list] = {name: [] for name in commands}
        for _ in range(args.repeat):
            for name, c in commands.items():
                runs[name].append(timed_command(c, tmp))
    rows = []
    for name, rr in runs.items():
        target = DEMO_TARGET if name.startswith("run") else LIGHT_TARGET
        walls, cpus = [r[0] for r in rr], [r[1] for r in rr]
        rows.append({"command": name, "wall_median_s": statistics.median(walls), "wall_min_s": min(walls),
                     "cpu_median_s": statistics.median(cpus), "target_s": target,
                     "met": statistics.median(walls) <= target, "loads": " ".join(rr[0][2]) or "none of them"})
    lines = ["# How fast the commands answer", "",
             f"{machine_line()}; interpreter {sys.executable}; {args.repeat} runs of each after a warm-up.", "",
             "| command | wall, median (fastest) s | CPU, median s | target (wall) | met | loads |",
             "|---|---|---|---|---|---|"]
    lines += [f"| `{r['command']}` | {r['wall_median_s']:.2f} ({r['wall_min_s']:.2f}) | {r['cpu_median_s']:.2f} | "
              f"{r['target_s']:g} s | {'yes' if r['met'] else 'no'} | {r['loads']} |" for r in rows]
    write_outputs(args.out, "startup", rows, "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
