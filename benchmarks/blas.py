"""The BLAS under MUMPS, PETSc and numpy: Debian's reference BLAS/LAPACK (netlib) against OpenBLAS (serial), side by
side in one run, on the same limit analyses.

Debian chooses the ``libblas.so.3`` and ``liblapack.so.3`` every program loads through its alternatives; ``./run``
installs ``libopenblas0-serial``, whose alternatives outrank netlib's. This study loads each library explicitly
(``LD_LIBRARY_PATH`` at its folder, which the dynamic loader searches before the alternatives' links), so both are
measured on the same machine whatever the alternatives point to:

1. the scene: demos/bare_arch.toml at ``--sizes`` elements through the thickness (a mesh from about 1k to 100k
   unknowns);
2. per size, a warm-up run with each library (the JIT cache, the file cache), then ``--repeat`` pairs of fresh
   ``bridgefem run --json`` processes, the order alternating; per run the phases of results.json ``timings``;
3. the ratio netlib / OpenBLAS of the limit search (the factorisations and solves) and of the whole command's wall
   time, the median of the pairs, and whether both libraries give the same bracket (to 1e-9 relative).

OpenBLAS's serial build uses one thread, so two MPI ranks on two cores do not compete with BLAS threads. Run:

    ./run python benchmarks/blas.py                       # sizes 4, 16, 48; 3 pairs each (about 3 min)
    ./run python benchmarks/blas.py --sizes 8 --repeat 5

Writes DIR/blas.md and .csv (default results/blas).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import machine_line, timed, write_outputs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LIB = Path("/usr/lib/x86_64-linux-gnu")
LIBRARIES = {"netlib": (LIB / "blas", LIB / "lapack"), "OpenBLAS": (LIB / "openblas-serial",)}
"""Each BLAS's folders (``libblas.so.3``, ``liblapack.so.3``) as Debian 12 installs them."""
SAME = 1e-9  # relative difference of two brackets that counts as the same answer


def run(library: str, scene: Path) -> dict:
    """One ``bridgefem run`` in a fresh process with ``library`` loaded: its wall time (s), phases and bracket."""
    env = {**os.environ, "LD_LIBRARY_PATH": ":".join(str(p) for p in LIBRARIES[library])}
    with tempfile.TemporaryDirectory() as tmp:
        wall, _, _ = timed([sys.executable, "-m", "bridgefem", "run", str(scene), "--out", f"{tmp}/out", "--json"],
                           env)
        data = json.loads((Path(tmp) / "out" / "results.json").read_text())
    lim = data["limit_load"]
    return {"wall": wall, "search": data["timings"]["limit search"], "dofs": data["model"]["dofs"],
            "bracket": (lim["lower"], lim["upper"])}


def loaded(library: str) -> str:
    """The BLAS file numpy's process maps with ``library`` chosen (a check that the choice takes effect)."""
    env = {**os.environ, "LD_LIBRARY_PATH": ":".join(str(p) for p in LIBRARIES[library])}
    probe = ("import numpy; print([l.split()[-1] for l in open('/proc/self/maps')"
             " if 'libblas' in l or 'libopenblas' in l][0])")
    return subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env,
                          check=True).stdout.strip()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[4, 16, 48], help="elements through the thickness")
    p.add_argument("--repeat", type=int, default=3, help="alternating pairs per size")
    p.add_argument("--out", type=Path, default=ROOT / "results" / "blas")
    args = p.parse_args()
    missing = [str(d) for dirs in LIBRARIES.values() for d in dirs if not (d / "libblas.so.3").exists()
               and not (d / "liblapack.so.3").exists()]
    if missing:
        sys.exit(f"blas.py: no BLAS/LAPACK in {missing} (./run installs libopenblas0-serial)")
    maps = {lib: loaded(lib) for lib in LIBRARIES}
    base = (ROOT / "demos" / "bare_arch.toml").read_text()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for ett in args.sizes:
            scene = Path(tmp) / f"ett{ett}.toml"
            scene.write_text(base + f"\n[mesh]\nelements_through_thickness = {ett}\n")
            for lib in LIBRARIES:
                run(lib, scene)  # warm-up
            pairs = []
            for k in range(args.repeat):
                order = list(LIBRARIES) if k % 2 == 0 else list(reversed(LIBRARIES))
                pairs.append({lib: run(lib, scene) for lib in order})
            a, b = (statistics.median(pp[lib]["search"] for pp in pairs) for lib in LIBRARIES)
            wa, wb = (statistics.median(pp[lib]["wall"] for pp in pairs) for lib in LIBRARIES)
            same = all(abs(x - y) <= SAME * abs(x) for pp in pairs for x, y in
                       zip(pp["netlib"]["bracket"], pp["OpenBLAS"]["bracket"]))
            rows.append({"elements_through_thickness": ett, "dofs": pairs[0]["netlib"]["dofs"],
                         "search_netlib_s": a, "search_openblas_s": b, "search_ratio": a / b,
                         "wall_netlib_s": wa, "wall_openblas_s": wb, "wall_ratio": wa / wb, "same_bracket": same})
            print(f"{ett} elements: search {a:.3f} / {b:.3f} s = {a / b:.2f}x; whole run {wa:.2f} / {wb:.2f} s; "
                  f"same bracket: {same}", flush=True)
    lines = ["# BLAS under MUMPS, PETSc and numpy: netlib against OpenBLAS (serial)", "",
             f"{machine_line()}; {args.repeat} alternating pairs per size, medians; libraries as loaded: "
             + ", ".join(f"{lib} {m}" for lib, m in maps.items()) + ".", "",
             "| elements through the thickness | unknowns | limit search, netlib / OpenBLAS (s) | ratio | "
             "whole run, netlib / OpenBLAS (s) | ratio | same bracket |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['elements_through_thickness']} | {r['dofs']} | {r['search_netlib_s']:.3f} / "
              f"{r['search_openblas_s']:.3f} | **{r['search_ratio']:.2f}** | {r['wall_netlib_s']:.2f} / "
              f"{r['wall_openblas_s']:.2f} | {r['wall_ratio']:.2f} | {'yes' if r['same_bracket'] else 'NO'} |"
              for r in rows]
    write_outputs(args.out, "blas", rows, "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
