"""MPI speed-up of the FE limit analysis: the same scene of at least 100k dofs serial and on ``mpirun -n 2``.

The machine's load average is printed before and after: on a shared 2-core machine another job running at the
same time slows the 2-rank run most, so the ratio is only meaningful when both load averages are low. Each run is
a fresh process (serial: ``python``; parallel: ``mpirun -n 2 python``) that first does a warm-up run
(Gmsh loaded, forms compiled) and then times :func:`bridgefem.analysis.runner.run_analysis`, per phase (the slowest
rank). The speed-up is serial time / parallel time, measured in one invocation so that machine noise is shared;
with ``--repeat`` the runs alternate and the fastest of each is kept. The brackets must match (same status, and
the same bounds to 1e-9 relative, or the same load steps).

Run:

    ./run python benchmarks/mpi_speedup.py                         # segmental arch, t/48, P1 (~120k dofs)
    ./run python benchmarks/mpi_speedup.py --case semicircular --ett 64   # the reference arch, ~140k dofs
    ./run python benchmarks/mpi_speedup.py --ett 16 --repeat 2     # a smaller check
    ./run python benchmarks/mpi_speedup.py --ranks 2 3

Prints a markdown table and writes it to DIR/mpi_speedup.md and DIR/mpi_speedup.csv (default results/mpi_speedup).
Target: speed-up >= 1.5 with 2 ranks at >= 100k dofs, same bracket.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import PHASES, bracket_kn, builtin_cases, machine_line, run_jobs, scene_variant, write_outputs  # noqa: E402

TARGET = 1.5


def same_bracket(a: dict, b: dict) -> bool:
    if a["status"] != b["status"]:
        return False
    for k in ("lower_N", "upper_N"):
        x, y = a[k], b[k]
        if (x is None) != (y is None) or (x is not None and abs(x - y) > 1e-9 * max(abs(x), 1.0)):
            return False
    return True


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", default="segmental", help="a built-in case of benchmarks/harness.py (default "
                   "segmental: few load steps, so the serial parts weigh most)")
    p.add_argument("--scene", type=Path, help="a scene file instead of --case")
    p.add_argument("--ett", type=int, default=48, help="elements through the thickness (default 48: ~120k dofs)")
    p.add_argument("--degree", type=int, default=1)
    p.add_argument("--tolerance", type=float, help="bracket tolerance (default: the default preset's)")
    p.add_argument("--ranks", type=int, nargs="+", default=[2], help="parallel rank counts (default 2)")
    p.add_argument("--repeat", type=int, default=1, help="alternating repeats; the fastest run is kept")
    p.add_argument("--out", type=Path, default=Path("results/mpi_speedup"))
    p.add_argument("--figures", type=Path, help="also copy mpi_speedup.md and .png into this folder")
    args = p.parse_args(argv)
    if args.scene is not None:
        base, name = tomllib.loads(args.scene.read_text()), args.scene.stem
    elif args.case in builtin_cases():
        base, name = builtin_cases()[args.case], args.case
    else:
        p.error(f"--case {args.case!r}: built-in cases are {', '.join(builtin_cases())}")
    scene = scene_variant(base, preset="default", ett=args.ett, degree=args.degree, tolerance=args.tolerance)
    if args.tolerance is None:
        from bridgefem.scene.schema import PRESETS

        args.tolerance = PRESETS["default"][("solver", "tolerance")]
    job = {"scene": scene, "repeat_budget": 0.0}
    load_before = os.getloadavg()
    print(f"load average before: {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f}", flush=True)
    start = time.perf_counter()
    best: dict[int, dict] = {}
    for rep in range(args.repeat):
        for ranks in [1, *args.ranks]:
            rec = run_jobs([job], ranks=ranks)[0]
            rec["ranks"] = ranks
            took = rec.get("time_s")
            print(f"repeat {rep + 1}, {ranks} rank(s): " + (rec["error"] if "error" in rec else
                  f"{rec['dofs']} dofs, {rec['status']}, [{rec['lower_N']:.6g}, {rec['upper_N']}] N, {took:.2f} s, "
                  f"{rec['factorisations']} factorisations"), flush=True)
            if "error" not in rec and (ranks not in best or took < best[ranks]["time_s"]):
                best[ranks] = rec
    if 1 not in best:
        print("the serial run failed: no speed-up", file=sys.stderr)
        return 1
    serial = best[1]
    head = ["ranks", "dofs", "status", "bracket kN", "total s", *[f"{ph} s" for ph in PHASES], "factorisations",
            "speed-up total", "speed-up search", "same bracket"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    rows = []
    for ranks, r in sorted(best.items()):
        lower, upper = bracket_kn(r)
        up = "-" if upper is None else f"{upper:.2f}"
        r["speedup"] = serial["time_s"] / r["time_s"]
        r["speedup_search"] = serial["time_limit_search_s"] / r["time_limit_search_s"]
        r["same_bracket"] = same_bracket(serial, r)
        cells = [str(ranks), str(r["dofs"]), r["status"], f"[{lower:.2f}, {up}]", f"{r['time_s']:.1f}",
                 *[f"{r['time_' + ph.replace(' ', '_') + '_s']:.2f}" for ph in PHASES], str(r["factorisations"]),
                 f"{r['speedup']:.2f}", f"{r['speedup_search']:.2f}", "yes" if r["same_bracket"] else "**no**"]
        lines.append("| " + " | ".join(cells) + " |")
        rows.append(r)
    elapsed = time.perf_counter() - start
    load_after = os.getloadavg()
    print(f"load average after: {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}", flush=True)
    verdict = [f"{ranks} ranks: speed-up {r['speedup']:.2f} (target >= {TARGET:g}: "
               f"{'met' if r['speedup'] >= TARGET else 'NOT met'}), bracket "
               f"{'identical' if r['same_bracket'] else 'DIFFERENT'}" for ranks, r in sorted(best.items()) if ranks > 1]
    md = (f"# MPI speed-up: {name}, t/{args.ett}, P{args.degree}, tolerance {args.tolerance:g}\n\n"
          f"{machine_line()} at the end; load average (1 min) {load_before[0]:.2f} before and {load_after[0]:.2f} "
          f"after ({os.cpu_count()} CPUs: other jobs on the machine make the ratio unreliable); fastest of "
          f"{args.repeat} alternating run(s) per rank count; benchmark wall time {elapsed:.0f} s.\n\n"
          + "\n".join(lines) + "\n\n" + "\n".join(f"- {v}" for v in verdict) + "\n")
    title = f"MPI speed-up: {name}, t/{args.ett}, P{args.degree}, {serial['dofs']} dofs"
    write_outputs(args.out, "mpi_speedup", rows, md, plot=lambda path: plot(rows, title, path), figures=args.figures)
    return 0


def plot(rows: list[dict], title: str, path: Path) -> None:
    """Wall time per phase (stacked bars) for each rank count, with the speed-up over serial on each bar."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    labels = [f"{r['ranks']} rank{'s' if r['ranks'] > 1 else ''}" for r in rows]
    bottom = [0.0] * len(rows)
    for ph in PHASES:
        times = [r["time_" + ph.replace(" ", "_") + "_s"] for r in rows]
        ax.bar(labels, times, bottom=bottom, label=ph)
        bottom = [b + t for b, t in zip(bottom, times)]
    for x, (r, top) in enumerate(zip(rows, bottom)):
        ax.annotate(f"x{r['speedup']:.2f}", (x, top), ha="center", va="bottom")
    ax.set_ylim(0, 1.1 * max(bottom))
    ax.set_ylabel("wall time (s)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
