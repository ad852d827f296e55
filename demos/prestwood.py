"""Prestwood bridge (TRRL RR110): the limit load with the fill modelled three ways, against the 228 kN test.

0. **bare ring**: the rigid-block LP of the ring alone (fill removed) under the same load on its extrados;
1. **fill as dead load only**: the rigid-block LP on the same joints with the fill's weight on the voussoirs
   and the load on the extrados below the loading beam (the classical bare-arch assessment);
2. **elastic fill**: FE with a linear elastic fill behind an arch-fill contact interface (no strength limit);
3. **Mohr-Coulomb fill**: FE with the elastic-plastic fill of the scene (demos/prestwood.toml), associated flow,
   and with the dilation angle psi = phi/2 and 0 (non-associated flow).

Then the sensitivity of the Mohr-Coulomb limit load to the three least certain inputs (fill friction angle,
fill cohesion and fill depth over the crown; each varied alone from the scene's value). The published predictions
of the same bridge are listed with the table (PUBLISHED). The FE cases use the scene's mesh (for a Mohr-Coulomb
fill the preset's: quadratic displacements, docs/fill.md); ``--degree`` and ``--elements`` (elements through the
ring) override it. The loading beam is the scene's ``[fill] loading_beam`` (the TRRL's rigid spreader beam).

Run:

    ./run python demos/prestwood.py                  # everything (a few minutes)
    ./run python demos/prestwood.py --no-sensitivity
    ./run python demos/prestwood.py --elements 4     # the sensitivity on a finer mesh
    ./run mpirun -n 2 python demos/prestwood.py --no-sensitivity

Writes DIR/prestwood.md (the table, also printed), DIR/prestwood.csv, DIR/<case>/ (results.json, fields.xdmf,
load_deflection.png and mechanism.png of each FE case) and DIR/prestwood.png (load against deflection under the
load for the FE cases, with the test load); DIR defaults to results/prestwood and is replaced atomically. Loads
in kN for the full 3.8 m width.
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import time
from pathlib import Path

from mpi4py import MPI

from bridgefem.analysis.runner import run_analysis
from bridgefem.io.output import results_folder
from bridgefem.io.results import write_results
from bridgefem.io.targets import OutputError
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.model import Scene, with_mesh
from bridgefem.scene.reader import load_scene

TEST_LOAD_KN = 228.0  # TRRL RR110: maximum load of the collapse test
PUBLISHED = {"nonlinear FE, Mohr-Coulomb fill (Simoncello et al. 2020, Front. Built Environ. 6:7)": 245.0,
             "limit analysis with backfill (Zampieri et al. 2020, Eng. Struct. 225:111135)": 220.0}  # kN
HERE = Path(__file__).resolve().parent


def variants(scene: Scene, sensitivity: bool) -> dict[str, Scene]:
    """The FE cases: elastic fill, the scene's Mohr-Coulomb fill and (optionally) one-at-a-time variations."""
    fill = scene.fill
    cases = {"elastic fill": dataclasses.replace(scene, fill=dataclasses.replace(fill, material="elastic")),
             "Mohr-Coulomb fill": scene}
    for psi in (fill.friction_angle / 2, 0.0):
        cases[f"Mohr-Coulomb fill, dilation angle {psi:g} deg"] = dataclasses.replace(
            scene, fill=dataclasses.replace(fill, dilation_angle=psi))
    if sensitivity:
        for label, change in ((f"friction angle {fill.friction_angle - 5:g} deg", {"friction_angle": -5.0}),
                              (f"friction angle {fill.friction_angle + 5:g} deg", {"friction_angle": 5.0}),
                              ("cohesion 0 kPa", {"cohesion": -fill.cohesion}),
                              (f"cohesion {2 * fill.cohesion / 1e3:g} kPa", {"cohesion": fill.cohesion}),
                              (f"depth {fill.depth - 0.1:.1f} m", {"depth": -0.1}),
                              (f"depth {fill.depth + 0.1:.1f} m", {"depth": 0.1})):
            key, delta = next(iter(change.items()))
            cases[label] = dataclasses.replace(scene, fill=dataclasses.replace(fill, **{key: getattr(fill, key) + delta}))
    return cases


def fe_row(label: str, scene: Scene, out: Path, comm: MPI.Comm) -> dict:
    """One FE case (collective): its bracket (kN), the ratio of its midpoint to the test, mechanism, cost."""
    start = time.perf_counter()
    an = run_analysis(scene, comm)
    data = write_results(an, out / label.replace(" ", "_"))
    seconds = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    lim = data["limit_load"]
    lower, upper = lim["lower"] / 1e3, None if lim["upper"] is None else lim["upper"] / 1e3
    mid = 0.5 * (lower + upper) if data["status"] == "limit load found" else None  # a bracket only then
    return {"case": label, "status": data["status"], "lower_kN": lower, "upper_kN": upper,
            "ratio_to_test": mid / TEST_LOAD_KN if mid else None,
            "hinges": " ".join(f"{j}{p[0]}" for j, p in sorted(data["mechanism"]["hinge_positions"].items(),
                                                                key=lambda kv: int(kv[0]))),
            "steps": data["solver"]["load_steps"], "solves": data["solver"]["solves"], "seconds": seconds,
            "curve": [(h["deflection"], h["load"] / 1e3) for h in data["history"] if h["converged"]]}


def lp_row(scene: Scene, label: str = "fill as dead load only (LP)") -> dict:
    lp = collapse_load(scene)
    load = lp.load / 1e3 if lp.load else None
    return {"case": label, "status": lp.status, "lower_kN": load, "upper_kN": load,
            "ratio_to_test": load / TEST_LOAD_KN if load else None,
            "hinges": " ".join(f"{j}{p[0]}" for j, p in sorted(lp.hinge_positions.items())),
            "steps": None, "solves": None, "seconds": lp.time_s, "curve": []}


def _num(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def markdown(rows: list[dict]) -> str:
    lines = ["| case | status | limit load (kN) | / test (228 kN) | hinges | load steps | linear solves | time (s) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        bracket = (f"{r['lower_kN']:.1f}" if r["upper_kN"] == r["lower_kN"] else
                   f"[{_num(r['lower_kN'], '.1f')}, {_num(r['upper_kN'], '.1f')}]")
        lines.append(f"| {r['case']} | {r['status']} | {bracket} | {_num(r['ratio_to_test'], '.3f')} | {r['hinges']} "
                     f"| {_num(r['steps'], 'd')} | {_num(r['solves'], 'd')} | {r['seconds']:.1f} |")
    lines += ["", "| published prediction | limit load (kN) | / test |", "|---|---|---|"]
    lines += [f"| {name} | {load:.0f} | {load / TEST_LOAD_KN:.3f} |" for name, load in PUBLISHED.items()]
    lines.append(f"| test (TRRL RR110, Page 1987) | {TEST_LOAD_KN:.0f} | 1.000 |")
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for r in rows:
        if r["curve"]:
            d, p = zip(*r["curve"])
            ax.plot([1e3 * v for v in d], p, marker=".", ms=3, label=r["case"])
    ax.axhline(TEST_LOAD_KN, color="k", ls="--", lw=1, label="test maximum (228 kN)")
    lp = [r for r in rows if r["case"].startswith("fill as dead load")]
    if lp and lp[0]["lower_kN"]:
        ax.axhline(lp[0]["lower_kN"], color="grey", ls=":", lw=1, label="LP, fill as dead load only")
    ax.set_xlabel("arch deflection under the load (mm)")
    ax.set_ylabel("live load (kN, full width)")
    top = 1.6 * TEST_LOAD_KN
    reach = [1e3 * d for r in rows for d, p in r["curve"] if p <= top]  # the elastic fill runs far beyond
    ax.set_ylim(0, top)
    ax.set_xlim(0, 1.1 * max(reach, default=1.0))
    ax.set_title("Prestwood bridge: live load against deflection")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", default=str(HERE / "prestwood.toml"))
    parser.add_argument("--no-sensitivity", action="store_true", help="only the three fill models")
    parser.add_argument("--out", default="results/prestwood")
    parser.add_argument("--degree", type=int, choices=(1, 2), help="Lagrange degree of the FE cases "
                        "(default: the scene's)")
    parser.add_argument("--elements", type=int, help="elements through the ring of the FE cases (default: the "
                        "scene's)")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    scene = load_scene(args.scene)
    if args.degree:
        scene = dataclasses.replace(scene, mesh=dataclasses.replace(scene.mesh, degree=args.degree))
    if args.elements:
        scene = with_mesh(scene, args.elements)
    out = Path(args.out)
    try:
        with results_folder(out, comm) as work:  # checked before the study; replaces out when all is written
            rows = [lp_row(dataclasses.replace(scene, fill=None), "bare ring, fill removed (LP)"), lp_row(scene)]
            for label, case in variants(scene, not args.no_sensitivity).items():
                rows.append(fe_row(label, case, work, comm))
                if comm.rank == 0:
                    r = rows[-1]
                    print(f"{label}: {r['status']}, [{_num(r['lower_kN'], '.1f')}, {_num(r['upper_kN'], '.1f')}] "
                          f"kN ({r['seconds']:.0f} s)", flush=True)
            if comm.rank == 0:
                table = markdown(rows)
                (work / "prestwood.md").write_text(table + "\n")
                with open(work / "prestwood.csv", "w", newline="") as f:
                    w = csv.DictWriter(f, fieldnames=[k for k in rows[0] if k != "curve"], extrasaction="ignore")
                    w.writeheader()
                    w.writerows(rows)
                plot(rows, work / "prestwood.png")
    except OutputError as err:
        parser.error(str(err))
    if comm.rank == 0:
        print(table)
        print(f"results in {out}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
