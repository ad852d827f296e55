"""Cost growth of the FE limit analysis with the mesh, in units of one linear elastic solve of the same mesh.

For the cases of benchmarks/harness.py (the reference semicircular arch and the segmental arch, 16 voussoirs,
the default preset's bracket tolerance), refined through the thickness from about 1k to 200k dofs (P1 by default;
the voussoirs stay many elements long), each size runs in a fresh process, after a warm-up run that loads Gmsh and
compiles the forms, and measures:

- the whole limit analysis (:func:`bridgefem.analysis.runner.run_analysis`, all phases; fastest of up to 5 repeats
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

    ./run python benchmarks/cost_growth.py                               # full (about 4 min on 2 cores)
    ./run python benchmarks/cost_growth.py --quick                       # 4 sizes up to 10k dofs (~1 min)
    ./run python benchmarks/cost_growth.py --cases segmental --sizes P1:4,8 P2:4 --figures demos/figures

Writes DIR/cost_growth.csv, DIR/cost_growth.md (the table, also printed) and DIR/cost_growth.png (log-log time
against dofs with fitted slopes; ratio to the elastic solve; meshing + assembly share); DIR defaults to
results/cost_growth.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import bracket_kn, builtin_cases, fmt, machine_line, run_jobs, scene_variant, worker, write_outputs  # noqa: E402

RATIO_TARGET = 20.0  # whole limit analysis <= this many linear elastic solves of the same mesh
SHARE_TARGET = 0.10  # meshing + assembly <= this share of a limit analysis
LP_BLOCKS = 1000
DEFAULT_SIZES = {"semicircular": ("P1:2,4,8,16,32",), "segmental": ("P1:2,4,8,16,32,64",)}  # t/64: 135k, 206k
QUICK_SIZES = ("P1:2,4,8,16",)
DOF_RANGE = (1_000, 210_000)  # the sizes of the ratio target: 1k to about 200k dofs


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
    A = solver.system.A.copy()  # now the bonded matrix
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
    from bridgefem.limit.collapse import collapse_load
    from bridgefem.scene.reader import scene_from_dict

    scene = scene_from_dict(scene_variant(base, voussoirs=blocks))
    times, lp = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        lp = collapse_load(scene)
        times.append(time.perf_counter() - t0)
    return {"blocks": blocks, "time_s": min(times), "first_s": times[0], "solve_blocks_s": lp.time_s,
            "load_kN": lp.load / 1e3}


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
        lower, upper = bracket_kn(r)
        cells = [r["case"], f"P{r['degree']}", f"t/{r['ett']}", str(r["dofs"]), str(r["pairs"]), r["status"],
                 f"[{lower:.2f}, {fmt(upper, '.2f')}]", f"{r['time_s']:.2f}", f"{r['elastic_solve_s']:.3f}",
                 f"{r['refactor_solve_s']:.3f}", f"{r['ratio']:.0f}", f"{r['ratio_cpu']:.0f}",
                 f"{r['ratio_refactor']:.0f}",
                 str(r["factorisations"]), str(r["linear_solves"]), f"{100 * r['share_mesh_assembly']:.1f}",
                 f"{100 * r['share_preprocessing']:.1f}", fmt(r.get("peak_mb"), ".0f")]
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
                           f"(slope {fmt(s.get('time_s'), '.2f')})")
        c = line.get_color()
        ax1.loglog(n, [r["elastic_solve_s"] for r in sel], marker + "--", mfc="none", color=c,
                   label=f"{name}: one elastic solve (slope {fmt(s.get('elastic_solve_s'), '.2f')})")
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


def measure_size(case: str, base: dict, degree: int, ett: int) -> dict:
    """One size of one case in a fresh process (default preset's tolerance): the record with its ratios."""
    scene = scene_variant(base, preset="default", ett=ett, degree=degree)
    rec = run_jobs([{"scene": scene, "repeat_budget": 8.0}], script=Path(__file__).resolve())[0]
    row = {"case": case, "degree": degree, "ett": ett, **rec}
    if "error" in rec:
        print(f"{case} P{degree} t/{ett}: {rec['error']}", flush=True)
        return row
    pre = sum(rec[f"time_{k}_s"] for k in ("geometry", "mesh", "assembly", "pairing", "solver_setup"))
    row.update(ratio=rec["time_s"] / rec["elastic_solve_s"], ratio_cpu=rec["cpu_s"] / rec["elastic_solve_cpu_s"],
               ratio_refactor=rec["time_s"] / rec["refactor_solve_s"],
               share_mesh_assembly=(rec["time_mesh_s"] + rec["time_assembly_s"]) / rec["time_s"],
               share_preprocessing=pre / rec["time_s"])
    print(f"{case} P{degree} t/{ett}: {rec['dofs']} dofs, {rec['status']}, analysis {rec['time_s']:.2f} s "
          f"({rec['linear_solves']} solves), elastic solve {rec['elastic_solve_s']:.3f} s, ratio {row['ratio']:.0f}, "
          f"refactor check: {rec['refactor_counted']}", flush=True)
    return row


def summary(rows: list[dict], slopes: dict, lp: dict) -> str:
    """The slopes and the verdicts on the targets (ratio over DOF_RANGE, meshing + assembly share, LP time)."""
    good = [r for r in rows if "error" not in r]
    in_range = [r for r in good if DOF_RANGE[0] <= r["dofs"] <= DOF_RANGE[1]]
    worst_ratio = max((r["ratio"] for r in in_range), default=None)
    best_ratio = min((r["ratio"] for r in in_range), default=None)
    worst_share = max((r["share_mesh_assembly"] for r in good), default=None)
    slope_lines = "".join(f"- {k[0]} P{k[1]} (>= 900 dofs): limit analysis {fmt(v['time_s'], '.2f')} (CPU "
                          f"{fmt(v['cpu_s'], '.2f')}), elastic solve {fmt(v['elastic_solve_s'], '.2f')}, refactor + "
                          f"solve {fmt(v['refactor_solve_s'], '.2f')}, linear solves per analysis "
                          f"{fmt(v['linear_solves'], '.2f')}\n" for k, v in slopes.items())
    return (f"\nSlopes of log time against log dofs:\n\n{slope_lines}\n"
            f"Ratio limit analysis / elastic solve, {DOF_RANGE[0]:,}-{DOF_RANGE[1]:,} dofs: "
            f"{fmt(best_ratio, '.0f')} to {fmt(worst_ratio, '.0f')} (target <= {RATIO_TARGET:g}); worst meshing + "
            f"assembly share: {fmt(worst_share and 100 * worst_share, '.1f')} % (target <= {100 * SHARE_TARGET:g} %; "
            f"warm process: the one-off `import gmsh` and the first-use form compilation are excluded).\n\n"
            f"Rigid-block LP with {lp['blocks']} voussoirs: {lp['time_s']:.3f} s, fastest of 3 (ring model + LP; "
            f"LP alone {lp['solve_blocks_s']:.3f} s; the first call in the process, which loads the LP solver: "
            f"{lp['first_s']:.3f} s; target < 1 s), collapse load {lp['load_kN']:.2f} kN.\n")


def bonded_extra(an) -> dict:
    """The worker's extra measurement: the bonded solve of the analysis's mesh."""
    return bonded_solve_times(an.solver)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", nargs="+", default=None, metavar="Pd:e1,e2",
                   help=f"degree and elements through the thickness (default: {DEFAULT_SIZES})")
    p.add_argument("--quick", action="store_true", help=f"sizes {' '.join(QUICK_SIZES)}")
    p.add_argument("--cases", nargs="+", default=["semicircular", "segmental"], metavar="CASE",
                   help="built-in cases of benchmarks/harness.py (default: semicircular segmental)")
    p.add_argument("--out", type=Path, default=Path("results/cost_growth"))
    p.add_argument("--figures", type=Path, help="also copy cost_growth.png and .md into this folder")
    p.add_argument("--worker", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker is not None:
        worker(json.loads(args.worker), extra=bonded_extra)
        return 0
    from bridgefem.scene.schema import PRESETS

    builtin = builtin_cases()
    unknown = [c for c in args.cases if c not in builtin]
    if unknown:
        p.error(f"--cases: unknown case {unknown[0]!r}; built-in cases are {', '.join(builtin)}")
    try:
        sizes = {c: parse_sizes(args.sizes or (QUICK_SIZES if args.quick else DEFAULT_SIZES[c])) for c in args.cases}
    except ValueError as err:
        p.error(str(err))
    start = time.perf_counter()
    rows = [measure_size(c, builtin[c], deg, ett) for c in args.cases for deg, ett in sizes[c]]
    good = [r for r in rows if "error" not in r]
    keys = ("time_s", "cpu_s", "elastic_solve_s", "refactor_solve_s", "linear_solves")
    slopes = {key: {k: slope([r for r in good if (r["case"], r["degree"]) == key], k) for k in keys}
              for key in series_keys(good)}
    lp = lp_timing(builtin[args.cases[0]])
    title = f"Cost growth: {', '.join(args.cases)}, tolerance {PRESETS['default'][('solver', 'tolerance')]:g}, serial"
    md = (f"# {title}\n\n{machine_line()} at the end; benchmark wall time {time.perf_counter() - start:.0f} s.\n\n"
          + markdown_table(rows) + summary(rows, slopes, lp))
    write_outputs(args.out, "cost_growth", rows, md, lambda path: plot(rows, slopes, title, path), args.figures)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
