"""Mesh convergence of the fill model's N_gamma: a rigid rough (or smooth) strip footing on a cohesionless soil with
weight, phi = 30 deg, against Martin's (2005) method-of-characteristics value (rough 14.75, smooth 7.65,
bridgefem.fe.footing.MARTIN_N_GAMMA), by :func:`bridgefem.fe.footing.cohesionless_n_gamma` (two vanishing cohesions
on the smoothed cone, extrapolated to c = 0) on the graded P2 meshes of :func:`bridgefem.fe.footing.strip_footing`.

What it measures, per cells per side: N(c), N(c/2), the extrapolated N(0) and its ratio to Martin's value, the
Newton iterations, the largest plateau of the two load-settlement curves and the wall time; then, over successive
halvings of the cell size, the ratio of the distances to Martin's value (the claim: halving the cells at least
halves the distance, a displacement method converging from above to the published value, not to a value of its
own), the observed order and, with three meshes, the Richardson value L* = L3 + (L3 - L2) / (2^p - 1). docs/fill.md,
section 1 ("N_gamma"), has the measured table; tests/test_footing.py checks the coarsest mesh against Martin's value
with its measured error.

Writes DIR/footing_convergence.md and .csv (default results/footing_convergence); exits with 1 when a halving of
the cells does not halve the distance to Martin's value.

Run:

    ./run python benchmarks/footing_convergence.py                    # rough, 8 and 16 cells (about 1 min idle)
    ./run python benchmarks/footing_convergence.py --cells 8 16 32    # with 32 cells (about 2 x 11 min loaded)
    ./run python benchmarks/footing_convergence.py --smooth --out /tmp/fc
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import machine_line, write_outputs  # noqa: E402

from bridgefem.fe.footing import MARTIN_N_GAMMA, cohesionless_n_gamma  # noqa: E402

PHI = 30.0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cells", type=int, nargs="+", default=[8, 16], help="cells per side, each twice the last")
    p.add_argument("--smooth", action="store_true", help="a smooth base (default: rough)")
    p.add_argument("--settlement", type=float, default=0.2, help="settlement, in units of B (default 0.2)")
    p.add_argument("--steps", type=int, default=40, help="increments to it (default 40)")
    p.add_argument("--out", type=Path, default=Path("results/footing_convergence"))
    args = p.parse_args(argv)
    rough = not args.smooth
    exact = MARTIN_N_GAMMA[PHI][0 if rough else 1]
    rows = []
    for cells in args.cells:
        start = time.perf_counter()
        n0, (full, half) = cohesionless_n_gamma(PHI, rough, cells, settlement=args.settlement, steps=args.steps)
        rows.append({"cells": cells, "n_c": full.limit, "n_c_half": half.limit, "n_0": n0, "ratio": n0 / exact,
                     "newton": full.newton + half.newton, "plateau": max(full.plateau, half.plateau),
                     "wall_s": time.perf_counter() - start})
        print(f"{cells} cells: N(0) = {n0:.3f} ({n0 / exact:.3f} x Martin)", flush=True)
    lines = [f"# N_gamma of a {'rough' if rough else 'smooth'} strip footing, phi = {PHI:g} deg, against Martin "
             f"(2005): {exact}\n", f"Settlement {args.settlement:g} B in {args.steps} steps. {machine_line()}\n",
             "| cells per side | N(c) | N(c/2) | N(0) | N(0) / Martin | Newton | plateau | wall (s) |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['cells']} | {r['n_c']:.2f} | {r['n_c_half']:.2f} | {r['n_0']:.2f} | {r['ratio']:.3f} | "
              f"{r['newton']} | {r['plateau']:.4f} | {r['wall_s']:.0f} |" for r in rows]
    lines.append("")
    for a, b in zip(rows, rows[1:]):
        shrink = abs(b["n_0"] - exact) / abs(a["n_0"] - exact)
        verdict = "at least halves" if shrink <= 0.5 else "does NOT halve"
        lines.append(f"- {a['cells']} -> {b['cells']} cells: distance to Martin x {shrink:.3f} ({verdict}; "
                     f"observed order {-math.log2(shrink):.2f})")
    if len(rows) >= 3:
        l1, l2, l3 = (r["n_0"] for r in rows[-3:])
        if (l2 - l3) * (l1 - l2) > 0:
            order = math.log2((l1 - l2) / (l2 - l3))
            star = l3 + (l3 - l2) / (2 ** order - 1)
            lines.append(f"- Richardson ({rows[-3]['cells']}-{rows[-2]['cells']}-{rows[-1]['cells']}): order "
                         f"{order:.2f}, L* = {star:.2f} +- {1.25 * abs(star - l3):.2f} ({star / exact:.3f} x Martin)")
    write_outputs(args.out, "footing_convergence", rows, "\n".join(lines) + "\n")
    halves = all(abs(b["n_0"] - exact) <= 0.5 * abs(a["n_0"] - exact) for a, b in zip(rows, rows[1:]))
    return 0 if halves else 1


if __name__ == "__main__":
    raise SystemExit(main())
