"""PNG of the collapse bounds (``bridgefem bounds --plot``): the upper bound's mechanism (voussoirs moved by their
velocities, the fill shaded by its speed) over the lower bound's stress field (the fill's major compressive principal
stress per triangle, in kPa, compression negative). Lengths in m, loads in kN; the mechanism's displacements are
scaled so that the largest voussoir moves ``amplitude`` x the span."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.tri import Triangulation

from ..limit.bounds import Bounds
from ..scene.model import Scene
from ..structure.ring import scene_ring
from .plots import plt  # matplotlib with its own defaults and the Agg backend


def plot_bounds(scene: Scene, b: Bounds, path: Path, amplitude: float = 0.05) -> None:
    """Write the PNG: top, the mechanism with the largest voussoir displacement ``amplitude`` x span; bottom, the
    lower bound's stress field (kPa, compression negative). Needs a fill and both bounds."""
    ring = scene_ring(scene)
    mesh = b.problem.mesh
    tri = Triangulation(mesh.x[:, 0], mesh.x[:, 1], mesh.triangles)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True)
    if b.block_velocities is not None:
        v = b.block_velocities
        ref = b.problem.blocks.ref
        polys = [blk.polygon for blk in ring.blocks]
        moves = [np.column_stack([v[k, 0] - v[k, 2] * (p[:, 1] - ref[k, 1]), v[k, 1] + v[k, 2] * (p[:, 0] - ref[k, 0])])
                 for k, p in enumerate(polys)]
        scale = amplitude * scene.arch.span / max(max(np.abs(m).max() for m in moves), 1e-300)
        speed = np.linalg.norm(b.soil_velocities[:len(mesh.x)], axis=1) * scale
        shade = top.tripcolor(tri, speed, shading="gouraud", cmap="viridis")
        fig.colorbar(shade, ax=top, label="fill displacement (m, scaled)")
        for p, m in zip(polys, moves):
            top.fill(*p.T, facecolor="none", edgecolor="0.6", lw=0.5)
            top.fill(*(p + scale * m).T, facecolor="tan", edgecolor="k", lw=0.6, alpha=0.9)
    top.set_title(f"{scene.name}: upper bound {_kn(b.upper.load)} (mechanism, displacements scaled)")
    if b.stress is not None:
        s = b.stress.mean(axis=1)
        centre, radius = 0.5 * (s[:, 0] + s[:, 1]), np.hypot(0.5 * (s[:, 0] - s[:, 1]), s[:, 2])
        shade = bottom.tripcolor(tri, facecolors=(centre - radius) / 1e3, cmap="magma")
        fig.colorbar(shade, ax=bottom, label="major compressive stress (kPa)")
    for blk in ring.blocks:
        bottom.fill(*blk.polygon.T, facecolor="0.85", edgecolor="k", lw=0.4)
    bottom.set_title(f"lower bound {_kn(b.lower.load)} (statically admissible stress field, triangle means)")
    for ax in (top, bottom):
        ax.set_aspect("equal")
        ax.set_ylabel("y (m)")
    bottom.set_xlabel("x (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _kn(load: float | None) -> str:
    return "none" if load is None else f"{load / 1e3:.1f} kN"
