"""Command line: ``bridgefem run | converge | lp | min-thickness | check SCENE.toml``.

Exit codes: 0 computed (whatever the structural status), 1 solver failure, 2 bad input (nothing written).
PETSc options of the contact solver: ``--petsc KEY=VALUE`` or ``-bridgefem_KEY VALUE`` (they override the
scene's ``[solver.petsc]`` table, which overrides the defaults).
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import traceback
from pathlib import Path

from .scene import Scene, SceneError, load_scene

PETSC_PREFIX = "-bridgefem_"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="bridgefem", description="Limit loads of masonry arch bridges.")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="FE limit analysis (and its rigid-block LP check) of a scene")
    run.add_argument("scene", type=Path)
    run.add_argument("--out", type=Path, help="output folder (default results/<scene name>)")
    run.add_argument("--petsc", action="append", default=[], metavar="KEY=VALUE",
                     help="PETSc option for the contact solver, without the prefix (repeatable)")
    run.add_argument("--quiet", action="store_true", help="no per-step progress")
    conv = sub.add_parser("converge", help="limit load on successively halved meshes, observed order, extrapolation")
    conv.add_argument("scene", type=Path)
    conv.add_argument("--levels", default="2,4,8", help="elements through the ring, each twice the previous")
    conv.add_argument("--out", type=Path, help="folder for convergence.json (default: none written)")
    check = sub.add_parser("check", help="validate a scene file and print it")
    check.add_argument("scene", type=Path)
    lp = sub.add_parser("lp", help="rigid-block limit analysis (linear programme) of a scene")
    lp.add_argument("scene", type=Path)
    lp.add_argument("--json", action="store_true", help="print one JSON object")
    lp.add_argument("--friction-model", choices=["associative", "non-associative"], default="associative")
    mt = sub.add_parser("min-thickness", help="least ring thickness in equilibrium under self-weight (LP)")
    mt.add_argument("scene", type=Path)
    mt.add_argument("--json", action="store_true", help="print one JSON object")
    mt.add_argument("--friction-model", choices=["associative", "non-associative"], default="associative")
    return p


def _petsc_options(pairs: list[str], raw: list[str]) -> dict:
    out = {}
    for item in pairs:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise SceneError(f"--petsc {item!r}: expected KEY=VALUE, e.g. --petsc ksp_type=preonly")
        out[key.lstrip("-")] = value
    i = 0
    while i < len(raw):
        arg = raw[i]
        if not arg.startswith(PETSC_PREFIX):
            raise SceneError(f"unknown argument {arg!r}; PETSc options must start with {PETSC_PREFIX}")
        has_value = i + 1 < len(raw) and not raw[i + 1].startswith("-")
        out[arg[len(PETSC_PREFIX):]] = raw[i + 1] if has_value else ""
        i += 2 if has_value else 1
    return out


def _progress(total: float):
    from mpi4py import MPI

    def report(step) -> None:
        if MPI.COMM_WORLD.rank != 0:
            return
        c = step.counts
        pairs = f"open/stick/slip {c['open']}/{c['stick']}/{c['slip']}" if c else step.reason
        if step.cohesion is not None:
            pairs += f"  (fill cohesion raised to {step.cohesion / 1e3:.3g} kPa)"
        print(f"step {step.index:3d}  load {step.level * total / 1e3:10.3f} kN  "
              f"{'converged' if step.converged else 'FAILED   '}  newton {step.iterations:2d}  "
              f"residual {step.residual:.1e}  {pairs}  ({step.seconds:.2f} s)", flush=True)

    return report


def _run(args, petsc: dict) -> int:
    scene = load_scene(args.scene)
    out = args.out or Path("results") / scene.name
    from mpi4py import MPI

    from .analysis import run_analysis
    from .results import write_results

    comm = MPI.COMM_WORLD
    total = sum(ld.factor for ld in scene.loads)
    an = run_analysis(scene, comm, petsc, report=(lambda s: None) if args.quiet else _progress(total))
    extra = {"loads": [{"kind": ld.kind, "position": ld.position, "x": sum(ld.x_range(scene.arch.span)) / 2,
                        "length": ld.length, "factor": ld.factor} for ld in scene.loads]}
    data = write_results(an, out, extra)
    if comm.rank == 0:
        lim = data["limit_load"]
        digits = _decimals(lim["tolerance"] * lim["lower"] / 1e3)
        upper = "none" if lim["upper"] is None else f"{lim['upper'] / 1e3:.{digits}f}"
        print(f"{scene.name}: {data['status']}; limit load in [{lim['lower'] / 1e3:.{digits}f}, {upper}] kN "
              f"(relative tolerance {lim['tolerance']:g}, width {scene.arch.width:g} m)")
        if data["failure_reason"]:
            print(f"  last failed step: {data['failure_reason']}")
        print(f"  hinges at joints {data['mechanism']['hinges']}, sliding joints {data['mechanism']['sliding']}")
        lp = data["lp"]
        if lp["load"]:
            ratio = f", FE/LP = {data['fe_lp_ratio']:.4f}" if data["fe_lp_ratio"] else ""
            print(f"  rigid-block LP check ({lp['model']}): {lp['load'] / 1e3:.2f} kN, hinges "
                  f"{lp['mechanism']['hinges']}{ratio}")
        ring = data["ring_under_transmitted_loads"]
        if ring and ring["load"]:
            print(f"  ring under the loads the fill transmits (rigid-block LP): {ring['load'] / 1e3:.2f} kN, "
                  f"{ring['ratio']:.4f} x the last converged FE load, hinges {ring['mechanism']['hinges']}")
        for warning in data["warnings"]:
            print(f"  WARNING: {warning}")
        print(f"  results in {out}/ (results.json, fields.xdmf, load_deflection.png, mechanism.png)")
    return 1 if data["status"].startswith("solver failure") else 0


def _levels(text: str) -> list[int]:
    from .convergence import check_levels

    try:
        levels = [int(v) for v in text.split(",")]
        check_levels(levels)
    except ValueError as err:
        raise SceneError(f"--levels {text!r}: {err}") from None
    return levels


def _decimals(width: float) -> int:
    """Decimals that show a bracket of this width (at least 2): one digit below its leading one."""
    return max(2, math.ceil(-math.log10(width)) + 1) if width > 0 else 2


def _check(args) -> int:
    scene: Scene = load_scene(args.scene)
    print(json.dumps({"scene": scene.name, "valid": True}, indent=2))
    return 0


def _lp(args) -> int:
    from .rigid_block import collapse_load

    res = collapse_load(load_scene(args.scene), friction_model=args.friction_model)
    if args.json:
        from .results import lp_summary

        print(json.dumps(lp_summary(res)))
    else:
        load = "none" if res.load is None else f"{res.load / 1e3:.3f} kN"
        print(f"rigid-block LP ({res.friction_model} friction): {res.status}; collapse load {load}; "
              f"hinges {sorted(res.hinges)}, sliding {sorted(res.sliding)} ({res.time_s:.3f} s)")
    return 0


def _min_thickness(args) -> int:
    from .rigid_block import min_thickness

    res = min_thickness(load_scene(args.scene), friction_model=args.friction_model)
    if args.json:
        print(json.dumps(res.to_dict()))
    else:
        ratio = "" if res.ratio is None else f", t/R = {res.ratio:.5f}"
        print(f"minimum thickness under self-weight ({args.friction_model} friction): {res.thickness:.5f} m{ratio}")
    return 0


def main(argv: list[str] | None = None) -> int:
    logging.getLogger().setLevel(logging.WARNING)
    argv = sys.argv[1:] if argv is None else argv
    args, raw = _parser().parse_known_args(argv)
    try:
        petsc = _petsc_options(getattr(args, "petsc", []), raw) if args.command == "run" else {}
        if raw and args.command != "run":
            raise SceneError(f"unknown argument {raw[0]!r}")
        if args.command == "run":
            return _run(args, petsc)
        if args.command == "check":
            return _check(args)
        if args.command == "converge":
            from .convergence import command
            levels = _levels(args.levels)
            return command(load_scene(args.scene), levels, args.out)
        return _lp(args) if args.command == "lp" else _min_thickness(args)
    except SceneError as err:
        print(f"bridgefem: error: {err}", file=sys.stderr)
        return 2
    except Exception:
        _abort_if_parallel()
        raise


def _abort_if_parallel() -> None:
    """An unexpected error on one MPI rank leaves the others waiting in a collective call for ever: print it and
    abort the whole job (mpirun exits non-zero) instead. Serial runs keep the usual traceback and exit code 1."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    if comm.size > 1:
        traceback.print_exc()
        print(f"bridgefem: error on MPI rank {comm.rank}: aborting all {comm.size} ranks", file=sys.stderr,
              flush=True)
        comm.Abort(1)


if __name__ == "__main__":
    sys.exit(main())
