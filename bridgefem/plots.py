"""PNG plots: the load-deflection path and the deformed arch with hinges and sliding joints marked."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .geometry import ArchRing  # noqa: E402


def plot_load_deflection(data: dict, path: Path) -> None:
    """Live load (kN) against the downward deflection under the load (mm) at every converged step."""
    pts = sorted((h["load"], h["deflection"]) for h in data["history"] if h["converged"])
    fig, ax = plt.subplots(figsize=(6, 4.2))
    if pts:
        load, defl = np.array(pts).T
        ax.plot(defl * 1e3, load / 1e3, "o-", ms=3, label="converged steps (FE)")
    lim = data["limit_load"]
    if lim["upper"] is not None and lim["upper"] > 0:
        ax.axhspan(lim["lower"] / 1e3, lim["upper"] / 1e3, color="tab:red", alpha=0.25,
                   label=f"limit load bracket ({lim['lower'] / 1e3:.1f}-{lim['upper'] / 1e3:.1f} kN)")
    lp = data.get("lp")
    if lp and lp.get("load"):
        ax.axhline(lp["load"] / 1e3, color="k", ls="--", lw=1, label=f"rigid-block LP ({lp['load'] / 1e3:.1f} kN)")
    ax.set_xlabel("deflection under the load (mm, down)")
    ax.set_ylabel("live load (kN)")
    ax.set_title(f"{data['scene']}: {data['status']}")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _hinge_point(ring: ArchRing, joint: int, where: str) -> np.ndarray:
    jt = ring.joints[joint]
    return jt.extrados if where == "extrados" else jt.intrados


def plot_mechanism(ring: ArchRing, data: dict, motion: np.ndarray | None, path: Path) -> None:
    """Undeformed ring and elastic abutments (grey), displaced by the blocks' rigid motions (amplified), FE
    hinges (red dots), sliding joints (blue) and, when present, the LP hinges (black rings)."""
    fig, ax = plt.subplots(figsize=(8, 4.8))
    blocks = ring.voussoirs + ring.abutments
    for v in blocks:
        p = np.vstack([v.polygon, v.polygon[:1]])
        ax.plot(p[:, 0], p[:, 1], color="0.75", lw=0.8)
    scale = 0.0
    if motion is not None:
        disp = np.abs(motion[:, :2]).max() + np.abs(motion[:, 2]).max() * ring.span
        scale = 0.04 * ring.span / disp if disp > 0 else 0.0
        for v, (ax_, ay_, th) in zip(blocks, motion):
            p = np.vstack([v.polygon, v.polygon[:1]])
            q = p + scale * (np.array([ax_, ay_]) + th * np.column_stack([-p[:, 1], p[:, 0]]))
            ax.fill(q[:, 0], q[:, 1], color="tan", alpha=0.6, lw=0)
            ax.plot(q[:, 0], q[:, 1], color="saddlebrown", lw=0.7)
    mech = data["mechanism"]
    for jid, where in mech["hinge_positions"].items():
        x, y = _hinge_point(ring, int(jid), where)
        ax.plot(x, y, "o", color="red", ms=8, zorder=5)
    for jid in mech["sliding"]:
        jt = ring.joints[jid]
        ax.plot(*np.array([jt.intrados, jt.extrados]).T, color="tab:blue", lw=3, zorder=5)
    lp = data.get("lp")
    if lp and lp.get("mechanism"):
        for jid, where in lp["mechanism"].get("hinge_positions", {}).items():
            x, y = _hinge_point(ring, int(jid), where)
            ax.plot(x, y, "o", mfc="none", mec="k", ms=13, mew=1.5, zorder=6)
    for ld in data.get("loads", []):
        x0 = ld["x"]
        top = ring.extrados_point(x0)
        ax.annotate("", xy=top, xytext=top + np.array([0, 0.15 * ring.span]),
                    arrowprops=dict(arrowstyle="-|>", color="k", lw=1.5))
    handles = [plt.Line2D([], [], marker="o", color="red", ls="", label="FE hinge"),
               plt.Line2D([], [], color="tab:blue", lw=3, label="FE sliding joint")]
    if lp:
        handles.append(plt.Line2D([], [], marker="o", mfc="none", mec="k", ls="", ms=10, label="LP hinge"))
    ax.legend(handles=handles, loc="upper right", fontsize=8)
    ax.set_aspect("equal")
    ax.set_title(f"{data['scene']}: mechanism at the last converged step (displacements x {scale:.3g})")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
