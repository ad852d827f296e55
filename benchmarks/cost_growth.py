"""Cost growth of the FE limit analysis with the mesh, in units of one linear elastic solve of the same mesh.

For the cases of demos/speed_accuracy.py (the reference semicircular arch and the segmental arch, 16 voussoirs,
the default preset's bracket tolerance), refined through the thickness from about 1k to 200k dofs (P1 by default;
the voussoirs stay many elements long), each size runs in a fresh process, after a warm-up run that loads Gmsh and
compiles the forms, and measures:

- the whole limit analysis (:func:`bridgefem.analysis.run_analysis`, all phases; fastest of up to 3 repeats
  for the small sizes) and its phases;
- one linear elastic solve of the same mesh: the bonded system (every joint pair stuck, i.e. the stiffness
  matrix with the joints glued, the first system of every analysis) factorised by a fresh MUMPS LU — symbolic
  analysis, numeric factorisation — and solved, fastest of 3 (``elastic``); and a numeric refactorisation + solve
  of it inside the contact solver, which is what each active-set iteration costs (``refactor``);
- the ratio whole analysis / elastic solve (target: at most 20; wall times, and CPU times, which a shared machine
  does not inflate), meshing + assembly as a share of the analysis (target: at most 10 %), and the least-squares
  slopes of log time against log dofs.

Also: the rigid-block LP with 1000 voussoirs (target: under 1 s), fastest of 3, and the first call.

Run:

    ./run python benchmarks/cost_growth.py                               # full (about 13 min on 2 cores)
    ./run python benchmarks/cost_growth.py --quick                       # 4 sizes up to 10k dofs (~1 min)
    ./run python benchmarks/cost_growth.py --cases segmental --sizes P1:4,8 P2:4 --figures demos/figures

Writes DIR/cost_growth.csv, DIR/cost_growth.md (the table, also printed) and DIR/cost_growth.png (log-log time
against dofs with fitted slopes; ratio to the elastic solve; meshing + assembly share); DIR defaults to
results/cost_growth.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "demos"))
from speed_accuracy import builtin_cases, git_state, measure, run_jobs, scene_variant  # noqa: E402  (shared harness)

RATIO_TARGET = 20.0  # whole limit analysis <= this many linear elastic solves of the same mesh
SHARE_TARGET = 0.10  # meshing + assembly <= this share of a limit analysis
LP_BLOCKS = 1000
DEFAULT_SIZES = ("P1:2,4,8,16,32,64",)
QUICK_SIZES = ("P1:2,4,8,16",)


def bonded_solve_times(solver, repeats: int = 7, budget: float = 2.0) -> dict:
    """Times (s) of the bonded system: one refactorisation + solve inside the contact solver (a single active-set
    iteration at zero live load from every pair stuck) and the fastest of 3 to ``repeats`` fresh MUMPS LU
    factorisations (symbolic + numeric) + solves of that matrix (more while they took less than ``budget`` s)."""
    from mpi4py import MPI
    from petsc4py import PETSc

    comm = solver.comm
    keep, before = solver.max_iterations, dict(solver.stats)
    solver.max_iterations = 1
    t0 = time.perf_counter()
    solver.solve_step(0.0, solver.initial_iterate())
    refactor = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    solver.max_iterations = keep
    counted = {k: solver.stats[k] - before[k] for k in ("factorisations", "solves")}
    A = solver.A.copy()  # now the bonded matrix
    b, x = A.createVecLeft(), A.createVecRight()
    b.set(1.0)  # the cost of a direct solve does not depend on the right-hand side
    best, best_cpu, spent, i = np.inf, np.inf, 0.0, 0
    while i < 3 or (i < repeats and spent < budget):
        i += 1
        ksp = PETSc.KSP().create(comm)
        ksp.setOperators(A)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        pc.setFactorSetUpSolverType()
        pc.getFactorMatrix().setMumpsIcntl(14, 200)
        comm.barrier()
        t0, c0 = time.perf_counter(), time.process_time()
        ksp.setUp()
        ksp.solve(b, x)
        took = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        best, spent = min(best, took), spent + took
        best_cpu = min(best_cpu, comm.allreduce(time.process_time() - c0, op=MPI.SUM))
        ksp.destroy()
    A.destroy()
    return {"refactor_solve_s": refactor, "elastic_solve_s": best, "elastic_solve_cpu_s": best_cpu,
            "refactor_counted": f"{counted['factorisations']} factorisation(s), {counted['solves']} solve(s)"}


def worker(payload: dict) -> None:
    """Measure each job (scene dictionary, repeat budget) and its bonded solve; print ``RESULT {json}`` lines."""
    from mpi4py import MPI

    jobs = payload["jobs"]
    t0 = time.perf_counter()
    import gmsh  # noqa: F401
    gmsh_import = time.perf_counter() - t0
    for job in jobs:
        try:
            an, rec = measure(job["scene"], job["repeat_budget"])
            rec.update(bonded_solve_times(an.solver))
            rec["gmsh_import_s"] = gmsh_import
        except Exception as err:
            rec = {"error": f"{type(err).__name__}: {err}"}
        if MPI.COMM_WORLD.rank == 0:
            print("RESULT " + json.dumps(rec), flush=True)


def parse_sizes(specs) -> list[tuple[int, int]]:
    out = []
    for spec in specs:
        deg, _, etts = spec.partition(":")
        if deg not in ("P1", "P2") or not etts:
            raise ValueError(f"--sizes {spec!r}: expected P1:e1,e2,... or P2:e1,e2,...")
        out += [(int(deg[1]), int(e)) for e in etts.split(",")]
    return out


def slope(rows: list[dict], key: str, min_dofs: int = 900) -> float | None:
    """Least-squares slope of log(key) against log(dofs) over rows with at least ``min_dofs`` dofs."""
    pts = [(r["dofs"], r[key]) for r in rows if r.get(key) and r["dofs"] >= min_dofs]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def lp_timing(base: dict, blocks: int = LP_BLOCKS, repeats: int = 3) -> dict:
    """Wall time (s) of the rigid-block LP with ``blocks`` voussoirs (ring model + LP), fastest of ``repeats``."""
    from bridgefem.rigid_block import collapse_load
    from bridgefem.scene import scene_from_dict

    scene = scene_from_dict(scene_variant(base, voussoirs=blocks))
    times, lp = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        lp = collapse_load(scene)
        times.append(time.perf_counter() - t0)
    return {"blocks": blocks, "time_s": min(times), "first_s": times[0], "solve_blocks_s": lp.time_s,
            "load_kN": lp.load / 1e3}


def _f(v, fmt):
    return "-" if v is None else format(v, fmt)


def markdown_table(rows: list[dict]) -> str:
    head = ["case", "deg", "elements", "dofs", "pairs", "status", "FE bracket kN", "limit analysis s",
            "elastic solve s", "refactor+solve s", "ratio (target <= 20)", "CPU ratio", "ratio to refactor",
            "factorisations", "solves", "mesh+assembly %", "pre-processing %", "peak MB"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['case']} | P{r['degree']} | t/{r['ett']} | - | - | {r['error']} |"
                         + " - |" * (len(head) - 6))
            continue
        kn = r["load_total"] / 1e3
        up = None if r["upper_N"] is None else r["upper_N"] * kn
        cells = [r["case"], f"P{r['degree']}", f"t/{r['ett']}", str(r["dofs"]), str(r["pairs"]), r["status"],
                 f"[{r['lower_N'] * kn:.2f}, {_f(up, '.2f')}]", f"{r['time_s']:.2f}", f"{r['elastic_solve_s']:.3f}",
                 f"{r['refactor_solve_s']:.3f}", f"{r['ratio']:.0f}", f"{r['ratio_cpu']:.0f}",
                 f"{r['ratio_refactor']:.0f}",
                 str(r["factorisations"]), str(r["linear_solves"]), f"{100 * r['share_mesh_assembly']:.1f}",
                 f"{100 * r['share_preprocessing']:.1f}", _f(r.get("peak_mb"), ".0f")]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def series_keys(rows: list[dict]) -> list[tuple[str, int]]:
    return list(dict.fromkeys((r["case"], r["degree"]) for r in rows))


def plot(rows: list[dict], slopes: dict, title: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(16, 4.6))
    markers = "osD^v<>"
    for i, key in enumerate(series_keys(rows)):
        sel = sorted((r for r in rows if (r["case"], r["degree"]) == key and "error" not in r),
                     key=lambda r: r["dofs"])
        if not sel:
            continue
        name, marker = f"{key[0]} P{key[1]}", markers[i % len(markers)]
        n = [r["dofs"] for r in sel]
        s = slopes.get(key, {})
        line, = ax1.loglog(n, [r["time_s"] for r in sel], marker + "-", label=f"{name}: limit analysis "
                           f"(slope {_f(s.get('time_s'), '.2f')})")
        c = line.get_color()
        ax1.loglog(n, [r["elastic_solve_s"] for r in sel], marker + "--", mfc="none", color=c,
                   label=f"{name}: one elastic solve (slope {_f(s.get('elastic_solve_s'), '.2f')})")
        ax1.loglog(n, [RATIO_TARGET * r["elastic_solve_s"] for r in sel], ":", color=c, lw=1)
        ax2.loglog(n, [r["ratio"] for r in sel], marker + "-", color=c, label=f"{name}: limit / elastic solve (wall)")
        ax2.loglog(n, [r["ratio_cpu"] for r in sel], marker + "--", mfc="none", color=c, label=f"{name}: CPU time")
        ax2.loglog(n, [r["linear_solves"] for r in sel], marker + ":", mfc="none", color=c, alpha=0.6,
                   label=f"{name}: linear solves per analysis")
        ax3.semilogx(n, [100 * r["share_mesh_assembly"] for r in sel], marker + "-", color=c,
                     label=f"{name}: mesh + assembly")
        ax3.semilogx(n, [100 * r["share_preprocessing"] for r in sel], marker + "--", mfc="none", color=c,
                     label=f"{name}: all phases before the search")
    ax1.plot([], [], ":", color="grey", label=f"{RATIO_TARGET:g} x elastic solve (the target)")
    ax2.axhline(RATIO_TARGET, color="crimson", lw=1, label=f"target {RATIO_TARGET:g}")
    ax3.axhline(100 * SHARE_TARGET, color="crimson", lw=1, label=f"target {100 * SHARE_TARGET:g} %")
    ax1.set_ylabel("wall time (s)")
    ax2.set_ylabel("ratio / count")
    ax3.set_ylabel("share of the limit analysis (%)")
    for ax in (ax1, ax2, ax3):
        ax.set_xlabel("dofs (displacements + joint forces)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", nargs="+", default=None, metavar="Pd:e1,e2",
                   help=f"degree and elements through the thickness (default: {' '.join(DEFAULT_SIZES)})")
    p.add_argument("--quick", action="store_true", help=f"sizes {' '.join(QUICK_SIZES)}")
    p.add_argument("--cases", nargs="+", default=["semicircular", "segmental"], metavar="CASE",
                   help="built-in cases of demos/speed_accuracy.py (default: semicircular segmental)")
    p.add_argument("--out", type=Path, default=Path("results/cost_growth"))
    p.add_argument("--figures", type=Path, help="also copy cost_growth.png and .md into this folder")
    p.add_argument("--worker", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker is not None:
        worker(json.loads(args.worker))
        return 0
    from bridgefem.scene import PRESETS

    try:
        sizes = parse_sizes(args.sizes or (QUICK_SIZES if args.quick else DEFAULT_SIZES))
    except ValueError as err:
        p.error(str(err))
    builtin = builtin_cases()
    unknown = [c for c in args.cases if c not in builtin]
    if unknown:
        p.error(f"--cases: unknown case {unknown[0]!r}; built-in cases are {', '.join(builtin)}")
    start = time.perf_counter()
    rows = []
    for case in args.cases:
        for deg, ett in sizes:
            scene = scene_variant(builtin[case], preset="default", ett=ett, degree=deg)  # the default tolerance
            rec = run_jobs(Path(__file__).resolve(), [{"scene": scene, "repeat_budget": 8.0}])[0]
            row = {"case": case, "degree": deg, "ett": ett, **rec}
            if "error" not in rec:
                pre = sum(rec[f"time_{k}_s"] for k in ("geometry", "mesh", "assembly", "pairing", "solver_setup"))
                row.update(ratio=rec["time_s"] / rec["elastic_solve_s"],
                           ratio_cpu=rec["cpu_s"] / rec["elastic_solve_cpu_s"],
                           ratio_refactor=rec["time_s"] / rec["refactor_solve_s"],
                           share_mesh_assembly=(rec["time_mesh_s"] + rec["time_assembly_s"]) / rec["time_s"],
                           share_preprocessing=pre / rec["time_s"])
                print(f"{case} P{deg} t/{ett}: {rec['dofs']} dofs, {rec['status']}, analysis {rec['time_s']:.2f} s "
                      f"({rec['linear_solves']} solves), elastic solve {rec['elastic_solve_s']:.3f} s, ratio "
                      f"{row['ratio']:.0f}, refactor check: {rec['refactor_counted']}", flush=True)
            else:
                print(f"{case} P{deg} t/{ett}: {rec['error']}", flush=True)
            rows.append(row)
    good = [r for r in rows if "error" not in r]
    keys = ("time_s", "cpu_s", "elastic_solve_s", "refactor_solve_s", "linear_solves")
    slopes = {key: {k: slope([r for r in good if (r["case"], r["degree"]) == key], k) for k in keys}
              for key in series_keys(good)}
    lp = lp_timing(builtin[args.cases[0]])
    elapsed = time.perf_counter() - start
    load = os.getloadavg()
    degrees = "/".join(f"P{d}" for d in sorted({d for d, _ in sizes}))
    title = (f"Cost growth: {', '.join(args.cases)}, {degrees}, tolerance "
             f"{PRESETS['default'][('solver', 'tolerance')]:g}, serial")
    slope_lines = "".join(f"- {k[0]} P{k[1]} (>= 900 dofs): limit analysis {_f(v['time_s'], '.2f')} (CPU "
                          f"{_f(v['cpu_s'], '.2f')}), elastic solve {_f(v['elastic_solve_s'], '.2f')}, refactor + "
                          f"solve {_f(v['refactor_solve_s'], '.2f')}, linear solves per analysis "
                          f"{_f(v['linear_solves'], '.2f')}\n" for k, v in slopes.items())
    worst_ratio = max((r["ratio"] for r in good), default=None)
    worst_share = max((r["share_mesh_assembly"] for r in good), default=None)
    gm = min((r["gmsh_import_s"] for r in good), default=None)
    summary = (f"\nSlopes of log time against log dofs:\n\n{slope_lines}\n"
               f"Worst ratio limit analysis / elastic solve: {_f(worst_ratio, '.0f')} (target <= {RATIO_TARGET:g}); "
               f"worst meshing + assembly share: {_f(worst_share and 100 * worst_share, '.1f')} % (target <= "
               f"{100 * SHARE_TARGET:g} %; warm process: the one-off `import gmsh`, at least {_f(gm, '.2f')} s, and "
               f"the first-use form compilation are excluded).\n\n"
               f"Rigid-block LP with {lp['blocks']} voussoirs: {lp['time_s']:.3f} s, fastest of 3 (ring model + LP; "
               f"LP alone {lp['solve_blocks_s']:.3f} s; the first call in the process, which loads the LP solver: "
               f"{lp['first_s']:.3f} s; target < 1 s), collapse load {lp['load_kN']:.2f} kN.\n")
    md = (f"# {title}\n\nCode: {git_state()}; {os.cpu_count()} CPU(s), load average {load[0]:.1f} at the end; "
          f"benchmark wall time {elapsed:.0f} s.\n\n" + markdown_table(rows) + summary)
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "cost_growth.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
        writer.writeheader()
        writer.writerows(rows)
    (args.out / "cost_growth.md").write_text(md)
    plot(rows, slopes, title, args.out / "cost_growth.png")
    if args.figures:
        args.figures.mkdir(parents=True, exist_ok=True)
        for name in ("cost_growth.png", "cost_growth.md"):
            shutil.copy(args.out / name, args.figures / name)
    print(md)
    print(f"written to {args.out}/ (cost_growth.csv, .md, .png)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
