"""The commands that print a study rather than run one analysis: ``bridgefem converge`` (the limit load on nested
meshes, :mod:`bridgefem.analysis.convergence`) and ``bridgefem bounds`` (the conic lower and upper collapse bounds,
:mod:`bridgefem.limit.bounds`). The command line (:mod:`bridgefem.io.cli`) parses the arguments and maps errors to
exit codes; these print (rank 0), write what they write under the output policy (:mod:`bridgefem.io.output`) and
return the exit code: 0 computed, 1 a solver failure. Loads printed in kN, written in N.
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import math
from pathlib import Path

from ..analysis.convergence import RATIO, MeshLimit, study, table
from ..limit.bounds import bounds_summary, collapse_bounds
from ..scene.keys import SceneError
from ..scene.model import Scene
from ..status import Status
from .output import results_folder


def converge_command(scene: Scene, levels: list[int], out: Path | None) -> int:
    """``bridgefem converge``: print the study and write ``convergence.json`` into the results folder ``out`` (under
    the output policy of :mod:`bridgefem.io.output`: a new folder or an earlier bridgefem results folder)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD

    def progress(m: MeshLimit) -> None:
        if comm.rank == 0:
            upper = "none" if m.upper is None else f"{m.upper / 1e3:.2f}"
            print(f"t/{m.elements_through_thickness}: [{m.lower / 1e3:.2f}, {upper}] kN, {m.status}, "
                  f"{m.seconds:.1f} s", flush=True)

    with results_folder(out, comm) if out is not None else contextlib.nullcontext() as folder:
        meshes, ex = study(scene, levels, comm, progress)  # the output folder is checked and locked before it
        if comm.rank == 0:
            print(table(scene, meshes, ex))
            if folder is not None:
                data = {"scene": scene.name, "degree": scene.mesh.degree, "unit": "N", "ratio": RATIO,
                        "meshes": [dataclasses.asdict(m) for m in meshes],
                        "extrapolation": None if ex is None else dataclasses.asdict(ex)}
                (folder / "convergence.json").write_text(json.dumps(data, indent=2))
    return 0 if all(m.upper is not None for m in meshes) else 1


def bounds_command(scene: Scene, as_json: bool, refine: float = 1.0, plot: Path | None = None) -> int:
    """``bridgefem bounds``: print the bounds (text or one JSON object), optionally write the mechanism and the
    stress field to the PNG ``plot`` (a scene with a fill); exit code 1 on a solver failure."""
    if not refine > 0 or not math.isfinite(refine):
        raise SceneError(f"--refine {refine!r}: allowed is a positive number (mesh refinement factor)")
    if plot is not None and scene.fill is None:
        raise SceneError(f"--plot {plot}: the plot shows the fill's mechanism and stresses; this scene has no fill "
                         "(use bridgefem run for a bare arch's mechanism)")
    if plot is not None and (plot.exists() or plot.is_symlink()):
        raise SceneError(f"--plot {plot}: the file exists; bridgefem never overwrites a file it did not create "
                         "(give a new file name)")
    b = collapse_bounds(scene, refine)
    data = bounds_summary(b)
    if plot is not None:
        from .bounds_plot import plot_bounds

        plot_bounds(scene, b, plot)
    if as_json:
        print(json.dumps(data))
    else:
        def kn(x):
            return "none" if x.load is None else f"{x.load / 1e3:.2f} kN"
        mesh = "no fill" if b.mesh is None else f"{b.mesh['triangles']} fill triangles, size {b.mesh['size']:.3g} m"
        print(f"{scene.name}: collapse load in [{kn(b.lower)}, {kn(b.upper)}] "
              f"(lower: {b.lower.status}, upper: {b.upper.status}; {mesh}; {b.timings['total']:.2f} s)")
        if data["mechanism"]:
            mech = data["mechanism"]
            separated = f", separated ring interfaces {mech['separated']}" if mech["separated"] else ""
            print(f"  upper-bound mechanism: hinges at joints {mech['hinges']}, sliding joints {mech['sliding']}"
                  f"{separated}")
        for name, x in (("lower", b.lower), ("upper", b.upper)):
            s = x.sizes
            print(f"  {name}: {s['unknowns']} unknowns, {s['equalities']} equalities, {s['inequalities']} "
                  f"inequalities, {s['cones']} cones; {x.iterations} iterations, {x.seconds:.2f} s")
    return 1 if any(x.status.startswith(Status.FAILURE) for x in (b.lower, b.upper)) else 0  # conic statuses
