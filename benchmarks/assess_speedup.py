"""MPI speed-up of the whole ``bridgefem assess`` command: serial against ``mpirun -n 2``, measured side by side.

1. The scene (``--bridge``): demos/bare_arch.toml's arch under two 100 kN axles 1.2 m apart (docs/benchmarks.md), or
   the Prestwood bridge with its fill (demos/prestwood.toml) under the same axles on 0.3 m tyres, assessed at each
   ``--step`` (m; "default": span/40).
2. A warm-up of each command (not counted: the JIT cache, the file cache), then ``--repeat`` pairs, the order
   alternating (serial first, then parallel first, ...), each command a fresh process timed from outside: wall time
   of the whole command, CPU time of all its processes (user + system), and the assessment's own time (its
   assessment.json ``seconds.total``). Each pair gives its ratios, serial / parallel; the median is quoted.
3. Every parallel answer must be the serial one: the same critical x, LP factor and FE bracket (to 1e-9).
4. The start-up every process pays whatever it computes (``python -c "import bridgefem.io.cli,
   bridgefem.analysis.runner, gmsh, matplotlib.pyplot"``: the imports, the MPI and PETSc start, DOLFINx, Gmsh's library
   and matplotlib, which the first FE run and the first picture load) is timed the same way, serial and under ``mpirun
   -n 2``, and with it the best ratio two ranks could reach for this work (Amdahl): serial / (start-up + (serial -
   start-up) / 2).

The machine's load average is printed before and after: on a shared 2-core machine another job slows the 2-rank run
most, so read the ratios with it. Run:

    ./run python benchmarks/assess_speedup.py                      # default step and 0.05 m, 5 pairs each
    ./run python benchmarks/assess_speedup.py --step default --repeat 9
    ./run python benchmarks/assess_speedup.py --bridge prestwood --step default --repeat 1    # ~5 min

Writes DIR/assess_speedup.md and .csv (default results/assess_speedup). Target: >= 1.7 for the whole command.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import machine_line, timed, write_outputs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1.7
VEHICLE = "\n[vehicle]\naxles = [100e3, 100e3]\nspacing = [1.2]\n"
BRIDGES = {"bare": ("bare_arch.toml", VEHICLE), "prestwood": ("prestwood.toml", VEHICLE + "contact_length = 0.3\n")}
"""Each ``--bridge``: its demo scene (whose ``[[load]]`` tables are dropped) and the vehicle that replaces them."""
MPI = ["mpirun", "-n", "2"]


def answer(folder: Path) -> tuple[dict, float]:
    """(the answer, the assessment's own seconds) of an assessment.json."""
    data = json.loads((folder / "assessment.json").read_text())
    fe = data["adequacy_factor"]
    return ({"critical_x": data["critical_x"], "lp": data["lp_adequacy_factor"],
             "fe": None if fe is None else (fe["lower"], fe["upper"])}, data["seconds"]["total"])


def same(a: dict, b: dict) -> bool:
    def close(x, y):
        return x is None and y is None or (x is not None and y is not None and abs(x - y) <= 1e-9 * max(abs(x), 1))
    return (close(a["critical_x"], b["critical_x"]) and close(a["lp"], b["lp"])
            and (a["fe"] is None) == (b["fe"] is None) and (a["fe"] is None or all(map(close, a["fe"], b["fe"]))))


def pairs(serial: list[str], parallel: list[str], repeat: int, env: dict, on_pair=None) -> list[tuple]:
    """A warm-up of each command, then ``repeat`` (serial, parallel) runs in alternating order."""
    timed(serial, env)
    timed(parallel, env)
    out = []
    for k in range(repeat):
        order = (serial, parallel) if k % 2 == 0 else (parallel, serial)
        got = {id(c): timed(c, env) for c in order}
        out.append((got[id(serial)], got[id(parallel)]))
        if on_pair:
            on_pair(*out[-1])
    return out


def median_ratio(values: list[tuple[float, float]]) -> tuple[float, float, float]:
    r = sorted(a / b for a, b in values)
    return r[0], statistics.median(r), r[-1]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--step", nargs="+", default=["default", "0.05"], help='screening steps (m, or "default")')
    p.add_argument("--repeat", type=int, default=5, help="pairs per step (default 5)")
    p.add_argument("--bridge", choices=sorted(BRIDGES), default="bare", help="the scene (default: bare)")
    p.add_argument("--out", type=Path, default=Path("results/assess_speedup"))
    args = p.parse_args(argv)
    env = {**os.environ, "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    py = [sys.executable]
    load_before = os.getloadavg()
    start = time.perf_counter()
    imports = ["-c", "import bridgefem.io.cli, bridgefem.analysis.runner, gmsh, matplotlib.pyplot"]
    startup = pairs(py + imports, MPI + py + imports, args.repeat, env)
    f1 = statistics.median(s[0] for s, _ in startup)
    f2 = statistics.median(q[0] for _, q in startup)
    rows, lines = [], []
    with tempfile.TemporaryDirectory() as tmp:
        demo, vehicle = BRIDGES[args.bridge]
        scene = Path(tmp) / f"{args.bridge}_two_axles.toml"
        scene.write_text((ROOT / "demos" / demo).read_text().split("[[load]]")[0] + vehicle)
        for step in args.step:
            opt = [] if step == "default" else ["--step", step]
            outs = {"s": Path(tmp) / f"s{step}", "p": Path(tmp) / f"p{step}"}
            base = ["-m", "bridgefem", "assess", str(scene), *opt, "--json", "--out"]
            serial, parallel = py + base + [str(outs["s"])], MPI + py + base + [str(outs["p"])]
            record = []

            def on_pair(s, q, record=record, outs=outs):
                (a_s, own_s), (a_p, own_p) = answer(outs["s"]), answer(outs["p"])
                record.append({"serial": s, "parallel": q, "own": (own_s, own_p), "same": same(a_s, a_p),
                               "answer": a_s})
                print(f"step {step}: serial {s[0]:.2f} s, 2 ranks {q[0]:.2f} s, ratio {s[0] / q[0]:.2f} "
                      f"(assessment {own_s / own_p:.2f}), same answer: {same(a_s, a_p)}", flush=True)

            pairs(serial, parallel, args.repeat, env, on_pair)
            whole = median_ratio([(r["serial"][0], r["parallel"][0]) for r in record])
            own = median_ratio([r["own"] for r in record])
            t1 = statistics.median(r["serial"][0] for r in record)
            t2 = statistics.median(r["parallel"][0] for r in record)
            cpu1 = statistics.median(r["serial"][1] for r in record)
            cpu2 = statistics.median(r["parallel"][1] for r in record)
            bound = t1 / (f1 + (t1 - f1) / 2)
            rows.append({"step": step, "serial_s": t1, "parallel_s": t2, "ratio_min": whole[0],
                         "ratio_median": whole[1], "ratio_max": whole[2], "assessment_ratio_median": own[1],
                         "serial_cpu_s": cpu1, "parallel_cpu_s": cpu2, "startup_serial_s": f1,
                         "startup_parallel_s": f2, "amdahl_bound": bound,
                         "same_answer": all(r["same"] for r in record), "answer": json.dumps(record[0]["answer"])})
            lines.append(f"| {step} | {t1:.2f} / {t2:.2f} | **{whole[1]:.2f}** ({whole[0]:.2f}-{whole[2]:.2f}) | "
                         f"{own[1]:.2f} | {cpu1:.2f} / {cpu2:.2f} | {bound:.2f} | "
                         f"{'yes' if rows[-1]['same_answer'] else '**NO**'} |")
    load_after = os.getloadavg()
    md = (f"# `bridgefem assess` of the {args.bridge} bridge: serial against `mpirun -n 2`, side by side\n\n"
          f"{machine_line()}; "
          f"load average (1 min) {load_before[0]:.2f} before and {load_after[0]:.2f} after on {os.cpu_count()} "
          f"CPUs; {args.repeat} alternating pairs per step after a warm-up of each; medians; benchmark wall time "
          f"{time.perf_counter() - start:.0f} s.\n\n"
          f"Start-up of a process (`import bridgefem.io.cli, bridgefem.analysis.runner, gmsh, matplotlib.pyplot`: "
          f"imports, MPI, PETSc, DOLFINx, Gmsh, matplotlib): {f1:.2f} s serial, "
          f"{f2:.2f} s under `mpirun -n 2`.\n\n"
          "| step (m) | whole command, serial / 2 ranks (s) | ratio, median (min-max) | the assessment's own "
          "ratio (assessment.json) | CPU s, serial / 2 ranks | best 2-rank ratio for this start-up (Amdahl) | "
          "same answer |\n|---|---|---|---|---|---|---|\n" + "\n".join(lines) + "\n\n"
          + "\n".join(f"- step {r['step']}: whole-command ratio {r['ratio_median']:.2f} (target >= {TARGET:g}: "
                      f"{'met' if r['ratio_median'] >= TARGET else 'NOT met'})" for r in rows) + "\n")
    write_outputs(args.out, "assess_speedup", rows, md)
    return 0 if all(r["same_answer"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
