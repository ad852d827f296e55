"""Cost of the fill: wall time, unknowns, linear solves and factorisations per limit load of the Prestwood bridge
(demos/prestwood.toml, its loading beam rigid) on each mesh, with the distance of each limit from the
extrapolated mesh-converged value (``bridgefem converge`` on P2, docs/fill.md).

A benchmark that prints figures, not a timed test. Each case is one :func:`bridgefem.analysis.convergence.solve_mesh`
(the whole analysis: meshing, assembly, self-weight, limit search) at the scene's bracket tolerance (the
fill preset's); the distance is to ``--reference`` (kN, default :data:`REFERENCE_KN`). The mesh of each
:data:`bridgefem.scene.schema.FILL_PRESETS` preset is marked. ``demos/speed_accuracy.py --fill`` prints the same table.

Run:

    ./run python benchmarks/fill_cost.py                      # P1 and P2 on t/2 and t/4 (a few minutes)
    ./run python benchmarks/fill_cost.py --cases P2-t8        # the cases whose name contains "P2-t8"
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
from pathlib import Path

from bridgefem.analysis.convergence import solve_mesh
from bridgefem.scene.model import with_mesh
from bridgefem.scene.reader import load_scene
from bridgefem.scene.schema import FILL_PRESETS

SCENE = Path(__file__).resolve().parents[1] / "demos/prestwood.toml"
CASES = {f"P{d}-t{n}": (d, n) for d in (1, 2) for n in (2, 4, 8)}
DEFAULT_CASES = ("P1-t2", "P1-t4", "P2-t2", "P2-t4")
REFERENCE_KN = 215.805  # Richardson extrapolation of P2 t/2, t/4, t/8 (docs/fill.md, section 3)


def preset_of(degree: int, elements: int) -> str:
    """The fill presets whose mesh this is ("" if none)."""
    return ", ".join(name for name, v in FILL_PRESETS.items()
                     if (v["mesh", "degree"], v["mesh", "elements_through_thickness"]) == (degree, elements))


def fill_table(names: list[str], reference: float | None = REFERENCE_KN) -> tuple[list[dict], list[str]]:
    """Run the named cases on Prestwood: their records (loads in kN) and the Markdown table's lines (printed as
    they come)."""
    base = load_scene(SCENE)
    lines = ["| mesh | fill preset | limit (kN) | status | unknowns | linear solves | factorisations | wall (s) | "
             "distance to L* |", "|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    rows = []
    for name in names:
        degree, n = CASES[name]
        scene = with_mesh(dataclasses.replace(base, mesh=dataclasses.replace(base.mesh, degree=degree)), n)
        m = solve_mesh(scene)
        upper = "none" if m.upper is None else f"{m.upper / 1e3:.1f}"
        distance = "-" if reference is None else f"{100 * (m.limit / 1e3 / reference - 1):+.1f} %"
        lines.append(f"| {name} | {preset_of(degree, n)} | [{m.lower / 1e3:.1f}, {upper}] | {m.status} | {m.dofs} | "
                     f"{m.solves} | {m.factorisations} | {m.seconds:.1f} | {distance} |")
        print(lines[-1], flush=True)
        rows.append({"mesh": name, "preset": preset_of(degree, n), "lower_kN": m.lower / 1e3,
                     "upper_kN": None if m.upper is None else m.upper / 1e3, "status": m.status, "unknowns": m.dofs,
                     "solves": m.solves, "factorisations": m.factorisations, "wall_s": m.seconds,
                     "reference_kN": reference})
    return rows, lines


def main(argv: list[str] | None = None) -> int:
    logging.getLogger().setLevel(logging.WARNING)
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", default="", help="run the cases whose name contains this (default: "
                        + ", ".join(DEFAULT_CASES) + ")")
    parser.add_argument("--reference", type=float, default=REFERENCE_KN, help="mesh-converged limit (kN)")
    args = parser.parse_args(argv)
    fill_table([n for n in CASES if args.cases in n] if args.cases else list(DEFAULT_CASES), args.reference)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
