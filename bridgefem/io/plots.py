"""PNG plots of a run (matplotlib, Agg): the load-deflection path with the limit-load bracket, and the collapse
mechanism.

Loads are drawn in kN, deflections in mm (positive down), lengths in m. The bracket is a band between its ends,
at least ``BAND_MIN`` of the load axis high so that a tight bracket stays visible; the mechanism draws the
voussoirs displaced by the collapse mode, amplified until its largest block motion is ``MODE_SIZE`` x the span,
with the hinges and sliding joints marked.

The pictures are drawn with matplotlib's own defaults and the Agg backend: a ``matplotlibrc`` in the current folder
(which matplotlib reads as it is imported) could otherwise choose a backend module, or have every label typeset by
an external LaTeX program, and the same run would draw different pictures in different folders.
"""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import matplotlib

matplotlib.rcdefaults()  # no rc file's settings: the module docstring
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402

from ..geometry.ring import ArchRing  # noqa: E402
from ..status import Status  # noqa: E402

BAND_MIN = 0.015  # the bracket band is drawn at least this fraction of the load axis high (1e-4 wide is invisible)
MODE_SIZE = 0.08  # the collapse mode is amplified until its largest block motion is this fraction of the span
TITLE_WIDTH = 70  # characters per title line
LEGEND_WIDTH = 60  # characters per legend line


def bracket_decimals(width: float) -> int:
    """Decimals that show a bracket of this width (at least 2): one digit below its leading one."""
    return max(2, math.ceil(-math.log10(width)) + 1) if width > 0 else 2


def format_bracket(lower: float, upper: float | None, tolerance: float) -> str:
    """``[lower, upper] kN`` from loads in N, with the decimals that show the bracket's tolerance."""
    digits = bracket_decimals(tolerance * lower / 1e3)
    high = "none" if upper is None else f"{upper / 1e3:.{digits}f}"
    return f"[{lower / 1e3:.{digits}f}, {high}] kN"


def _title(ax, data: dict) -> None:
    """The scene's name (at most two lines) and its status."""
    name = textwrap.wrap(data["scene"], TITLE_WIDTH, max_lines=2, placeholder=" ...")
    ax.set_title("\n".join(name + textwrap.wrap(data["status"], TITLE_WIDTH)), fontsize=9)


def plot_load_deflection(data: dict, path: Path) -> None:
    """Live load (kN) against the downward deflection under the load (mm) at every converged step, the limit-load
    bracket (a band, widened to stay visible) and the rigid-block LP's collapse load."""
    pts = sorted((h["load"], h["deflection"]) for h in data["history"] if h["converged"])
    lim = data["limit_load"]
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    if pts:
        load, defl = np.array(pts).T
        ax.plot(defl * 1e3, load / 1e3, "o-", ms=3, label="converged load steps (FE)")
    else:
        ax.text(0.5, 0.5, "no converged load step", transform=ax.transAxes, ha="center", va="center")
    lp = data.get("lp")
    if lp and lp.get("load"):
        ax.axhline(lp["load"] / 1e3, color="k", ls="--", lw=1,
                   label=f"rigid-block LP, {lp['model']}: {lp['load'] / 1e3:.2f} kN")
    bounds = data.get("fill_bounds") or {}
    for key, style in (("lower", ":"), ("upper", "-.")):
        if bounds.get(key):
            ax.axhline(bounds[key] / 1e3, color="tab:green", ls=style, lw=1,
                       label=f"{key} bound, rigid-plastic fill (conic): {bounds[key] / 1e3:.1f} kN")
    if Status.of(data["status"]) is Status.LIMIT:
        low, high = ax.get_ylim()
        half = max(lim["upper"] - lim["lower"], BAND_MIN * (high - low) * 1e3) / 2e3
        mid = (lim["lower"] + lim["upper"]) / 2e3
        ax.axhspan(mid - half, mid + half, color="tab:red", alpha=0.3,
                   label=f"limit load {format_bracket(lim['lower'], lim['upper'], lim['tolerance'])} "
                         f"(tolerance {lim['tolerance']:g}; band at least {BAND_MIN:.1%} of the axis)")
    ax.set_xlabel("deflection under the load (mm, down)")
    ax.set_ylabel(f"live load (kN, for a width of {lim['width']:g} m)")
    _title(ax, data)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _hinge_point(ring: ArchRing, joint: int, where: str) -> np.ndarray:
    jt = ring.joints[joint]
    return jt.extrados if where == "extrados" else jt.intrados


def _joint_line(jt) -> np.ndarray:
    """The points (m) to draw a joint through: its curve (a ring interface) or its two ends."""
    return jt.curve if jt.curve is not None else np.array([jt.intrados, jt.extrados])


def _label_joints(ax, ring: ArchRing) -> None:
    """Every voussoir joint's and springing's number: the inner ring's inside its intrados, the outer ring's (a
    single ring's) outside its extrados, a middle ring's at the joint's centre on a white ground (each span's rings
    its own); a pier's bed joints' beside its right face."""
    for barrel in ring.barrels:
        ring_of = {v.id: v.ring for v in barrel.voussoirs}
        outer = barrel.n_rings - 1
        for jt in barrel.ring_joints:
            r = ring_of[jt.left if jt.left in ring_of else jt.right]
            if r == outer:
                at, box = jt.extrados + 0.06 * ring.span * jt.tangent, None
            elif r == 0:
                at, box = jt.intrados - 0.04 * ring.span * jt.tangent, None
            else:
                at, box = jt.centre, dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.8)
            ax.text(*at, str(jt.id), fontsize=6 if barrel.n_rings == 1 else 5, ha="center", va="center",
                    color="0.35", bbox=box, zorder=8)
    for jt in ring.joints:
        if jt.kind == "pier":
            ax.text(*(jt.extrados + np.array([0.02 * ring.span, 0.0])), str(jt.id), fontsize=6, ha="left",
                    va="center", color="0.35", zorder=8)


def _thrust_lines(points: list[dict], spans: int) -> list[list[dict]]:
    """The line of thrust's points (results.json ``line_of_thrust.points``) as polylines: one per span (lines 0 ..
    ``spans`` - 1), left to right, and one per pier, from the top down (each point's ``line``)."""
    lines: dict[int, list[dict]] = {}
    for p in points:
        lines.setdefault(p.get("line", 0), []).append(p)
    return [sorted(ps, key=(lambda p: p["x"]) if k < spans else (lambda p: -p["y"])) for k, ps in sorted(lines.items())]


def plot_mechanism(ring: ArchRing, data: dict, mode: np.ndarray | None, path: Path,
                   fill: np.ndarray | None = None) -> None:
    """The collapse mechanism: the ring and elastic abutments (grey outline), the fill (``fill``: its region,
    m), the blocks moved by ``mode`` (their rigid motion over the last converged load increment: rows ux m, uy m,
    rotation rad; amplified to be seen), FE hinges (red dots, labelled with their joint numbers), sliding joints
    (blue, a ring interface along its curve), separated ring interfaces (orange, dashed), the rigid-block LP's
    hinges (black rings), the line of thrust of the last converged state (purple, diamonds where it touches the
    intrados or extrados: ``data["line_of_thrust"]``), every voussoir joint's number (:func:`_label_joints`), and
    the live loads as arrows."""
    fig, ax = plt.subplots(figsize=(8, 5))
    if fill is not None:
        ax.fill(fill[:, 0], fill[:, 1], color="olivedrab", alpha=0.15, lw=0)
        ax.plot(*np.vstack([fill, fill[:1]]).T, color="olivedrab", lw=0.6)
    blocks = ring.blocks
    outlines = [np.vstack([v.polygon, v.polygon[:1]]) for v in blocks]
    ax.add_collection(LineCollection(outlines, colors="0.6", lw=0.8))  # one artist for all the blocks
    scale = 0.0
    if mode is not None:
        reach = np.abs(mode[:len(blocks), :2]).max() + np.abs(mode[:len(blocks), 2]).max() * ring.span
        scale = MODE_SIZE * ring.span / reach if reach > 0 else 0.0
        moved = [p + scale * (np.array([mx, my]) + th * np.column_stack([-p[:, 1], p[:, 0]]))
                 for p, (mx, my, th) in zip(outlines, mode)]
        ax.add_collection(PolyCollection(moved, facecolors="tan", alpha=0.6, lw=0))
        ax.add_collection(LineCollection(moved, colors="saddlebrown", lw=0.7))
    thrust = (data.get("line_of_thrust") or {}).get("points") or []
    for line in _thrust_lines(thrust, len(ring.barrels)):
        ax.plot([p["x"] for p in line], [p["y"] for p in line], "-", color="tab:purple", lw=1.4, zorder=4)
    if thrust:
        touching = [p for p in thrust if p["touches"]]
        ax.plot([p["x"] for p in touching], [p["y"] for p in touching], "D", color="tab:purple", ms=5, zorder=6)
    _label_joints(ax, ring)
    mech = data["mechanism"]
    for jid, where in mech["hinge_positions"].items():
        p = _hinge_point(ring, int(jid), where)
        ax.plot(*p, "o", color="red", ms=8, zorder=5)
        jt = ring.joints[int(jid)]
        side = jt.tangent if where == "extrados" else -jt.tangent
        ax.annotate(f"hinge {jid}", p, p + 0.12 * ring.span * side, fontsize=8, color="red", ha="center",
                    arrowprops=dict(arrowstyle="-", color="red", lw=0.6), zorder=7)
    for jid in mech["sliding"]:
        ax.plot(*_joint_line(ring.joints[jid]).T, color="tab:blue", lw=3, zorder=5)
    for jid in mech.get("separated", []):
        ax.plot(*_joint_line(ring.joints[jid]).T, color="tab:orange", lw=2, ls="--", zorder=5)
    lp = data.get("lp")
    if lp and lp.get("mechanism"):
        for jid, where in lp["mechanism"].get("hinge_positions", {}).items():
            ax.plot(*_hinge_point(ring, int(jid), where), "o", mfc="none", mec="k", ms=13, mew=1.5, zorder=6)
    top = fill[:, 1].max() if fill is not None else None
    for ld in data.get("loads", []):
        half = (ld.get("length") or 0.0) / 2
        xs = np.linspace(ld["x"] - half, ld["x"] + half, 5 if half else 1)
        tips = [np.array([x, top]) if top is not None else ring.extrados_point(x) for x in xs]
        for tip in tips:
            ax.annotate("", xy=tip, xytext=tip + np.array([0, 0.15 * ring.span]),
                        arrowprops=dict(arrowstyle="-|>", color="k", lw=1.2))
        if half:
            ax.plot(xs, [t[1] + 0.15 * ring.span for t in tips], color="k", lw=1.2)
    handles = [plt.Line2D([], [], color="saddlebrown", lw=2,
                          label=f"blocks moved by the last converged load increment x {scale:.3g}"),
               plt.Line2D([], [], marker="o", color="red", ls="", label="FE hinge"),
               plt.Line2D([], [], color="tab:blue", lw=3, label="FE sliding joint")]
    if ring.n_rings > 1:
        handles.append(plt.Line2D([], [], color="tab:orange", lw=2, ls="--", label="FE separated ring interface"))
    if thrust:
        handles.append(plt.Line2D([], [], color="tab:purple", marker="D", ms=4, lw=1.4,
                                  label="line of thrust (diamonds: touches a face)"))
    if lp:
        handles.append(plt.Line2D([], [], marker="o", mfc="none", mec="k", ls="", ms=10,
                                  label=textwrap.fill(f"rigid-block LP hinge ({lp.get('model', 'bare ring')})",
                                                      LEGEND_WIDTH)))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=7)
    ax.set_aspect("equal")
    ax.margins(0.05, 0.25)
    _title(ax, data)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_elevation(ring: ArchRing, data: dict, path, fill: np.ndarray | None = None) -> None:
    """The bridge to scale (equal axes): the ring's voussoirs (and piers), the fill, each span and the live loads as
    arrows labelled with their loads (kN; ``data["loads"]`` with ``x`` from midspan and ``load`` N), at the road
    with a fill or on the extrados without."""
    fig, ax = plt.subplots(figsize=(8, 4))
    if fill is not None:
        ax.fill(fill[:, 0], fill[:, 1], color="olivedrab", alpha=0.2, lw=0)
    for v in ring.blocks:
        p = np.vstack([v.polygon, v.polygon[:1]])
        ax.fill(p[:, 0], p[:, 1], color="0.85", lw=0)
        ax.plot(p[:, 0], p[:, 1], color="0.4", lw=0.6)
    top = fill[:, 1].max() if fill is not None else None
    arrow = 0.12 * ring.span
    for ld in data.get("loads", []):
        tip = np.array([ld["x"], top]) if top is not None else ring.extrados_point(ld["x"])
        ax.annotate("", xy=tip, xytext=tip + np.array([0, arrow]), arrowprops=dict(arrowstyle="-|>", color="k"))
        ax.text(tip[0], tip[1] + arrow * 1.05, f"{ld['load'] / 1e3:.0f} kN", ha="center", va="bottom", fontsize=8)
    y = -0.05 * ring.span
    for barrel in ring.barrels:  # each span between its springings' intrados corners
        xs = np.concatenate([v.intrados[:, 0] for v in barrel.voussoirs])
        ax.annotate("", xy=(xs.min(), y), xytext=(xs.max(), y), arrowprops=dict(arrowstyle="<->", lw=0.8))
        ax.text(0.5 * (xs.min() + xs.max()), y, f"span {barrel.span:g} m", ha="center", va="top", fontsize=8)
    ax.set_aspect("equal")
    ax.margins(0.05, 0.2)
    ax.set_xlabel("x (m, from the first span's midspan)" if ring.spans else "x (m, from midspan)")
    ax.set_ylabel("y (m)")
    _title(ax, data)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_adequacy(data: dict, path) -> None:
    """The adequacy factor against the first axle's position (m from the left springing): the rigid-block LP at
    every screened position (line and dots), the FE brackets at the confirmed positions (red bars) and the critical
    position (a vertical line)."""
    pts = [(p["x0"], p["factor"]) for p in data["positions"] if p["factor"] is not None]
    fig, ax = plt.subplots(figsize=(7, 4))
    if pts:
        x, f = np.array(pts).T
        ax.plot(x, f, ".-", ms=3, lw=0.8, label="rigid-block LP (screen and refinements)")
    for c in data["confirmations"]:
        if c["adequacy"]:
            lo, hi = c["adequacy"]["lower"], c["adequacy"]["upper"]
            ax.errorbar([c["x0"]], [(lo + hi) / 2], yerr=[[(hi - lo) / 2 + 1e-9]], fmt="o", color="tab:red",
                        ms=5, capsize=4)
    ax.plot([], [], "o", color="tab:red", label="FE limit analysis (confirmed positions)")
    if data.get("critical_x") is not None:
        ax.axvline(data["critical_x"], color="k", ls="--", lw=0.8, label=f"critical: x = {data['critical_x']:.3f} m")
    if pts:
        finite = f[np.isfinite(f)]
        if len(finite):
            ax.set_ylim(0, min(finite.max(), 4 * finite.min()) * 1.05)
    ax.set_xlabel("first axle's position x (m from the left springing)")
    ax.set_ylabel("adequacy factor (collapse load / vehicle)")
    ax.set_title(textwrap.shorten(f"{data['scene']}: {data['status']}", TITLE_WIDTH * 2), fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
