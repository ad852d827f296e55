"""The assessment of a filled arch, shown on the Prestwood bridge (demos/prestwood.toml, its test load removed) under
a two-axle vehicle: how the rigid-block LP screen with the fill as dead load sees the vehicle through each
dispersion rule, where it puts the critical position, and what the FE (which carries the axles through the fill
itself) and the conic bounds of the bridge with its fill say there.

1. For each dispersion rule (:data:`bridgefem.scene.vehicles.DISPERSIONS`): the LP screen and its refinements
   (:func:`bridgefem.assess.sweep.assess` with ``fe=False``): the curve, the least factor and its first-axle x.
2. ``bridgefem assess`` itself, in a fresh process, with the default rule: the FE adequacy factor at the critical
   position, the LP's there, the conic bounds as factors, whether the FE lies inside them, and the command's time.
3. The FE limit analysis (:func:`bridgefem.analysis.runner.run_analysis`) at each rule's critical position and at
   ``--fe-points`` positions across the left half of the roll (the bridge is symmetric): the FE's own curve, to
   show where the FE's minimum is against each rule's.

Run:

    ./run python benchmarks/assess_prestwood.py                     # about 10 min on a shared 2-core machine
    ./run python benchmarks/assess_prestwood.py --fe-points 0       # the screens and the command only (~1.5 min)
    ./run python benchmarks/assess_prestwood.py --figures docs/figures

Writes DIR/assess_prestwood.md, .csv and .png (default results/assess_prestwood).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import fmt, machine_line, write_outputs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
VEHICLE = {"axles": [100e3, 100e3], "spacing": [1.2], "contact_length": 0.3}


def scene_text(vehicle: dict) -> str:
    """Prestwood's scene file with ``vehicle`` instead of its test load."""
    text = (ROOT / "demos" / "prestwood.toml").read_text().split("[[load]]")[0]
    text = text.replace('name = "prestwood"', 'name = "prestwood-vehicle"')
    return text + "\n[vehicle]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in vehicle.items())


def main(argv: list[str] | None = None) -> int:
    import bridgefem
    from bridgefem.analysis.runner import run_analysis
    from bridgefem.assess.sweep import assess
    from bridgefem.assess.vehicle import place
    from bridgefem.scene.vehicles import DISPERSIONS

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fe-points", type=int, default=5, help="FE positions across the left half (default 5)")
    p.add_argument("--out", type=Path, default=Path("results/assess_prestwood"))
    p.add_argument("--figures", type=Path, help="also copy the .md and .png into this folder")
    args = p.parse_args(argv)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "prestwood_vehicle.toml"
        path.write_text(scene_text(VEHICLE))
        base = bridgefem.load_scene(path)
        # step 2: the command as a user runs it
        t0 = time.perf_counter()
        run = subprocess.run([sys.executable, "-m", "bridgefem", "assess", str(path), "--out", str(Path(tmp) / "o"),
                              "--json"], capture_output=True, text=True, timeout=1800)
        command_s = time.perf_counter() - t0
        if run.returncode != 0:
            print(run.stderr, file=sys.stderr)
            return 1
        data = json.loads((Path(tmp) / "o" / "assessment.json").read_text())
    span = base.arch.span
    screens = {}
    for rule in DISPERSIONS:  # step 1
        [a] = assess([bridgefem.edit(base, vehicle={"dispersion": rule})], fe=False)
        screens[rule] = a
    load = 2 * VEHICLE["axles"][0]

    fe_rows = {}
    xs = sorted({round(screens[r].lp_critical_x, 6) for r in DISPERSIONS})
    half = (span - VEHICLE["spacing"][0]) / 2  # the first axle where the vehicle stands mid-span
    grid = list(np.linspace(-VEHICLE["spacing"][0] + 0.3, half, args.fe_points)) if args.fe_points else []
    for x0 in sorted(set(xs) | {round(float(x), 6) for x in grid}):  # step 3
        pl = place(base, x0)
        an = run_analysis(pl.scene)
        total = an.load_total
        fe_rows[x0] = (an.search.lower * total / pl.load,
                       None if an.search.upper is None else an.search.upper * total / pl.load, str(an.search.status))
    rows = []
    for rule, a in screens.items():
        crit = fe_rows[round(a.lp_critical_x, 6)]
        rows.append({"kind": "screen", "dispersion": rule, "lp_factor": a.lp_factor, "lp_critical_x_m": a.lp_critical_x,
                     "fe_lower_at_x": crit[0], "fe_upper_at_x": crit[1], "positions": len(a.positions),
                     "lp_seconds": a.seconds["lp"]})
    for x0, (lo, hi, status) in sorted(fe_rows.items()):
        rows.append({"kind": "fe", "x0_m": x0, "fe_lower": lo, "fe_upper": hi, "status": status})
    b = data["bounds_factor"] or {}
    fe = data["adequacy_factor"]
    least_fe = min(fe_rows.items(), key=lambda kv: kv[1][0])
    head = ("| dispersion (LP screen) | least LP factor | at first-axle x (m) | FE factor at that x | "
            "LP / FE there |\n|---|---|---|---|---|\n")
    body = "".join(f"| {r['dispersion']}{' (default)' if r['dispersion'] == DISPERSIONS[0] else ''} | "
                   f"{r['lp_factor']:.4f} | {r['lp_critical_x_m']:.3f} | [{r['fe_lower_at_x']:.4f}, "
                   f"{fmt(r['fe_upper_at_x'], '.4f')}] | {r['lp_factor'] / r['fe_lower_at_x']:.3f} |\n"
                   for r in rows if r["kind"] == "screen")
    fe_table = ("| first-axle x (m) | FE adequacy factor | FE status |\n|---|---|---|\n"
                + "".join(f"| {x0:.3f} | [{lo:.4f}, {fmt(hi, '.4f')}] | {st} |\n"
                          for x0, (lo, hi, st) in sorted(fe_rows.items())))
    md = (f"# Assessment of Prestwood under two {VEHICLE['axles'][0] / 1e3:g} kN axles {VEHICLE['spacing'][0]:g} m "
          f"apart ({VEHICLE['contact_length']:g} m tyres, {load / 1e3:g} kN)\n\n{machine_line()}; study wall time "
          f"{time.perf_counter() - start:.0f} s.\n\n"
          f"`bridgefem assess` (default dispersion {DISPERSIONS[0]}): {data['status']}; FE adequacy factor "
          f"{'none' if fe is None else '[%.4f, %s]' % (fe['lower'], fmt(fe['upper'], '.4f'))} at first-axle x = "
          f"{fmt(data['critical_x'], '.3f')} m; LP screen "
          f"{data['lp_adequacy_factor']:.4f} at x = {data['lp_critical_x']:.3f} m; conic bounds of the bridge with "
          f"its fill there [{b.get('lower', float('nan')):.4f}, {b.get('upper', float('nan')):.4f}], the FE "
          f"{'inside' if b.get('fe_inside') else 'OUTSIDE'}; {len(data['positions'])} positions screened; "
          f"{command_s:.1f} s for the whole command (LP {data['seconds']['lp']:.1f} s, FE "
          f"{data['seconds'].get('fe', 0):.1f} s).\n\n"
          "The LP screen with each dispersion rule (the fill as dead load only) and the FE at the position it "
          "picks:\n\n" + head + body + "\n"
          f"The FE across the roll (least: {least_fe[1][0]:.4f} at x = {least_fe[0]:.3f} m):\n\n" + fe_table)

    def plot(path: Path) -> None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 4.5))
        for rule, a in screens.items():
            pts = [(q.x0, q.factor) for q in a.positions if q.factor is not None and np.isfinite(q.factor)]
            x, f = np.array(pts).T
            ax.plot(x, f, lw=1.2, label=f"LP screen, {rule}")
        fx = sorted(fe_rows)
        ax.errorbar(fx, [fe_rows[x][0] for x in fx], fmt="ks", ms=5, label="FE limit analysis")
        if b:
            ax.vlines(data["critical_x"], b["lower"], b["upper"], colors="tab:red", lw=4, alpha=0.5,
                      label="conic bounds at the critical x")
        ax.set_ylim(0, 3.5)
        ax.set_xlabel("first axle x (m from the left springing)")
        ax.set_ylabel("adequacy factor")
        ax.set_title("Prestwood, two 100 kN axles 1.2 m apart: LP screen by dispersion rule, FE, bounds",
                     fontsize=10)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)

    write_outputs(args.out, "assess_prestwood", rows, md, plot=plot, figures=args.figures)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
