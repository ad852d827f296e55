"""Probe the ring meshing for cases Gmsh cannot mesh: every shape, 4-256 voussoirs, 1-8 elements through the
thickness, a point load at a joint and at offsets from it (1e-7 to 0.3 voussoir lengths), joint_at_loads true and
false. Gmsh runs in a child process that works through the cases and records each before and after meshing it,
so an abort (SIGABRT) or a process out of memory (3 GiB cap) is reported as that case's failure and the probe
goes on with the next one.

    ./run python benchmarks/mesh_probe.py            # 2275 cases, about 15 min on 2 cores
    ./run python benchmarks/mesh_probe.py --quick    # 4-33 voussoirs, 1 and 4 elements (about 1 min)

Prints the number of cases, the failures grouped by message, and the slowest case.
"""
from __future__ import annotations

import argparse
import itertools
import json
import resource
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

SHAPES = {"semicircular": (10.0, 5.0), "segmental": (10.0, 2.5), "pointed": (10.0, 8.66),
          "elliptical": (10.0, 3.0), "parabolic": (10.0, 3.0)}
THICKNESS = 0.8  # m: t / span = 0.08
OFFSETS = (0.0, 1e-7, 1e-5, 1e-3, 0.02, 0.3)  # load offset from a joint's extrados corner, in voussoir lengths
MEMORY_CAP = 3 * 1024 ** 3  # bytes per child process


def cases(voussoirs, per_thickness) -> list[dict]:
    from bridgefem.geometry.ring import build_ring

    out = []
    for n, per, (shape, (span, rise)) in itertools.product(voussoirs, per_thickness, SHAPES.items()):
        corners = [j.extrados[0] for j in build_ring(shape, span, rise, THICKNESS, n).joints]
        k = max(1, n // 3)
        for joint_at_loads, offset in itertools.product((True, False), OFFSETS):
            x = corners[k] + offset * (corners[k + 1] - corners[k])
            out.append(dict(shape=shape, span=span, rise=rise, n=n, per=per, load_x=[x], jal=joint_at_loads,
                            offset=offset))
        out.append(dict(shape=shape, span=span, rise=rise, n=n, per=per, load_x=[], jal=True, offset=None))
    return out


def worker(case_file: str, start: int, log_file: str) -> None:
    """Mesh the cases from ``start`` on; one JSON line per case started and per case finished."""
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
    from bridgefem.fe.mesh import _gmsh_bridge
    from bridgefem.geometry.ring import build_ring

    todo = json.loads(Path(case_file).read_text())
    with open(log_file, "a") as log:
        for i in range(start, len(todo)):
            c = todo[i]
            log.write(json.dumps({"i": i, "start": True}) + "\n")
            log.flush()
            t0 = time.perf_counter()
            try:
                ring = build_ring(c["shape"], c["span"], c["rise"], THICKNESS, c["n"], c["load_x"], c["jal"])
                result = {"ok": True, "cells": len(_gmsh_bridge(ring, c["per"], None, 0.0).cells)}
            except Exception as err:  # a clear error is an outcome to report, not a probe failure
                result = {"ok": False, "error": f"{type(err).__name__}: {err}"}
            log.write(json.dumps({"i": i, "seconds": time.perf_counter() - t0, **result}) + "\n")
            log.flush()


def probe(todo: list[dict]) -> dict[int, dict]:
    results: dict[int, dict] = {}
    with tempfile.TemporaryDirectory(prefix="mesh_probe_") as tmp:
        case_file, log_file = Path(tmp) / "cases.json", Path(tmp) / "log.jsonl"
        case_file.write_text(json.dumps(todo))
        start = 0
        while start < len(todo):
            log_file.write_text("")
            run = subprocess.run([sys.executable, __file__, "--worker", str(case_file), str(start), str(log_file)],
                                 capture_output=True, text=True)
            started = None
            for line in log_file.read_text().splitlines():
                entry = json.loads(line)
                if entry.get("start"):
                    started = entry["i"]
                else:
                    results[entry["i"]] = entry
            if run.returncode == 0 or started is None:
                break
            results[started] = {"ok": False, "error": f"child process died (exit code {run.returncode})"}
            start = started + 1
    return results


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.worker:
        worker(args.worker[0], int(args.worker[1]), args.worker[2])
        return
    todo = cases((4, 7, 16, 33), (1, 4)) if args.quick else cases((4, 7, 16, 33, 64, 128, 256), (1, 2, 3, 4, 8))
    results = probe(todo)
    failed = {i: r for i, r in results.items() if not r["ok"]}
    print(f"{len(todo)} cases, {len(results) - len(failed)} meshed, {len(failed)} failed")
    for message, count in Counter(r["error"][:100] for r in failed.values()).most_common():
        print(f"  {count} x {message}")
    for i, r in sorted(failed.items())[:20]:
        c = todo[i]
        print(f"  {c['shape']} N={c['n']} per thickness {c['per']} joint_at_loads={c['jal']} offset {c['offset']}: "
              f"{r['error'][:120]}")
    slowest = max((i for i, r in results.items() if r["ok"]), key=lambda i: results[i]["seconds"], default=None)
    if slowest is not None:
        c = todo[slowest]
        print(f"slowest: {c['shape']} N={c['n']} per thickness {c['per']}: {results[slowest]['seconds']:.2f} s")


if __name__ == "__main__":
    main()
