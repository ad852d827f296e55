"""Where each process of ``bridgefem assess`` spends its time, serial and under ``mpirun -n 2``: CPU seconds per phase.

On the shared machine the wall-time ratio of benchmarks/assess_speedup.py means little while other jobs run; the
CPU time of each process depends on them much less. Method:

1. The scene of assess_speedup.py's ``--bridge`` (its vehicle on demos/bare_arch.toml or demos/prestwood.toml) at
   ``--step``.
2. ``bridgefem assess`` run serial, then under ``mpirun -n 2``, each process in this file's ``--child`` mode: the
   command with its phases wrapped (the LP screen's levels ``_spread``, each FE run ``run_analysis``, each run's
   results and pictures ``_describe``), each recording its wall and CPU time (``time.process_time``); at its exit
   every process writes them with its total CPU since the interpreter started.
3. The table: per process, CPU s of the start (to the first LP level), the LP, each FE run, each results-and-pictures,
   the rest and the total; and serial CPU / the 2 ranks' critical path, the ratio two ranks would reach if CPU time
   were wall time. Open MPI polls while a rank waits in a collective, so a rank's waits count as its CPU: the rank
   that finishes first waits for the other in the last gather (in its "rest"), and the critical path is the
   largest CPU outside "rest" plus the least "rest".

Run: ``./run python benchmarks/assess_phases.py [--bridge prestwood] [--step 0.05]``.
"""
from __future__ import annotations

import argparse
import atexit
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from assess_speedup import BRIDGES, MPI, ROOT  # noqa: E402


def child(out: Path, argv: list[str]) -> int:
    """``bridgefem assess argv`` with its phases timed (step 2); writes ``out``.<rank>.json at exit."""
    import bridgefem.analysis.runner as runner
    import bridgefem.assess.sweep as sweep
    import bridgefem.io.assessment as io_assessment
    from bridgefem.io.cli import main

    marks: list[tuple[str, float, float]] = []

    def timed(module, name: str, phase: str) -> None:
        fn = getattr(module, name)

        def wrapped(*args, **kwargs):
            w, c = time.perf_counter(), time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                marks.append((phase, time.perf_counter() - w, time.process_time() - c))
        setattr(module, name, wrapped)

    timed(sweep, "_spread", "lp")
    timed(runner, "run_analysis", "fe")
    timed(io_assessment, "_describe", "results")
    start = time.process_time()

    def dump() -> None:
        from mpi4py import MPI as mpi

        data = {"marks": marks, "cpu": time.process_time(), "imports": start}
        (out.parent / f"{out.name}.{mpi.COMM_WORLD.rank}.json").write_text(json.dumps(data))
    atexit.register(dump)
    return main(["assess", *argv])


def row(name: str, data: dict) -> tuple[str, float]:
    """The table's row of one process, and its "rest" (CPU s outside the timed phases)."""
    lp = sum(c for p, _, c in data["marks"] if p == "lp")
    fe = [c for p, _, c in data["marks"] if p == "fe"]
    res = [c for p, _, c in data["marks"] if p == "results"]
    rest = data["cpu"] - data["imports"] - lp - sum(fe) - sum(res)
    return (f"| {name} | {data['imports']:.2f} | {lp:.2f} | {' + '.join(f'{c:.2f}' for c in fe)} | "
            f"{' + '.join(f'{c:.2f}' for c in res)} | {rest:.2f} | **{data['cpu']:.2f}** |"), rest


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bridge", choices=sorted(BRIDGES), default="bare")
    p.add_argument("--step", default="default", help='screening step (m, or "default")')
    p.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args, rest = p.parse_known_args(argv)
    if args.child:
        return child(args.child, rest)
    env = {**os.environ, "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    load = os.getloadavg()[0]
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        demo, vehicle = BRIDGES[args.bridge]
        scene = Path(tmp) / f"{args.bridge}_two_axles.toml"
        scene.write_text((ROOT / "demos" / demo).read_text().split("[[load]]")[0] + vehicle)
        opt = [] if args.step == "default" else ["--step", args.step]
        cpu = {}
        for name, launch in (("serial", []), ("2 ranks", MPI)):
            tag = Path(tmp) / name.replace(" ", "")
            cmd = [*launch, sys.executable, __file__, "--child", str(tag), str(scene), *opt, "--json",
                   "--out", str(Path(tmp) / f"out-{tag.name}")]
            w = time.perf_counter()
            subprocess.run(cmd, check=True, env=env, capture_output=True, text=True)
            wall = time.perf_counter() - w
            ranks = sorted(Path(tmp).glob(f"{tag.name}.*.json"))
            for f in ranks:
                data = json.loads(f.read_text())
                line, rest = row(f"{name}, rank {f.name.split('.')[1]} (wall {wall:.2f} s)", data)
                cpu.setdefault(name, []).append((data["cpu"], rest))
                lines.append(line)
    print(f"{args.bridge}, step {args.step}; load average (1 min) {load:.2f} before, {os.getloadavg()[0]:.2f} after "
          f"on {os.cpu_count()} CPUs\n")
    print("| process | start (imports) | LP levels | FE runs | results and pictures | rest | CPU s in all |\n"
          "|---|---|---|---|---|---|---|\n" + "\n".join(lines))
    ranks = cpu["2 ranks"]
    critical = max(c - r for c, r in ranks) + min(r for _, r in ranks)
    print(f"\n2 ranks' critical path {critical:.2f} CPU s; serial CPU / that: {cpu['serial'][0][0] / critical:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
