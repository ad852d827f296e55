"""Cost of the fill: wall time, unknowns, linear solves and factorisations per limit load of the Prestwood bridge
(demos/prestwood.toml) on each mesh of the speed-accuracy map, with the distance of each limit from the
extrapolated mesh-converged value (``bridgefem converge`` on P2, docs/fill.md).

A benchmark that prints figures, not a timed test. Each case is one :func:`bridgefem.convergence.solve_mesh`
(the whole analysis: meshing, assembly, self-weight, limit search); the distance is to ``--reference`` (kN,
default the P2 extrapolation of docs/fill.md).

Run:

    ./run python benchmarks/fill_cost.py                      # P1 and P2 on t/2 and t/4 (a few minutes)
    ./run python benchmarks/fill_cost.py --cases P2-t8        # the cases whose name contains "P2-t8"
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
from pathlib import Path

from bridgefem.convergence import solve_mesh, with_mesh
from bridgefem.scene import load_scene

SCENE = Path(__file__).resolve().parents[1] / "demos/prestwood.toml"
CASES = {f"P{d}-t{n}": (d, n) for d in (1, 2) for n in (2, 4, 8)}
DEFAULT_CASES = ("P1-t2", "P1-t4", "P2-t2", "P2-t4")


def main(argv: list[str] | None = None) -> int:
    logging.getLogger().setLevel(logging.WARNING)
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", default="", help="run the cases whose name contains this (default: "
                        + ", ".join(DEFAULT_CASES) + ")")
    parser.add_argument("--reference", type=float, default=None, help="mesh-converged limit (kN)")
    args = parser.parse_args(argv)
    base = load_scene(SCENE)
    names = [n for n in CASES if args.cases in n] if args.cases else list(DEFAULT_CASES)
    print("| mesh | limit (kN) | status | unknowns | linear solves | factorisations | wall (s) | distance |")
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        degree, n = CASES[name]
        scene = with_mesh(dataclasses.replace(base, mesh=dataclasses.replace(base.mesh, degree=degree)), n)
        m = solve_mesh(scene)
        upper = "none" if m.upper is None else f"{m.upper / 1e3:.1f}"
        distance = "-" if args.reference is None else f"{100 * (m.limit / 1e3 / args.reference - 1):+.1f} %"
        print(f"| {name} | [{m.lower / 1e3:.1f}, {upper}] | {m.status} | {m.dofs} | {m.solves} | "
              f"{m.factorisations} | {m.seconds:.1f} | {distance} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
