"""Clarabel's two KKT factorisations side by side on the collapse-bound programmes (bridgefem.limit.bounds).

Every interior-point iteration of the static and kinematic programmes factorises one sparse quasi-definite KKT
system; Clarabel offers QDLDL (its default) and faer (supernodal). For each scene (and refinement factor of its
fill's mesh) the problem is built once, then each programme is solved with each factorisation, alternately,
``--rounds`` times on one thread, with the cap of the runs (``conic.MAX_ITERATIONS``). Printed per programme: the
triangles, the iterations, the fastest solve time with each factorisation, their ratio (qdldl / faer: below 1,
QDLDL is faster) and the relative difference of the load factors reached (the iterates agree up to rounding, which
can move a programme's iteration count by a few).
The factorisation the runs use is ``conic.FACTORISATION``.

Run:

    ./run python benchmarks/bounds_factorisation.py                      # Prestwood at refine 0.5, 1, 2; small bridge
    ./run python benchmarks/bounds_factorisation.py SCENE.toml ... --refine 1

A bridge of several spans under a Mohr-Coulomb fill from the campaign (spans seed 20261269 #21: three segmental
spans, 5139 triangles)::

    ./run python benchmarks/campaign.py --spans --seed 20261269 --count 100 --only 21 --check-only --out /tmp/sc
    ./run python benchmarks/bounds_factorisation.py /tmp/sc/scene_0021/scene.toml --refine 1
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from bridgefem.limit.bounds_lower import lower_bound
from bridgefem.limit.bounds_model import bridge_problem
from bridgefem.limit.bounds_upper import upper_bound
from bridgefem.limit.conic import FACTORISATION, FACTORISATIONS
from bridgefem.scene.reader import load_scene

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENES = (ROOT / "demos" / "prestwood.toml", ROOT / "demos" / "small_bridge.toml")
PROGRAMMES = {"static": lambda problem, f: lower_bound(problem, factorisation=f),
              "kinematic": lambda problem, f: upper_bound(problem, f)}


def compare(problem, rounds: int) -> dict:
    """Per programme: iterations, fastest seconds per factorisation and the load factors reached."""
    out = {}
    for name, solve in PROGRAMMES.items():
        seconds = {f: [] for f in FACTORISATIONS}
        factors, iterations, status = {}, {}, {}
        for _ in range(rounds):
            for f in FACTORISATIONS:
                start = time.perf_counter()
                sol, layout = solve(problem, f)
                seconds[f].append(time.perf_counter() - start)
                iterations[f], status[f] = sol.iterations, sol.status
                factors[f] = None if sol.x is None else float(sol.x[layout["factor"]])
        out[name] = {"seconds": {f: min(s) for f, s in seconds.items()}, "factors": factors,
                     "iterations": iterations, "status": status}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", type=Path, default=list(DEFAULT_SCENES))
    ap.add_argument("--refine", type=float, nargs="+", default=[0.5, 1.0, 2.0])
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    a, b = FACTORISATIONS
    print(f"runs use {FACTORISATION}; ratio = {a} / {b} (fastest of {args.rounds} rounds, one thread)\n")
    print(f"| scene | refine | triangles | programme | iterations | {a} s | {b} s | ratio | load factor difference |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in args.scenes:
        scene = load_scene(path)
        for refine in args.refine:
            problem = bridge_problem(scene, refine)
            for name, r in compare(problem, args.rounds).items():
                fa, fb = r["factors"][a], r["factors"][b]
                diff = abs(fa - fb) / abs(fb) if fa is not None and fb else float("nan")
                print(f"| {path.parent.name}/{path.name} | {refine:g} | {problem.mesh.n_triangles} | {name} | "
                      f"{r['iterations'][a]} / {r['iterations'][b]} ({r['status'][a]}) | {r['seconds'][a]:.2f} | "
                      f"{r['seconds'][b]:.2f} | {r['seconds'][a] / r['seconds'][b]:.2f} | {diff:.1e} |", flush=True)


if __name__ == "__main__":
    main()
