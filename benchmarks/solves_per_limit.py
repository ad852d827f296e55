"""Linear solves per limit load: how much the load incrementation (:mod:`bridgefem.search.pathfollow`) costs.

The issue's target is at most 25 linear solves (``solver.stats["solves"]``: one per active-set Newton iteration,
self-weight step included) per limit load at a 0.5 % bracket tolerance (TOLERANCE). The cases are variants of
demos/bare_arch.toml and the Prestwood bridge with backfill (demos/prestwood.toml), each run through
:func:`bridgefem.analysis.runner.run_analysis`, which seeds the search with the rigid-block LP level. The "guess" column
scales that seed (x0.1, x10: a deliberately wrong guess; none: no guess; done by wrapping the search that
run_analysis calls) to show that the bracket stays correct and the cost bounded when the estimate is wrong. The
table lists linear solves (and of them those that condensed cycles and those of retries with other solver
settings: :mod:`bridgefem.solver.cycles` and :mod:`bridgefem.solver.newton` *Retries*), factorisations, load steps (failed ones in brackets),
the FE bracket and the LP value (kN for the scene's width) and whether the solves meet the target. A benchmark that
prints figures, not a timed test.

Run:

    ./run python benchmarks/solves_per_limit.py              # every case (about 1 min)
    ./run python benchmarks/solves_per_limit.py --cases demo  # the cases whose name contains "demo"
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from pathlib import Path

from mpi4py import MPI

from bridgefem.analysis import runner as analysis
from bridgefem.limit.collapse import collapse_load
from bridgefem.scene.model import Scene
from bridgefem.scene.reader import load_scene

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import scaled_guess  # noqa: E402

TARGET_SOLVES = 25
TOLERANCE = 0.005  # the bracket tolerance for the target, set on every case
DEMOS = Path(__file__).resolve().parents[1] / "demos"


def variant(scene: Scene, *, voussoirs: int | None = None, friction: float | None = None,
            shape: str | None = None, rise: float | None = None, joint_at_loads: bool | None = None) -> Scene:
    """The scene with some arch and joint values replaced (None: unchanged); lengths in m."""
    a = scene.arch
    arch = dataclasses.replace(a, voussoirs=voussoirs or a.voussoirs, shape=shape or a.shape,
                               rise=rise or a.rise,
                               joint_at_loads=a.joint_at_loads if joint_at_loads is None else joint_at_loads)
    joints = scene.joints if friction is None else dataclasses.replace(scene.joints, friction=friction)
    return dataclasses.replace(scene, arch=arch, joints=joints)


def with_tolerance(scene: Scene) -> Scene:
    """The scene with the bracket tolerance of the target."""
    return dataclasses.replace(scene, solver=dataclasses.replace(scene.solver, tolerance=TOLERANCE))


def cases(base: Scene, fill: Scene) -> list[tuple[str, Scene, float | None]]:
    """(name, scene, factor on the LP guess; None: no guess)."""
    segmental = variant(base, shape="segmental", rise=base.arch.span / 4)
    return [
        ("demo (N = 16, mu = 0.6)", base, 1.0),
        ("demo, mu = 10", variant(base, friction=10.0), 1.0),
        ("interface study N = 4", variant(base, voussoirs=4), 1.0),
        ("interface study N = 8", variant(base, voussoirs=8), 1.0),
        ("interface study N = 32", variant(base, voussoirs=32), 1.0),
        ("segmental, rise/span 1/4", segmental, 1.0),
        ("even joints (load on a voussoir)", variant(base, joint_at_loads=False), 1.0),
        ("N = 64, mu = 10", variant(base, voussoirs=64, friction=10.0), 1.0),
        ("N = 64, mu = 0.6", variant(base, voussoirs=64), 1.0),
        ("demo, guess x0.1", base, 0.1),
        ("demo, guess x10", base, 10.0),
        ("demo, no guess", base, None),
        ("segmental, guess x0.1", segmental, 0.1),
        ("segmental, guess x10", segmental, 10.0),
        ("Prestwood (fill; the LP takes it as dead load)", fill, 1.0),
    ]


def measure(name: str, scene: Scene, factor: float | None, comm: MPI.Comm) -> dict:
    """One row: counts of the FE run, its bracket and the LP value (kN)."""
    if factor == 1.0:  # run_analysis exactly as a user runs it
        an = analysis.run_analysis(scene, comm)
    else:
        with scaled_guess(factor):
            an = analysis.run_analysis(scene, comm)
    s, kn = an.search, an.load_total / 1e3
    lp = collapse_load(scene)
    return {"case": name, "guess": "none" if factor is None else f"x{factor:g}",
            "solves": an.solver.stats["solves"], "factorisations": an.solver.stats["factorisations"],
            "condensing": an.solver.stats["condensation_solves"], "retries": an.solver.stats["retry_solves"],
            "steps": len(s.steps), "failed": sum(not st.converged for st in s.steps),
            "lower": s.lower * kn, "upper": None if s.upper is None else s.upper * kn,
            "lp": None if lp.load is None else lp.load / 1e3, "status": s.status}


def table(rows: list[dict]) -> str:
    head = ["case", "guess", "solves", "of which condensing / retries", "factorisations", "steps (failed)",
            "FE bracket kN", "LP kN", "FE/LP", f"<= {TARGET_SOLVES} solves", "status"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        upper = "-" if r["upper"] is None else f"{r['upper']:.2f}"
        ratio = ("-" if r["upper"] is None or not r["lp"] else f"{(r['lower'] + r['upper']) / 2 / r['lp']:.4f}")
        lines.append("| " + " | ".join([
            r["case"], r["guess"], str(r["solves"]), f"{r['condensing']} / {r['retries']}", str(r["factorisations"]),
            f"{r['steps']} ({r['failed']})",
            f"[{r['lower']:.2f}, {upper}]", "-" if r["lp"] is None else f"{r['lp']:.2f}", ratio,
            "yes" if r["solves"] <= TARGET_SOLVES else "no", r["status"]]) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", nargs="+", default=[], metavar="TEXT", help="only cases whose name contains TEXT")
    args = p.parse_args(argv)
    logging.getLogger().setLevel(logging.WARNING)  # no JIT compiler chatter
    comm = MPI.COMM_WORLD
    base, fill = (with_tolerance(load_scene(DEMOS / f"{name}.toml")) for name in ("bare_arch", "prestwood"))
    chosen = [c for c in cases(base, fill) if not args.cases or any(t in c[0] for t in args.cases)]
    rows = [measure(name, scene, factor, comm) for name, scene, factor in chosen]
    if comm.rank == 0:
        print(f"# Linear solves per limit load (tolerance {base.solver.tolerance:g}, {comm.size} MPI rank(s))\n")
        print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
