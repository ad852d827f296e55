"""Mesh convergence of the limit load: the same scene on successively halved meshes, the observed order of
convergence and the Richardson-extrapolated limit with its uncertainty (``bridgefem converge SCENE.toml``).

The meshes double ``[mesh] elements_through_thickness`` (n, 2n, 4n, ...): every element size of the ring and the
fill (its sizes are multiples of the ring's, :mod:`bridgefem.fe.mesh`) halves, so the refinement ratio is r = 2. The
limit of a mesh is the midpoint of its bracket. With the three finest limits L1 (coarse), L2, L3 (fine):

- observed order ``p = ln((L1 - L2) / (L2 - L3)) / ln r`` (monotone convergence: the ratio is positive);
- Richardson extrapolation ``L* = L3 + (L3 - L2) / (r^p - 1)`` (Richardson 1911);
- uncertainty of L3 and of L* ``U = 1.25 |L* - L3|``: the grid convergence index of Roache (1994) with its
  safety factor for three meshes, plus the half widths of the brackets.

Without monotone convergence (the differences change sign, or do not shrink) no order is defined: L* is L3 and U
the largest difference between the three, so the study says it has not converged instead of extrapolating. A mesh
of the three that ended without a bracket (a solver failure: its last converged load is no limit) leaves the study
without extrapolation.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from math import log

from ..scene.model import Scene, with_mesh

RATIO = 2.0  # element size ratio between successive meshes
SAFETY = 1.25  # Roache's factor of safety for three meshes


@dataclass(frozen=True)
class MeshLimit:
    """One mesh of the study: ``elements_through_thickness``, the bracket (N; upper None if not closed), the
    search's status, unknowns, linear solves and factorisations, wall time (s) of the whole analysis."""

    elements_through_thickness: int
    lower: float
    upper: float | None
    status: str
    dofs: int
    solves: int
    factorisations: int
    seconds: float

    @property
    def limit(self) -> float:
        """Midpoint of the bracket (N); the last converged load when the bracket is not closed."""
        return self.lower if self.upper is None else 0.5 * (self.lower + self.upper)


@dataclass(frozen=True)
class Extrapolation:
    """Observed order (None without monotone convergence), extrapolated limit and its uncertainty (N)."""

    order: float | None
    value: float
    uncertainty: float

    def error_of(self, limit: float) -> float:
        """Relative distance of a limit (N) from the extrapolated value."""
        return abs(limit - self.value) / self.value


def richardson(limits: list[float], half_widths: list[float] | None = None) -> Extrapolation:
    """Extrapolation from the three finest of ``limits`` (coarse to fine, N) on meshes refined by :data:`RATIO`
    (module docstring); ``half_widths`` (N) of their brackets widen the uncertainty."""
    if len(limits) < 3:
        raise ValueError(f"need at least 3 meshes, got {len(limits)}")
    l1, l2, l3 = limits[-3:]
    spread = max(half_widths[-3:]) if half_widths else 0.0
    d12, d23 = l1 - l2, l2 - l3
    if d23 == 0.0:
        return Extrapolation(None, l3, spread)
    if d12 / d23 <= 1.0:  # differences of opposite sign or not shrinking: not in the asymptotic range
        return Extrapolation(None, l3, max(abs(d12), abs(d23), abs(l1 - l3)) + spread)
    order = log(d12 / d23) / log(RATIO)
    value = l3 - d23 / (RATIO ** order - 1.0)
    return Extrapolation(order, value, SAFETY * abs(value - l3) + spread)


def solve_mesh(scene: Scene, comm=None, report=None) -> MeshLimit:
    """Run the analysis of ``scene`` and summarise it as a :class:`MeshLimit` (loads in N for the full width)."""
    from mpi4py import MPI

    from .runner import run_analysis

    comm = comm or MPI.COMM_WORLD
    t = time.perf_counter()
    an = run_analysis(scene, comm, report=report or (lambda s: None), max_refinements=0)  # each level as asked
    seconds = time.perf_counter() - t
    total = an.load_total
    s = an.search
    stats = an.solver.stats
    return MeshLimit(scene.mesh.elements_through_thickness, s.lower * total,
                     None if s.upper is None else s.upper * total, s.status, an.n_dofs, stats["solves"],
                     stats["factorisations"], seconds)


def check_levels(levels: list[int]) -> None:
    """Raise ValueError unless ``levels`` are >= 3 mesh levels, each :data:`RATIO` x the previous."""
    if len(levels) < 3 or levels[0] < 1 or any(b != RATIO * a for a, b in zip(levels, levels[1:])):
        raise ValueError(f"levels must be 3 or more integers >= 1, each {RATIO:g} x the previous (e.g. 2,4,8), "
                         f"got {levels}")


def study(scene: Scene, levels: list[int], comm=None, progress=None
          ) -> tuple[list[MeshLimit], Extrapolation | None]:
    """Solve the scene on each mesh of ``levels`` (elements through the thickness, each twice the previous) and
    extrapolate (:func:`richardson`; None when one of the three finest has no bracket)."""
    check_levels(levels)
    meshes = []
    for n in levels:
        meshes.append(solve_mesh(with_mesh(scene, n), comm))
        if progress is not None:
            progress(meshes[-1])
    if any(m.upper is None for m in meshes[-3:]):
        return meshes, None
    return meshes, richardson([m.limit for m in meshes], [0.5 * (m.upper - m.lower) for m in meshes])


def table(scene: Scene, meshes: list[MeshLimit], ex: Extrapolation | None) -> str:
    """The study as a Markdown table (kN) with the extrapolation below it (or why there is none)."""
    rows = ["| elements through the ring | limit (kN) | status | unknowns | solves | factorisations | wall (s) "
            "| distance to L* |", "|---|---|---|---|---|---|---|---|"]
    for m in meshes:
        bracket = f"[{m.lower / 1e3:.1f}, {m.upper / 1e3:.1f}]" if m.upper is not None else \
            f"last converged {m.lower / 1e3:.1f}"
        rows.append(f"| {m.elements_through_thickness} (P{scene.mesh.degree}) | {bracket} | {m.status} | {m.dofs} "
                    f"| {m.solves} | {m.factorisations} | {m.seconds:.1f} | "
                    f"{'-' if ex is None else f'{100 * ex.error_of(m.limit):.1f} %'} |")
    if ex is None:
        failed = ", ".join(f"t/{m.elements_through_thickness}" for m in meshes[-3:] if m.upper is None)
        rows.append(f"\nno extrapolation: {failed} ended without a bracket (its last converged load is no limit)")
        return "\n".join(rows)
    order = "none (not converging monotonically)" if ex.order is None else f"{ex.order:.2f}"
    rows.append(f"\nobserved order {order}; extrapolated limit L* = {ex.value / 1e3:.1f} +- "
                f"{ex.uncertainty / 1e3:.1f} kN")
    return "\n".join(rows)


