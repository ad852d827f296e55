"""Command line: ``bridgefem run | converge | lp | min-thickness | bounds | check | assess SCENE.toml``.

Exit codes: 0 computed (whatever the structural status), 1 solver failure (its results go to ``<out>-failed``;
the earlier results in ``<out>`` are kept) or no stable thickness (``min-thickness``), 2 bad input or a refused
output folder (one line on stderr, nothing written; checked before the analysis), 130 interrupted (Ctrl-C) and 143
terminated by SIGTERM (the earlier results kept, nothing half-written; under ``mpirun``, which exits 1 after either,
``./run mpirun`` gives these codes). Where results go: :mod:`bridgefem.io.output` (docs/output-policy.md). A bad option
in the user's PETSC_OPTIONS ends bridgefem as PETSc starts, with exit code 2: :mod:`bridgefem.petsc_start`.
PETSc options of the contact solver: ``--petsc KEY=VALUE`` or ``-bridgefem_KEY VALUE`` (any option; they override
the scene's ``[solver.petsc]`` table, which may set only allow-listed solver settings, the user's PETSC_OPTIONS and
the defaults).
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import gc
import json
import logging
import math
import sys
import traceback
from pathlib import Path

from ..petsc_start import launcher_rank
from ..scene.document import key_units, resolved_document
from ..scene.keys import SceneError
from ..scene.model import Scene
from ..scene.petsc_options import PETSC_PREFIX
from ..scene.reader import did_you_mean, load_scene, resolved_toml
from ..status import COLLAPSE_END, RINGS_UNDER_FILL, Status
from ..structure.sizing import LARGE_DOFS, MAX_DOFS, SizeEstimate, check_size
from .output import Terminated, claim, sigterm_raises
from .targets import OutputError, failed_target, version


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="bridgefem", description="Limit loads of masonry arch bridges.")
    p.add_argument("--version", action="version", version=f"bridgefem {version()}")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="FE limit analysis (and its rigid-block LP check) of a scene")
    run.add_argument("scene", type=Path)
    run.add_argument("--out", type=Path, help="output folder (default results/<scene name>)")
    _run_options(run)
    run.add_argument("--quiet", action="store_true", help="no per-step progress")
    run.add_argument("--json", action="store_true", help="print the run's summary as one JSON object, the last line "
                     "of stdout (the progress goes to stderr)")
    conv = sub.add_parser("converge", help="limit load on successively halved meshes, observed order, extrapolation")
    conv.add_argument("scene", type=Path)
    conv.add_argument("--levels", default="2,4,8", help="elements through the ring, each twice the previous")
    conv.add_argument("--out", type=Path, help="folder for convergence.json (default: none written)")
    check = sub.add_parser("check", help="validate a scene file as run does before its analysis (the same "
                                          "options) and print it resolved (every key, defaults filled in, with units)")
    check.add_argument("scene", type=Path)
    _run_options(check)
    check.add_argument("--json", action="store_true", help="print the resolved scene and the size estimate as one "
                       "JSON object")
    lp = sub.add_parser("lp", help="rigid-block limit analysis (linear programme) of a scene")
    lp.add_argument("scene", type=Path)
    lp.add_argument("--json", action="store_true", help="print one JSON object")
    lp.add_argument("--friction-model", choices=["associative", "non-associative"], default="associative")
    mt = sub.add_parser("min-thickness", help="least ring thickness in equilibrium under self-weight (LP)")
    mt.add_argument("scene", type=Path)
    mt.add_argument("--json", action="store_true", help="print one JSON object")
    mt.add_argument("--friction-model", choices=["associative", "non-associative"], default="associative")
    bd = sub.add_parser("bounds", help="lower and upper collapse bounds with the fill (conic optimisation)")
    bd.add_argument("scene", type=Path)
    bd.add_argument("--json", action="store_true", help="print one JSON object")
    bd.add_argument("--refine", type=float, default=1.0, help="mesh refinement factor (default 1)")
    bd.add_argument("--plot", type=Path, metavar="PNG", help="write the mechanism and the stress field to this PNG")
    asm = sub.add_parser("assess", help="roll the scene's [vehicle] across the bridge: critical position, adequacy "
                                         "factor (FE, with the rigid-block LP's), report.html")
    asm.add_argument("scene", type=Path, nargs="+", help="one or more scenes, each with a [vehicle]")
    asm.add_argument("--step", type=float, help="screening step of the first axle's position, m (default span/40)")
    asm.add_argument("--out", type=Path, help="output folder (default results/<scene name>-assessment; several "
                     "scenes: DIR/<scene name>-assessment)")
    asm.add_argument("--json", action="store_true", help="print the verdict as one JSON object, the last line of "
                     "stdout")
    for command in sub.choices.values():  # each command's options, for the hint after an unknown one
        command.set_defaults(options=[s for a in command._actions for s in a.option_strings if s != "-h"])
    return p


def _run_options(parser: argparse.ArgumentParser) -> None:
    """The options that decide what ``run`` accepts before its analysis; ``check`` takes them too, so that it
    validates exactly what the same ``run`` would."""
    parser.add_argument("--petsc", action="append", default=[], metavar="KEY=VALUE",
                        help="PETSc option for the contact solver, without the prefix (repeatable)")
    parser.add_argument("--no-size-limit", action="store_true",
                        help=f"run a model of more than {MAX_DOFS:,} unknowns (the memory limit still applies)")


def _unknown(arg: str, options: list[str], petsc: bool = False) -> SceneError:
    """The one-line error for an argument no option of the command takes, with the nearest option (difflib);
    ``petsc``: the command also takes PETSc options."""
    shown = arg if arg.isprintable() and len(arg) <= 60 else repr(arg[:60])
    if not arg.startswith("-"):
        return SceneError(f"unexpected argument {shown}")
    names = {option.lstrip("-"): option for option in options}  # the dashes would make every option look close
    hint = did_you_mean(arg.partition("=")[0].lstrip("-"), names, names.get).strip()
    if not hint:
        hint = "the options are " + ", ".join(options)
        if petsc:
            hint += f"; PETSc options must start with -{PETSC_PREFIX}"
    return SceneError(f"unknown option {shown}; {hint}")


def _petsc_options(pairs: list[str], raw: list[str], options: list[str]) -> dict:
    """The PETSc options of ``run``: ``--petsc KEY=VALUE`` pairs and the raw ``-bridgefem_KEY [VALUE]``
    arguments; anything else in ``raw`` is an unknown option (``options``: the command's own)."""
    prefix = "-" + PETSC_PREFIX
    out = {}
    for item in pairs:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise SceneError(f"--petsc {item!r}: expected KEY=VALUE, e.g. --petsc ksp_type=preonly")
        out[key.lstrip("-")] = value
    i = 0
    while i < len(raw):
        arg = raw[i]
        if not arg.startswith(prefix):
            raise _unknown(arg, options, petsc=True)
        has_value = i + 1 < len(raw) and not raw[i + 1].startswith("-")
        out[arg[len(prefix):]] = raw[i + 1] if has_value else ""
        i += 2 if has_value else 1
    return out


def _progress(total: float, states: tuple[str, ...]):
    """Print one line per load step (rank 0): the live load, the outcome, Newton iterations, the residual and how
    many joint node pairs are in each of the joint law's ``states`` (e.g. open, sticking and slipping)."""
    from mpi4py import MPI

    names = "/".join(states)

    def report(step) -> None:
        if MPI.COMM_WORLD.rank != 0:
            return
        if step.index == 0:
            print(f"load steps: live load, outcome, Newton iterations, residual, joint node pairs {names}",
                  flush=True)
        c = step.counts
        if step.converged:
            what = f"pairs {names} {'/'.join(str(c[s]) for s in states)}" if c else ""
            outcome = "converged"
        else:
            what = _collapse(step.reason) if step.mechanism else step.reason
            outcome = "failed   "
        if step.cohesion is not None:
            what += f"  (fill cohesion raised to {step.cohesion / 1e3:.3g} kPa)"
        print(f"step {step.index:3d}  load {step.level * total / 1e3:10.3f} kN  {outcome}  newton "
              f"{step.iterations:2d}  residual {step.residual:.1e}  {what}  ({step.seconds:.2f} s)", flush=True)

    return report


def _collapse(reason: str) -> str:
    """What a failed step that proved collapse means to a user (the solver's numbers stay in results.json)."""
    if reason.startswith("load-deflection curve flat"):
        return "the load-deflection curve is flat: the structure moves as a mechanism"
    if reason.startswith("no trial above the bracket"):
        return ("no equilibrium by the static theorem: the rigid-block LP on the same joints under the FE's own loads "
                "bounds every FE equilibrium")
    if COLLAPSE_END in reason:
        return ("no equilibrium found with any solver setting, and the last converged state's rigid blocks with its "
                "friction capacities collapse at the bracket's upper end")
    if RINGS_UNDER_FILL in reason:
        return (f"{RINGS_UNDER_FILL} collapse: the rings move as a mechanism, which only the elastic fill's own "
                "stiffness could restrain further")
    return "no equilibrium: the voussoirs move as a mechanism"


@dataclasses.dataclass(frozen=True)
class Validated:
    """A scene that passed every check ``run`` makes before its analysis (:func:`validate`): its size estimate, the
    unknowns allowed, and a line for each point load moved onto a joint
    (:func:`bridgefem.structure.ring.snapped_loads`)."""

    scene: Scene
    size: SizeEstimate
    max_dofs: float
    notices: list[str]


def validate(args, petsc: dict) -> Validated:
    """Every check ``run`` makes before its analysis, for ``run`` and ``check`` alike, so that a scene ``check`` calls
    valid is never refused by ``run`` before it computes: the scene's keys (:func:`bridgefem.scene.reader.load_scene`),
    its size (:func:`bridgefem.structure.sizing.check_size`, ``--no-size-limit``), its ring with the joints at its loads
    (the one the FE and the LP share, :func:`bridgefem.structure.ring.scene_ring`) and the PETSc options (the scene's
    and ``petsc``, the command line's). Raises SceneError. Only the output folder is left to ``run`` (it depends on
    ``--out``)."""
    from ..structure.ring import scene_ring, snapped_loads

    scene = load_scene(args.scene)
    max_dofs = math.inf if args.no_size_limit else MAX_DOFS
    size = check_size(scene, max_dofs=max_dofs)
    ring = scene_ring(scene)
    options = {**scene.solver.petsc, **petsc}
    if options:  # PETSc started only to check options
        from mpi4py import MPI

        from ..solver.linear import check_petsc_options

        check_petsc_options(options, MPI.COMM_WORLD)
    return Validated(scene, size, max_dofs, [s.notice(scene.arch.span) for s in snapped_loads(scene, ring)])


RUN_JSON = ("scene", "status", "limit_load", "failure_reason", "evidence", "mechanism", "lp", "fe_lp_ratio",
            "static_bound", "ring_under_transmitted_loads", "fill_bounds", "mesh_refinements", "warnings")
"""The entries of results.json that ``run --json`` prints, with the ``results`` folder: the verdict and its
checks (the history, the joints and the model's details stay in results.json)."""


def _run(args, petsc: dict) -> int:
    valid = validate(args, petsc)
    scene, size, max_dofs = valid.scene, valid.size, valid.max_dofs
    out = args.out or Path("results") / scene.name
    from mpi4py import MPI

    from ..analysis.runner import run_analysis
    from ..laws.crushing import scene_law
    from ..solver.linear import check_environment_options
    from .results import FILES, write_results

    comm = MPI.COMM_WORLD
    check_environment_options(comm)
    announce = not args.quiet and size.dofs > LARGE_DOFS and comm.rank == 0
    # with --json, stdout holds the JSON object alone: what the run prints on its way goes to stderr
    with contextlib.redirect_stdout(sys.stderr) if args.json else contextlib.nullcontext():
        with claim(out, comm, also=(failed_target(out),), files=FILES):
            for line in valid.notices:
                _notice(line)
            if announce:
                print(f"{scene.name}: {size.describe()}", flush=True)
            report = (lambda s: None) if args.quiet else _progress(scene.live_per_level, scene_law(scene).STATES)
            an = run_analysis(scene, comm, petsc, report=report,
                              phase=_phase if announce else (lambda name: None), notice=_notice, max_dofs=max_dofs)
            failed = Status.of(an.search.status) is Status.FAILURE
            if failed:  # a failed run never replaces earlier results
                kept, out = out, failed_target(out)
            data = write_results(an, out)
        if comm.rank == 0 and failed:
            print(f"bridgefem: solver failure: its results are in {out}/; {kept}/ is left as it was", file=sys.stderr)
    if comm.rank == 0 and args.json:
        print(json.dumps({**{key: data[key] for key in RUN_JSON}, "results": str(out)}))
    elif comm.rank == 0:
        _print_run(scene, data, out)
    return Status.of(data["status"]).exit_code


def _print_run(scene, data: dict, out: Path) -> None:
    """The text summary of a run: its verdict, evidence, mechanism, LP check, mesh refinements and warnings."""
    from .plots import format_bracket

    lim = data["limit_load"]
    limit = Status.of(data["status"]) is Status.LIMIT
    if limit:
        print(f"{scene.name}: {data['status']}; limit load in "
              f"{format_bracket(lim['lower'], lim['upper'], lim['tolerance'])} "
              f"(relative tolerance {lim['tolerance']:g}, width {scene.arch.width:g} m)")
    else:
        print(f"{scene.name}: {data['status']}; carried {lim['lower'] / 1e3:.2f} kN (last converged live load, "
              f"width {scene.arch.width:g} m)")
    if data["evidence"]:
        print(f"  evidence: {data['evidence']}")
    if limit:
        print(f"  above the bracket: {_collapse(data['failure_reason'] or '')} (results.json: failure_reason)")
    elif data["failure_reason"]:
        print(f"  last failed step: {data['failure_reason']}")
    print(f"  hinges at joints {data['mechanism']['hinges']}, sliding joints {data['mechanism']['sliding']}")
    if scene.masonry.compressive_strength is not None:
        print(f"  {_crushed_line(data)}")
    lp = data["lp"]
    if lp["load"]:
        ratio = f", FE/LP = {data['fe_lp_ratio']:.4f}" if data["fe_lp_ratio"] else ""
        print(f"  rigid-block LP check ({lp['model']}): {lp['load'] / 1e3:.2f} kN, hinges "
              f"{lp['mechanism']['hinges']}{ratio}")
    ring = data["ring_under_transmitted_loads"]
    if ring and ring["load"]:
        print(f"  ring under the loads the fill transmits (rigid-block LP): {ring['load'] / 1e3:.2f} kN, "
              f"{ring['ratio']:.4f} x the last converged FE load, hinges {ring['mechanism']['hinges']}")
    if (data["fill_bounds"] or {}).get("programmes"):
        print(f"  {_bounds_line(data['fill_bounds'])}")
    refined = [r["elements_through_thickness"] for r in data["mesh_refinements"]]
    if refined:
        print(f"  mesh: {data['model']['elements_through_thickness']} elements through the thickness, after "
              f"runs with {', '.join(map(str, refined))} (results.json: mesh_refinements)")
    for warning in data["warnings"]:
        print(f"  WARNING: {warning}")
    print(f"  results in {out}/ (results.json, fields.xdmf, load_deflection.png, mechanism.png, report.html)")


def _bounds_line(bounds: dict) -> str:
    """The conic bounds of the bridge with its fill (results.json's ``fill_bounds``): each bound in kN, or why it
    has none (an undecided lower bound with its programme's value where it stopped)."""
    parts = []
    for name in ("lower", "upper"):
        programme = bounds["programmes"][name]
        if bounds[name] is not None:
            parts.append(f"{name} {bounds[name] / 1e3:.2f} kN")
        elif programme.get("load") is not None:
            parts.append(f"{name} undecided (its programme stopped at {programme['load'] / 1e3:.2f} kN, "
                         f"{programme['status']}, after {programme['iterations']} iterations)")
        else:
            parts.append(f"{name} none ({programme['status']})")
    return f"conic bounds of the bridge with its fill (rigid-plastic, fill_bounds): {', '.join(parts)}"


def _crushed_line(data: dict) -> str:
    """The crushed joints of a run's mechanism and the depth (m) of each one's compressed zone (its closed pairs'
    length: results.json's ``compressed_depth``)."""
    crushed = data["mechanism"]["crushed"]
    depth = {j["id"]: j.get("compressed_depth") for j in data["joints"]}
    zones = ", ".join(f"{j}: {depth[j]:.3f} m" for j in crushed) or "none"
    return f"crushed joints {crushed} (compressed zones: {zones})"


def _notice(line: str) -> None:
    """A re-run on a finer mesh, printed by rank 0 (even with --quiet: it changes the run's length and mesh)."""
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:
        print(f"bridgefem: {line}", flush=True)


def _phase(name: str) -> None:
    print(f"  {name} ...", flush=True)


def _levels(text: str) -> list[int]:
    from ..analysis.convergence import check_levels

    try:
        levels = [int(v) for v in text.split(",")]
        check_levels(levels)
    except ValueError as err:
        raise SceneError(f"--levels {text!r}: {err}") from None
    return levels



def _check(args, petsc: dict) -> int:
    """``bridgefem check``: :func:`validate`, as ``run`` with the same options, then the resolved scene (TOML, with
    the size estimate and the notices as comments; or one JSON object)."""
    valid = validate(args, petsc)
    scene, size = valid.scene, valid.size
    if args.json:
        print(json.dumps({"scene": resolved_document(scene), "units": key_units(), "notices": valid.notices,
                          "size": {**dataclasses.asdict(size), "memory_unit": "bytes", "estimate": True}}))
    else:
        notes = "".join(f"# note: {line}\n" for line in valid.notices)
        print(f"# {scene.name}: valid; {size.describe()}\n{notes}{resolved_toml(scene)}", end="")
    return 0


def _lp(args) -> int:
    from .lp_report import lp_summary, rigid_block_result

    scene = load_scene(args.scene)
    res = rigid_block_result(scene, args.friction_model)
    if args.json:
        print(json.dumps(lp_summary(res)))
    else:
        load = "none" if res.load is None else f"{res.load / 1e3:.3f} kN"
        print(f"rigid-block LP ({res.friction_model} friction): {res.status}; collapse load {load}; "
              f"{_mechanism_text(res.by_joint, scene)} ({res.time_s:.3f} s)")
        sides = [f"load {i + 1} on the {s} voussoir" if s != "split" else f"load {i + 1} shared by both voussoirs"
                 for i, s in enumerate(res.load_sides) if s is not None]
        if sides:
            print(f"  point loads on joints (least favourable): {', '.join(sides)}")
        if res.friction_model != "associative" and res.level_associative is not None:
            fixed = "a fixed point" if res.converged else f"no fixed point in {res.iterations} LPs"
            print(f"  associative friction: {res.level_associative * scene.live_per_level / 1e3:.3f} kN; "
                  f"non-associative: {fixed} (one collapse state of several, not a bound: docs/joints-and-lp.md)")
    return 1 if Status.of(res.status) is Status.FAILURE else 0


def _mechanism_text(mech, scene) -> str:
    """A rigid-block mechanism (``LPResult.by_joint``) in words: its hinges and sliding joints by id, and with rings
    how many of the ring interfaces separate and slide."""
    from ..structure.ring import scene_ring

    interfaces = {j.id for j in scene_ring(scene).joints if j.kind == "ring"}
    text = f"hinges {mech.hinges}, sliding {[j for j in mech.sliding if j not in interfaces]}"
    if interfaces:
        slide = sum(j in interfaces for j in mech.sliding)
        text += (f"; of {len(interfaces)} ring interfaces {len(mech.separated)} separate, {slide} slide "
                 "(--json: their ids)")
    return text


def _min_thickness(args) -> int:
    from ..limit.rigid_block import LPFailure
    from ..limit.thickness import NoStableThickness, min_thickness

    scene = load_scene(args.scene)
    if scene.spans:
        raise SceneError("[[span]]: min-thickness finds the least thickness of one ring on "
                         "its springings; allowed is a scene of one span ([arch]); a bridge of several spans: lp")
    try:
        res = min_thickness(scene, friction_model=args.friction_model)
    except (NoStableThickness, LPFailure) as err:
        what = "none" if isinstance(err, NoStableThickness) else "solver failure"
        print(json.dumps({"thickness": None, "reason": f"{what}: {err}"}) if args.json
              else f"minimum thickness under self-weight: {what}: {err}")
        return 1
    if args.json:
        print(json.dumps(res.to_dict()))
    else:
        ratio = "" if res.ratio is None else f", t/R = {res.ratio:.5f}"
        print(f"minimum thickness under self-weight ({args.friction_model} friction): {res.thickness:.5f} m{ratio}")
    return 0


MESHING_COMMANDS = ("run", "converge", "assess")
"""The commands that mesh with Gmsh (on rank 0) and run the FE."""


def _load_gmsh() -> None:
    """Load Gmsh's library before MPI's, PETSc's and DOLFINx's: in this order the dynamic linker loads them all in
    less time than with Gmsh's (and its hundred-odd dependencies) last, where the mesh first needs it
    (docs/benchmarks.md, *Commands that answer at once*). Only the order changes: the mesher imports the same
    module later."""
    import gmsh  # noqa: F401


def command() -> None:
    """The ``bridgefem`` command and ``python -m bridgefem``: :func:`main` on ``sys.argv``, then exit with its code.

    What is still alive then is frozen out of the garbage collector first (:func:`gc.freeze`): the interpreter's
    last collections as it exits would otherwise walk every object of the modules loaded (DOLFINx, UFL, PETSc,
    matplotlib: hundreds of thousands) only to free memory that the process's end returns anyway. Exit handlers
    (MPI's and PETSc's finalisation, :mod:`atexit`) run as before; every file written is closed by then."""
    code = main()
    gc.freeze()
    sys.exit(code)


def main(argv: list[str] | None = None) -> int:
    logging.getLogger().setLevel(logging.WARNING)
    argv = sys.argv[1:] if argv is None else argv
    args, raw = _parser().parse_known_args(argv)
    if args.command in MESHING_COMMANDS and launcher_rank() == 0:
        _load_gmsh()
    try:
        with sigterm_raises():
            takes_petsc = args.command in ("run", "check")
            petsc = _petsc_options(args.petsc, raw, args.options) if takes_petsc else {}
            if raw and not takes_petsc:
                raise _unknown(raw[0], args.options)
            if args.command == "run":
                return _run(args, petsc)
            if args.command == "check":
                return _check(args, petsc)
            if args.command == "converge":
                from .commands import converge_command

                return converge_command(load_scene(args.scene), _levels(args.levels), args.out)
            if args.command == "assess":
                from .assessment import assess_command

                return assess_command(args.scene, args.step, args.out, args.json)
            if args.command == "bounds":
                from .commands import bounds_command

                return bounds_command(load_scene(args.scene), args.json, args.refine, args.plot)
            return _lp(args) if args.command == "lp" else _min_thickness(args)
    except (SceneError, OutputError) as err:
        _error(str(err))
        return 2
    except Terminated:
        _error("terminated by SIGTERM; no results folder was left half-written")
        return 128 + 15
    except KeyboardInterrupt:
        _error("interrupted; no results folder was left half-written")
        return 128 + 2
    except Exception:
        _abort_if_parallel()
        raise


def _error(message: str) -> None:
    """One line on stderr, from one MPI rank (every rank meets the same error)."""
    if launcher_rank() == 0:
        print(f"bridgefem: error: {' '.join(message.split())}", file=sys.stderr, flush=True)


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
