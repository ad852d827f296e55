"""Sizes and times of the collapse-bound programmes (bridgefem.limit.bounds) per mesh, and their brackets.

For the Prestwood bridge (demos/prestwood.toml, the TRRL test: 228 kN; its load through a rigid loading beam,
``[fill] loading_beam``) at mesh refinement factors 0.5, 1 (the default: element size ring thickness / 2 near the
extrados) and 2, and for Prandtl's strip footing (weightless soil, phi = 20 deg, c = 1 Pa; exact N_c = 14.83, the
same for a flexible pressure and a rigid rough footing, the loading beam) at element sizes B/5, B/10, B/20 near its
edges:
triangles, unknowns, equalities, inequalities, second-order cones, interior-point iterations and seconds of each
programme, the lower and upper bounds and their gap. Target: Prestwood's bounds at the default mesh within 10 s
on 2 cores (printed as the ratio time / 10 s; wall time, so a loaded machine inflates it).

Run:

    ./run python benchmarks/bounds_size.py                 # both studies, about 4 min on a quiet machine
    ./run python benchmarks/bounds_size.py --refine 0.5 1  # Prestwood meshes only these
    ./run python benchmarks/bounds_size.py --no-footing
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

from bridgefem.limit.bounds import collapse_bounds, problem_bounds
from bridgefem.limit.bounds_model import Soil, strip_footing_problem
from bridgefem.scene.reader import load_scene

ROOT = Path(__file__).resolve().parents[1]
TARGET_SECONDS = 10.0
TEST_LOAD = 228e3  # N, Prestwood's collapse load in the TRRL test (Page 1987)


def _row(label, b, unit: float) -> str:
    lo, up = b.lower, b.upper
    gap = (up.load - lo.load) / up.load if lo.load is not None and up.load is not None else math.nan
    s = lo.sizes
    return (f"| {label} | {b.mesh['triangles']} | {s['unknowns']} | {s['equalities']} / {up.sizes['equalities']} | "
            f"{s['inequalities']} | {s['cones']} | {lo.iterations} / {up.iterations} | "
            f"{lo.seconds:.2f} / {up.seconds:.2f} | {_value(lo, unit)} | {_value(up, unit)} | {100 * gap:.1f} % |")


def _value(bound, unit: float) -> str:
    mark = "" if bound.status == "optimal" else f" ({bound.status})"
    return "none" if bound.load is None else f"{bound.load / unit:.2f}{mark}"


HEADER = ("| mesh | triangles | unknowns | equalities (lower / upper) | inequalities | cones | iterations (lower / "
          "upper) | solve s (lower / upper) | lower | upper | gap |\n|---|---|---|---|---|---|---|---|---|---|---|")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", type=float, nargs="+", default=[0.5, 1.0, 2.0])
    ap.add_argument("--no-footing", action="store_true")
    args = ap.parse_args()
    scene = load_scene(ROOT / "demos" / "prestwood.toml")
    print(f"Prestwood (kN; test {TEST_LOAD / 1e3:.0f} kN)\n\n{HEADER}")
    for r in args.refine:
        start = time.perf_counter()
        b = collapse_bounds(scene, r)
        wall = time.perf_counter() - start
        print(_row(f"refine {r:g} (size {b.mesh['size']:.3g} m)", b, 1e3), flush=True)
        if r == 1.0:
            print(f"\ndefault mesh: {wall:.2f} s in all (mesh {b.timings['mesh']:.2f} s), ratio to the "
                  f"{TARGET_SECONDS:g} s target {wall / TARGET_SECONDS:.2f}\n")
    if args.no_footing:
        return
    phi = 20.0
    t = math.tan(math.radians(phi))
    nc = (math.exp(math.pi * t) * math.tan(math.radians(45 + phi / 2)) ** 2 - 1) / t
    for rough, name in ((None, "flexible pressure"), (True, "rigid rough footing (the loading beam)")):
        print(f"\nPrandtl strip footing, {name}, phi = {phi:g} deg (N_c; exact {nc:.3f})\n\n{HEADER}")
        for size in (0.2, 0.1, 0.05):
            b = problem_bounds(strip_footing_problem(Soil(1.0, phi, 0.0), 1.0, 3.0, 1.5, size, rough=rough))
            b.mesh["size"] = size
            print(_row(f"size B/{1 / size:g}", b, 1.0), flush=True)


if __name__ == "__main__":
    main()
