"""``bridgefem assess SCENE... [--step M] [--out DIR] [--json]``: the assessment of each scene's ``[vehicle]``
(:mod:`bridgefem.assess.sweep`) written as assessment.json and report.html (with the pictures) into one results
folder per scene, under the output policy (:mod:`bridgefem.io.output`).

Folders: one scene: ``--out DIR`` or ``results/<name>-assessment``; several: ``<DIR or results>/<name>-assessment``.
Every folder and every scene is checked before anything is computed. The console: one line per confirmed position,
then a summary per scene; with ``--json`` the last line of stdout is one JSON object (one scene) or a list of them.
Loads in N for the scene's width, positions in m from the left springing.
"""
from __future__ import annotations

import contextlib
import json
import math
import sys
from pathlib import Path

from ..assess.sweep import LOCKED, Assessment, assess
from ..scene.keys import SceneError
from ..scene.model import Scene
from ..scene.reader import load_scene
from ..status import Status
from .output import claim, results_folder

FILES = ("assessment.json", "report.html")
JSON_KEYS = ("scene", "status", "adequacy_factor", "lp_adequacy_factor", "critical_x",
             "lp_critical_x", "bounds_factor", "warnings")


def _number(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _position(p) -> dict:
    status = LOCKED if p.factor == math.inf else p.status
    return {"x0": p.x0, "factor": _number(p.factor), "status": status, "hinges": list(p.hinges),
            "sliding": list(p.sliding), "axles_on_span": list(p.axles), "vehicle_load": p.load,
            "refined": p.refined}


def _bounds_factor(crit: dict | None) -> dict | None:
    """The conic bounds of the bridge with its fill at the critical position (results.json's ``fill_bounds``, N)
    as factors of the vehicle load there, and whether the FE bracket lies within them; None without both bounds."""
    b = (crit or {}).get("results", {}).get("fill_bounds") or {}
    if not (b.get("lower") and b.get("upper")) or crit["adequacy"] is None:
        return None
    lo, hi = float(b["lower"] / crit["load"]), float(b["upper"] / crit["load"])
    fe = crit["adequacy"]
    return {"lower": lo, "upper": hi,
            "fe_inside": bool(fe["upper"] is not None and lo <= fe["upper"] and fe["lower"] <= hi)}


def assessment_data(a: Assessment) -> dict:
    """assessment.json of one assessment (every rank holds the same)."""
    v = a.scene.vehicle
    confirmations = []
    for c in a.confirmations:
        s = {k: val for k, val in c.summary.items() if k != "pictures"}
        confirmations.append({
            "x0": c.x0, "load": c.load, "status": c.status, "lp_factor": _number(c.lp_factor),
            "proposed_by": c.proposed_by or "the scene's LP screen",
            "adequacy": None if c.adequacy is None else {"lower": c.adequacy[0], "upper": c.adequacy[1]},
            "ceiling": c.ceiling, "pruned": c.pruned,
            "hinges": s["mechanism"]["hinges"], "sliding": s["mechanism"]["sliding"], "evidence": s["evidence"],
            "warnings": s["warnings"], "seconds": c.seconds, "results": s})
    crit = next((c for c in confirmations if c["x0"] == a.critical_x), None)
    warnings = list(crit["warnings"]) if crit else []
    for c in confirmations:
        if Status.of(c["status"]) is Status.FAILURE and a.adequacy is not None:
            carried = c["results"]["limit_load"]["lower"] / c["load"]
            warnings.append(f"the FE at first-axle x = {c['x0']:.3f} m ended in {c['status']}, having carried the "
                            f"vehicle x {carried:.4f}" + (": above the adequacy factor, which stands" if carried >=
                                                          a.adequacy[0] else ": the adequacy factor may be lower"))
    if a.status == LOCKED:
        warnings.append("the vehicle cannot collapse the bridge at any position screened (locked): no adequacy factor")
    lo = a.adequacy
    return {
        "scene": a.scene.name, "status": a.status,
        "adequacy_factor": None if lo is None else {"lower": lo[0], "upper": lo[1]},
        "critical_x": a.critical_x,
        "lp_adequacy_factor": _number(a.lp_factor), "lp_critical_x": a.lp_critical_x,
        "bounds_factor": _bounds_factor(crit),
        "dispersion_screens": {rule: {"lp_factor": _number(m.factor), "lp_critical_x": m.x0}
                               for rule, m in a.dispersion_minima.items()} or None,
        "vehicle": {"axles": list(v.axles), "spacing": list(v.spacing), "contact_length": v.contact_length,
                    "standard": v.standard, "dispersion": v.dispersion if a.scene.fill is not None else None},
        "step": a.step,
        "units": {"x0": "m, the first (leftmost) axle from the left springing", "load": "N, for the scene's width",
                  "factor": "the vehicle's axle loads on the span times this collapse the bridge"},
        "positions": [_position(p) for p in a.positions],
        "confirmations": [{k: val for k, val in c.items() if k != "results"} for c in confirmations],
        "critical": None if crit is None else {"x0": crit["x0"], "load": crit["load"], "hinges": crit["hinges"],
                                               "sliding": crit["sliding"], "evidence": crit["evidence"],
                                               "results": crit["results"]},
        "warnings": warnings,
        "seconds": a.seconds,
        "versions": crit["results"].get("versions", {}) if crit else {},
    }


def _describe(an) -> dict:
    """results.json's entries of an FE analysis and its pictures (collective)."""
    from .results import pictures, summary

    data = summary(an)
    level = max(an.scene.vehicle.axles) if an.scene.vehicle is not None else None  # factor 1: the heaviest axle
    return {**data, "pictures": pictures(an, data, level)}


def _check_step(step: float | None, scenes: list[Scene]) -> None:
    if step is None:
        return
    span = min(s.arch.span for s in scenes)
    if not (math.isfinite(step) and 1e-3 * span <= step <= span):
        raise SceneError(f"--step {step!r}: allowed is a number of metres from 1e-3 x span to the span "
                         f"({1e-3 * span:g} to {span:g} m)")


def assess_command(paths: list[Path], step: float | None, out: Path | None, as_json: bool) -> int:
    """The command (module docstring); exit code 0, or 1 when an assessment ends in a solver failure."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    scenes = [load_scene(p) for p in paths]
    for p, s in zip(paths, scenes):
        if s.vehicle is None:
            raise SceneError(f"{p}: [vehicle]: missing; bridgefem assess rolls the scene's [vehicle] across the "
                             "bridge (axles = [N, ...] and spacing = [m, ...], or standard = \"<name>\")")
    names = [s.name for s in scenes]
    if len(set(names)) != len(names):
        raise SceneError(f"scene names {names}: each assessment needs its own folder; allowed are scenes with "
                         "different names")
    _check_step(step, scenes)
    if len(scenes) == 1:
        folders = [out or Path("results") / f"{scenes[0].name}-assessment"]
    else:
        folders = [(out or Path("results")) / f"{s.name}-assessment" for s in scenes]
    stack = contextlib.ExitStack()
    with stack:
        for f in folders:
            stack.enter_context(claim(f, comm, files=FILES))

        def progress(line: str) -> None:
            print(line, file=sys.stderr if as_json else sys.stdout, flush=True)

        results = assess(scenes, comm, step, describe=_describe, progress=progress)
    summaries = []
    for a, folder in zip(results, folders):
        data = assessment_data(a)
        crit = next((c for c in a.confirmations if c.x0 == a.critical_x), None)
        pics = dict(crit.summary.get("pictures", {})) if crit else {}
        with results_folder(folder, comm) as tmp:
            if comm.rank == 0:
                import io

                from .plots import plot_adequacy
                from .report import assessment_report

                buf = io.BytesIO()
                plot_adequacy(data, buf)
                pics["adequacy"] = buf.getvalue()
                (tmp / "assessment.json").write_text(json.dumps(data, indent=2))
                (tmp / "report.html").write_text(assessment_report(data, pics))
        summaries.append({**{k: data[k] for k in JSON_KEYS},
                          "adequacy_bracket": data["adequacy_factor"] and [data["adequacy_factor"]["lower"],
                                                                           data["adequacy_factor"]["upper"]],
                          "adequacy_factor": data["adequacy_factor"] and data["adequacy_factor"]["lower"],
                          "results": str(folder)})
        if comm.rank == 0 and not as_json:
            _print(data, folder)
    if comm.rank == 0 and as_json:
        print(json.dumps(summaries[0] if len(summaries) == 1 else summaries))
    return 1 if any(a.status.startswith(Status.FAILURE) for a in results) else 0


def _print(data: dict, folder: Path) -> None:
    """The summary of one assessment."""
    lp = data["lp_adequacy_factor"]
    lp_text = "none" if lp is None else f"{lp:.4f} at x = {data['lp_critical_x']:.3f} m"
    if data["adequacy_factor"]:
        a = data["adequacy_factor"]
        print(f"{data['scene']}: adequacy factor in [{a['lower']:.4f}, {a['upper']:.4f}] (FE), first axle at "
              f"x = {data['critical_x']:.3f} m from the left springing; rigid-block LP {lp_text}")
        crit = data["critical"]
        print(f"  hinges at joints {crit['hinges']}, sliding joints {crit['sliding']}")
        b = data["bounds_factor"]
        if b:
            print(f"  conic bounds of the bridge with its fill there: [{b['lower']:.4f}, {b['upper']:.4f}], the FE "
                  + ("inside them" if b["fe_inside"] else "OUTSIDE them"))
    else:
        print(f"{data['scene']}: {data['status']}; rigid-block LP {lp_text}")
    for w in data["warnings"]:
        print(f"  WARNING: {w}")
    print(f"  {len(data['positions'])} positions screened; results in {folder}/ (assessment.json, report.html)")
