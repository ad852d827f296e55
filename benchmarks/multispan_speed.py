"""The cost of a bridge of several spans against its spans run alone: issue #42's target, a three-span bridge's limit
analysis within 4 x the time of its three spans run alone.

1. The bridge (``--scene``, default demos/three_span.toml) and each of its spans alone on rigid springings (its
   ``[[span]]`` table as the ``[arch]`` of a scene of its own), under the bridge's loads moved onto that span at
   the same distance from its left springing as from the left springing of the span they stand on.
2. A warm-up of each (the forms' JIT cache), then ``--repeat`` rounds, the bridge and the spans taking turns, each
   a whole limit analysis in this process (:func:`bridgefem.analysis.runner.run_analysis`: mesh, LP, assembly,
   search, checks; not the interpreter's start, which a command pays once whatever it computes).
3. Per round: the bridge's wall time, the spans' summed, their ratio; the median ratio is quoted, with each run's
   bracket and linear solves.

Run (about a minute):

    ./run python benchmarks/multispan_speed.py
    ./run python benchmarks/multispan_speed.py --scene demos/three_span.toml --repeat 5

Writes DIR/multispan_speed.md and .csv (default results/multispan_speed). Target: ratio <= 4.
"""
from __future__ import annotations

import argparse
import copy
import statistics
import sys
import time
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import machine_line, write_outputs  # noqa: E402

from bridgefem.analysis.runner import run_analysis  # noqa: E402
from bridgefem.scene.reader import load_scene, scene_from_dict  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TARGET = 4.0  # the bridge / its spans alone


def spans_alone(path: Path) -> list:
    """Each span of the bridge at ``path`` as a scene of its own (step 1 of the module docstring)."""
    bridge = load_scene(path)
    doc = bridge.document
    out = []
    for k, (left, _) in enumerate(bridge.span_ranges()):
        d = copy.deepcopy({key: v for key, v in doc.items() if key not in ("span", "pier")})
        d["arch"] = copy.deepcopy(doc["span"][k])
        loads = []
        for ld in bridge.loads:
            lo, hi = ld.x_range(bridge.arch.span)
            on = next(j for j, (a, b) in enumerate(bridge.span_ranges()) if a <= (lo + hi) / 2 <= b)
            offset = (lo + hi) / 2 - bridge.span_ranges()[on][0]
            table = {"kind": ld.kind, "x": offset, "factor": ld.factor}
            if ld.kind == "patch":
                table["length"] = ld.length
            loads.append(table)
        d["load"] = loads
        d.setdefault("scene", {})["name"] = f"{bridge.name}_span{k + 1}"
        out.append(scene_from_dict(d))
    return out


def timed_analysis(scene) -> tuple[float, object]:
    start = time.perf_counter()
    an = run_analysis(scene, MPI.COMM_WORLD)
    return time.perf_counter() - start, an


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", type=Path, default=ROOT / "demos" / "three_span.toml")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--out", type=Path, default=ROOT / "results" / "multispan_speed")
    args = p.parse_args()
    bridge, alone = load_scene(args.scene), spans_alone(args.scene)
    for scene in [bridge, *alone]:
        timed_analysis(scene)  # warm-up
    rows = []
    for r in range(args.repeat):
        t_bridge, an = timed_analysis(bridge)
        parts = [timed_analysis(s) for s in alone]
        t_alone = sum(t for t, _ in parts)
        rows.append({"round": r + 1, "bridge_s": round(t_bridge, 3), "spans_alone_s": round(t_alone, 3),
                     "ratio": round(t_bridge / t_alone, 3), "bridge_solves": an.solver.stats["solves"],
                     "spans_solves": sum(a.solver.stats["solves"] for _, a in parts)})
        print(rows[-1], flush=True)
    ratio = statistics.median(row["ratio"] for row in rows)
    brackets = [f"{a.scene.name}: [{a.search.lower * a.load_total / 1e3:.3f}, "
                f"{a.search.upper * a.load_total / 1e3:.3f}] kN" if a.search.upper is not None
                else f"{a.scene.name}: {a.search.status}" for a in [an, *(a for _, a in parts)]]
    text = "\n".join([f"# {args.scene.name}: the bridge against its {len(alone)} spans alone", "", machine_line(), "",
                      f"median ratio bridge / spans alone: {ratio:.2f} (target <= {TARGET:g}: "
                      f"{'met' if ratio <= TARGET else 'not met'})", "", *brackets])
    write_outputs(args.out, "multispan_speed", rows, text)


if __name__ == "__main__":
    main()
