"""Interface-count study: the limit load of one arch cut into more and more voussoirs, by FE and by rigid-block LP.

Every joint of the ring is a potential crack, so the number of voussoirs N sets where hinges can form. For each N
(a joint always sits under each concentrated load) the scene is analysed by the FE contact model
(:func:`bridgefem.analysis.runner.run_analysis`) and by the rigid-block linear programme
(:func:`bridgefem.limit.collapse.collapse_load`) on the same joint layout. The study shows how the limit load drops
and settles as the joints get denser, whether the FE bracket and hinges follow the LP for every N, and what the
extra joints cost: FE degrees of freedom, load steps, linear solves and time, against the LP time.

Run (the default scene is demos/bare_arch.toml, N = 4 ... 128):

    ./run python demos/interface_study.py
    ./run mpirun -n 2 python demos/interface_study.py --voussoirs 8 16

Writes DIR/interface_study.csv (every number), DIR/interface_study.md (the summary table, also printed) and
DIR/interface_study.png (limit load and time against N); DIR defaults to results/interface_study and is
replaced atomically. Loads are in kN for the scene's width.
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import logging
import time
from pathlib import Path

from mpi4py import MPI

from bridgefem.analysis.runner import run_analysis
from bridgefem.io.output import claim, results_folder
from bridgefem.io.targets import OutputError
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.keys import SceneError
from bridgefem.scene.model import Scene
from bridgefem.scene.reader import load_scene

PHASES = ("geometry", "mesh", "assembly", "pairing", "solver setup", "limit search")


def with_voussoirs(scene: Scene, n: int, friction: float | None) -> Scene:
    """The scene cut into ``n`` voussoirs (joints kept under the loads), with an optional friction coefficient."""
    arch = dataclasses.replace(scene.arch, voussoirs=n, joint_at_loads=True)
    joints = scene.joints if friction is None else dataclasses.replace(scene.joints, friction=friction)
    return dataclasses.replace(scene, arch=arch, joints=joints)


def hinge_label(hinges: dict[int, str]) -> str:
    """Hinges as joint id + side, e.g. ``0e 3i 9e 16i`` (i: intrados, e: extrados)."""
    return " ".join(f"{j}{side[0]}" for j, side in sorted(hinges.items()))


def study_case(scene: Scene, comm: MPI.Comm) -> dict:
    """FE and LP analyses of one scene (collective); one row of the study, loads in kN, times in s."""
    start = time.perf_counter()
    an = run_analysis(scene, comm)
    fe_time = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    lp = collapse_load(scene)
    s, kn = an.search, an.load_total / 1e3
    lower = s.lower * kn
    upper = None if s.upper is None else s.upper * kn
    lp_load = None if lp.load is None else lp.load / 1e3
    ratio = (lower + upper) / 2 / lp_load if upper is not None and lp_load else None
    fe_hinges = {j.id: j.hinge for j in an.joints if j.hinge}
    return {
        "voussoirs": scene.arch.voussoirs, "fe_status": s.status, "fe_lower_kN": lower, "fe_upper_kN": upper,
        "lp_status": lp.status, "lp_kN": lp_load, "fe_lp_ratio": ratio,
        "fe_hinges": hinge_label(fe_hinges), "lp_hinges": hinge_label(lp.hinge_positions),
        "hinges_match": fe_hinges == lp.hinge_positions,
        "fe_sliding": " ".join(str(j.id) for j in an.joints if j.sliding),
        "lp_sliding": " ".join(map(str, lp.sliding)),
        "dofs": an.n_dofs, "newton_iterations": sum(st.iterations for st in s.steps), "load_steps": len(s.steps),
        "failed_steps": sum(not st.converged for st in s.steps),
        "factorisations": an.solver.stats["factorisations"], "linear_solves": an.solver.stats["solves"],
        **{f"time_{p.replace(' ', '_')}_s": an.timings.get(p, 0.0) for p in PHASES},
        "fe_time_s": fe_time, "lp_time_s": lp.time_s, "mpi_ranks": comm.size,
    }


def _num(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def markdown_table(rows: list[dict]) -> str:
    head = ["N", "FE bracket kN", "LP kN", "FE/LP", "hinges match", "dofs", "steps", "solves", "FE time s",
            "LP time s", "FE status"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [str(r["voussoirs"]), f"[{r['fe_lower_kN']:.3f}, {_num(r['fe_upper_kN'], '.3f')}]",
                 _num(r["lp_kN"], ".3f"), _num(r["fe_lp_ratio"], ".4f"), "yes" if r["hinges_match"] else "no",
                 str(r["dofs"]), str(r["load_steps"]), str(r["linear_solves"]), f"{r['fe_time_s']:.1f}",
                 f"{r['lp_time_s']:.3f}", r["fe_status"]]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], title: str, path: Path) -> None:
    """Left: limit load against N (FE bracket as error bars, LP line); right: FE and LP time against N."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [r["voussoirs"] for r in rows]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    fe = [r for r in rows if r["fe_upper_kN"] is not None]
    mid = [(r["fe_lower_kN"] + r["fe_upper_kN"]) / 2 for r in fe]
    err = [[m - r["fe_lower_kN"] for m, r in zip(mid, fe)], [r["fe_upper_kN"] - m for m, r in zip(mid, fe)]]
    ax1.errorbar([r["voussoirs"] for r in fe], mid, yerr=err, fmt="o-", capsize=4, label="FE (bracket)")
    lp = [r for r in rows if r["lp_kN"] is not None]
    ax1.plot([r["voussoirs"] for r in lp], [r["lp_kN"] for r in lp], "k--s", ms=4, mfc="none",
             label="rigid-block LP")
    ax1.set_xscale("log", base=2)
    ax1.set_xlabel("voussoirs N")
    ax1.set_ylabel("limit live load (kN)")
    ax2.loglog(n, [r["fe_time_s"] for r in rows], "o-", label="FE (all phases)")
    ax2.loglog(n, [r["lp_time_s"] for r in rows], "k--s", ms=4, mfc="none", label="rigid-block LP")
    ax2.set_xscale("log", base=2)
    ax2.set_xlabel("voussoirs N")
    ax2.set_ylabel("wall time (s)")
    for ax in (ax1, ax2):
        ax.set_xticks(n, [str(k) for k in n])
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_outputs(rows: list[dict], title: str, out: Path) -> None:
    """CSV, markdown and PNG into ``out``, atomically and under bridgefem's output policy (rank 0 only)."""
    with results_folder(out) as tmp:
        with open(tmp / "interface_study.csv", "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        (tmp / "interface_study.md").write_text(f"# {title}\n\n" + markdown_table(rows))
        plot(rows, title, tmp / "interface_study.png")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", type=Path, default=Path(__file__).resolve().parent / "bare_arch.toml")
    p.add_argument("--voussoirs", type=int, nargs="+", default=[4, 8, 16, 32, 64, 128], metavar="N")
    p.add_argument("--friction", type=float, metavar="MU", help="joint friction coefficient (default: the scene's)")
    p.add_argument("--out", type=Path, default=Path("results/interface_study"))
    args = p.parse_args(argv)
    logging.getLogger().setLevel(logging.WARNING)  # no JIT compiler chatter
    if min(args.voussoirs) < 2:
        p.error("--voussoirs: every N must be at least 2")
    if args.friction is not None and args.friction < 0:
        p.error("--friction: must be >= 0")
    comm = MPI.COMM_WORLD
    try:
        base = load_scene(args.scene)
        with claim(args.out, comm):  # a refused --out stops the study before it runs
            rows = [study_case(with_voussoirs(base, n, args.friction), comm) for n in args.voussoirs]
            if comm.rank == 0:
                mu = base.joints.friction if args.friction is None else args.friction
                title = f"Interface-count study: {base.name}, mu = {mu:g}, {comm.size} MPI rank(s)"
                write_outputs(rows, title, args.out)
                print(markdown_table(rows), end="")
                print(f"written to {args.out}/ (interface_study.csv, .md, .png)")
            comm.barrier()
    except (SceneError, OutputError) as err:  # raised identically on every rank
        p.error(str(err))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
