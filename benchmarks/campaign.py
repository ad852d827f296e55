"""Seeded random-scene campaign: does every arch a user can write end in a verdict the rigid-block LP confirms?

Each scene is drawn from the seed and its index alone (so one scene can be re-run with ``--only``):

- shape: all five; span 3-30 m; rise/span 0.15-0.5 (segmental 0.1-0.45, pointed 0.55-1.0);
- thickness t uniform from the least the shape stands under self-weight (:func:`bridgefem.limit.thickness.
  min_thickness`, at the scene's mu) to 0.4 of the centreline radius (circular shapes) or of the rise (others); when
  no thickness stands (low mu) from 0.05 to 0.4 of it, and the expected verdict is "unstable under self-weight";
- voussoirs 4-256 (log-uniform); mu 0.3-10 (log-uniform); E 1e8-1e11 Pa (log-uniform);
- one point load (70 %) or patch (up to 0.3 of the span) anywhere on the span; ``joint_at_loads`` true or false;
- ``FILL_SHARE`` of the scenes with a shallow fill (elastic, or Mohr-Coulomb: always under a patch, since a point
  force on a plastic continuum has no finite collapse load and the scene refuses it).

With ``--options`` every scene also gets one of the other things a scene file can ask for (:data:`OPTIONS`, drawn
from its own stream, :func:`draw_option`; without it the scene is the base campaign's): a second point load anywhere
on the span with a factor 0.2-1; elastic abutments 0.5-3 m high; a support movement at the left, right or both
springings, horizontal (spreading or closing) and, for half of them, a settlement, each 1e-5 to 1e-3 of the span
(log-uniform), imposed after the self-weight; the "fast" or "accurate" preset; quadratic elements; plane stress. The
rigid-block LP of results.json models the same loads and the abutments as rigid blocks, and ignores the movement
(a limit load of rigid blocks does not depend on a small support movement). With ``--ranks N`` every scene runs
under ``mpirun -n N`` (the same verdict and limit as the serial run is the brief's requirement).

Every scene is run by the command line (``bridgefem run``) in a subprocess with a timeout, and judged against the
rigid-block LP on the same joints that the run reports (results.json ``lp``, associative friction):

- *confirmed*: FE and LP give the same verdict; for a limit load, the FE bracket within ``NO_SLIP_TOL`` of the LP
  (:func:`bridgefem.analysis.evidence.reaches`, the evidence rule's agreement) when no joint slides (FE or LP), its lower end
  at most ``1 + NO_SLIP_TOL`` x LP when one does (and its upper end below ``1 - NO_SLIP_TOL`` x LP only
  with a proved mechanism: results.json ``evidence``); with a Mohr-Coulomb fill against the conic bounds of the
  bridge with its fill (results.json ``fill_bounds``, N): its lower bound x (1 - ``NO_SLIP_TOL``) at most the FE
  bracket's lower end and the bracket's upper end at most (1 + ``BOUND_TOL``) x the upper bound (the dead-load LP
  is no floor: the fill can fail under the load first); with an elastic fill (no bounds) any FE verdict at or
  above the LP with the fill as dead load (every verdict is, where that LP is unstable under self-weight: the
  elastic fill can hold up a ring that its weight alone brings down), or a limit at which the rings under the loads
  the fill transmits collapse (results.json ``ring_under_transmitted_loads``: ratio within ``NO_SLIP_TOL`` of 1; the
  fill spreads a load over a pier into the spans beside it, which the dead-load LP's load on the pier cannot);
- *solver failure*: the run says so (exit 1): honest, but no answer;
- *wrong*: a verdict the LP contradicts (e.g. "unstable" while the LP stands, or FE far from the LP);
  *wrong (fill mesh not converged)*: a fill scene's FE limit above the conic upper bound (docs/fill.md), counted
  apart;
- *crash*: a traceback, a signal, another exit code, or the timeout (``--timeout`` per span of a bridge);
- *unjudged (LP failed)*: the rigid-block LP of results.json failed, so that nothing confirms or contradicts the
  FE's verdict (not confirmed); *unjudged (bounds failed)*: with a Mohr-Coulomb fill, a limit at most the conic upper
  bound whose lower bound's programme gave no value (the dead-load LP is no floor: nothing confirms the limit);
- *rejected*: the scene is refused as bad input (exit 2, one line naming the key), e.g. a patch whose edges would
  leave a voussoir of (almost) no length; not counted in the success rate.

Prints one row per scene, the success rate, the classes, solves per limit (median, max; a scene's linear solves
summed over all its runs, the coarser meshes an automatic refinement replaced included) and the worst cases; writes
``campaign.json`` beside the scenes. Run::

    ./run nice python benchmarks/campaign.py --count 300 --seed 1 --jobs 2 --out /tmp/campaign
    ./run nice python benchmarks/campaign.py --count 150 --seed 1 --jobs 2 --options --out /tmp/campaign-options

With ``--rings`` every scene is a barrel of rings (:func:`draw_rings`, its own stream): 2-4 rings of equal
thickness, staggered or aligned, ring friction 0-0.8, ring cohesion 0 (a third of the scenes: unbonded) or 1-100 kPa
(log-uniform), at most ``RING_VOUSSOIRS`` voussoirs per ring; its thickness drawn as above from the least thickness of
the whole barrel (every ring scaled; to ``RING_RTOL``), judged as above against the LP on the same joints (the ring interfaces as their
chords)::

    ./run nice python benchmarks/campaign.py --count 100 --seed S --jobs 1 --rings --out /tmp/campaign-rings

With ``--spans`` every scene is a bridge of 2-5 spans on piers (:func:`draw_spans`, its own stream; the base draw
gives the shape, rise/span, thickness fraction, voussoirs, mu, E and the load's kind): spans 3-20 m, piers from stocky
to slender, ``SPAN_FILL_SHARE`` of them under a fill, the load anywhere on the bridge (over a pier too), judged as
above against the LP on the same blocks (spans and pier courses) or the fill's conic bounds::

    ./run nice python benchmarks/campaign.py --count 100 --seed S --jobs 1 --spans --out /tmp/campaign-spans

``--check-only`` writes the scenes and runs ``bridgefem check`` on each instead (no analysis; the LP still sets each
thickness): the scenes a campaign would reject as bad input, in a few minutes.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from bridgefem.analysis.evidence import AGREEMENT, reaches
from bridgefem.io.targets import failed_target
from bridgefem.limit.conic import INFEASIBLE

SHAPES = ("semicircular", "segmental", "pointed", "elliptical", "parabolic")
RISE_RATIO = {"segmental": (0.1, 0.45), "pointed": (0.55, 1.0), "elliptical": (0.15, 0.5), "parabolic": (0.15, 0.5)}
OPTIONS = ("second load", "elastic abutments", "support movement", "preset", "quadratic elements", "plane stress")
# the scene options of an --options campaign: the other sections and keys a user writes (docs/user-guide.md)
FILL_SHARE = 0.04  # scenes with a fill: a few (each costs about ten bare runs)
NO_SLIP_TOL = AGREEMENT  # FE within this fraction of the LP where no joint slides (issue 12)
BOUND_TOL = 0.005  # the FE bracket's upper end at most this fraction above the conic upper bound of a fill scene
MPIRUN_ENV = {"OMPI_MCA_rmaps_base_oversubscribe": "1"}  # --ranks: Open MPI may count fewer slots than ranks (a
# container's CPU limit), and then refuses to start; the rest of mpirun's environment is Python's copy of this
# process's, without the job variables (PMIX_*, OMPI_MCA_ess, ...) an MPI singleton sets in the C environment
RING_VOUSSOIRS = 32  # --rings: voussoirs per ring at most (4 rings of 64 make an LP of 3300 joints, 12 s, the ring
# interfaces being their chords; 256 would make 1024 blocks)
RING_RTOL = 1e-2  # --rings: the least thickness to 1 % (each LP of a barrel costs seconds; the draw needs no more)
SPAN_VOUSSOIRS = 64  # --spans: voussoirs per span at most (five spans of 256 would make a model of 1280 voussoirs)
SPAN_FILL_SHARE = 0.2  # --spans: bridges with a fill (each costs about ten bare ones)
TIMEOUT_S = 300.0  # a run that takes longer is a crash (the default demo takes about 3 s)


def draw(seed: int, index: int) -> dict:
    """The random choices of scene ``index`` (everything but the thickness, which needs the LP)."""
    rng = np.random.default_rng([seed, index])
    shape = SHAPES[rng.integers(len(SHAPES))]
    span = float(rng.uniform(3.0, 30.0))
    rise = span / 2 if shape == "semicircular" else float(span * rng.uniform(*RISE_RATIO[shape]))
    patch = round(float(rng.uniform(0.02, 0.3)) * span, 3) if rng.random() > 0.7 else 0.0
    choice = {
        "index": index, "shape": shape, "span": round(span, 3), "rise": round(rise, 3),
        "thickness_fraction": float(rng.random()),
        "voussoirs": int(round(math.exp(rng.uniform(math.log(4), math.log(256))))),
        "friction": round(float(math.exp(rng.uniform(math.log(0.3), math.log(10.0)))), 3),
        "young": float(f"{math.exp(rng.uniform(math.log(1e8), math.log(1e11))):.3g}"),
        "position": float(rng.random()),  # of the span the load's centre can take, placed below
        "patch": patch,
        "joint_at_loads": bool(rng.random() > 0.3),
        "fill": ("mohr-coulomb" if rng.random() < 0.5 else "elastic") if rng.random() < FILL_SHARE else None,
    }
    if choice["fill"] == "mohr-coulomb" and not patch:  # a point force on a plastic fill has no finite collapse load
        choice["patch"] = round(float(rng.uniform(0.02, 0.3)) * span, 3)
    edge = choice["patch"] / 2 / span  # a patch lies on the span
    choice["position"] = round(edge + (1 - 2 * edge) * choice["position"], 4)
    return choice


def draw_vehicle(seed: int, index: int, span: float, fill: str | None) -> dict:
    """Scene ``index``'s vehicle in a ``--vehicles`` campaign (its own stream): 1-3 axles of 20-200 kN, spaced
    0.1-0.5 of the span; point axles, or tyre patches of 0.02-0.1 of the span over a fill."""
    rng = np.random.default_rng([seed, index, 40])
    n = int(rng.integers(1, 4))
    contact = round(float(rng.uniform(0.02, 0.1)) * span, 3) if fill else 0.0
    spacing = [round(max(float(rng.uniform(0.1, 0.5)) * span, 1.5 * contact + 1e-3), 3) for _ in range(n - 1)]
    return {"axles": [round(float(rng.uniform(20e3, 200e3)), -2) for _ in range(n)], "spacing": spacing,
            "contact_length": contact}


def draw_option(seed: int, index: int) -> dict:
    """Scene ``index``'s option in an ``--options`` campaign: one of :data:`OPTIONS` with its values, drawn from its
    own stream (the base draw of the scene is :func:`draw`'s, unchanged)."""
    rng = np.random.default_rng([seed, index, 1])
    name = OPTIONS[rng.integers(len(OPTIONS))]
    values = {
        "second load": lambda: {"position": round(float(rng.random()), 4),
                                "factor": round(float(rng.uniform(0.2, 1.0)), 3)},
        "elastic abutments": lambda: {"height": round(float(rng.uniform(0.5, 3.0)), 3)},
        "support movement": lambda: {
            "springing": ("left", "right", "both")[rng.integers(3)],
            "horizontal": float(f"{rng.choice((-1, 1)) * math.exp(rng.uniform(math.log(1e-5), math.log(1e-3))):.3g}"),
            "vertical": float(f"{-math.exp(rng.uniform(math.log(1e-5), math.log(1e-3))) * rng.integers(2):.3g}")},
        "preset": lambda: {"preset": ("fast", "accurate")[rng.integers(2)]},
        "quadratic elements": dict,
        "plane stress": dict,
    }[name]()
    return {"name": name, **values}


def draw_rings(seed: int, index: int) -> dict:
    """Scene ``index``'s rings in a ``--rings`` campaign, from their own stream (the base draw is :func:`draw`'s,
    unchanged): 2-4 rings, "staggered" or "aligned", ring friction uniform 0-0.8, ring cohesion 0 for a third of the
    scenes, else log-uniform 1-100 kPa."""
    rng = np.random.default_rng([seed, index, 41])
    rings, bond = int(rng.integers(2, 5)), ("staggered", "aligned")[rng.integers(2)]
    friction = round(float(rng.uniform(0.0, 0.8)), 3)
    cohesion = 0.0 if rng.random() < 1 / 3 else float(f"{math.exp(rng.uniform(math.log(1e3), math.log(1e5))):.3g}")
    return {"rings": rings, "bond": bond, "friction": friction, "cohesion": cohesion}


def draw_spans(seed: int, index: int, choice: dict) -> dict:
    """Scene ``index``'s bridge in a ``--spans`` campaign, from its own stream (the base draw ``choice`` gives the
    shape, rise/span, thickness fraction, voussoirs, mu, E, the load's kind and ``joint_at_loads``): 2-5 spans of
    3-20 m (uniform), each with the base draw's rise/span and at most ``SPAN_VOUSSOIRS`` voussoirs; piers from stocky
    to slender: width from just above the least its springings allow (the fraction ``width`` of the range up to 0.4
    x the mean of its spans), height log-uniform 0.2-3 x that mean, batter 0 for half of them else uniform 0-0.1,
    1-8 courses; the load anywhere on the bridge (``position``: the fraction of the bridge's length its centre takes,
    a patch kept on it); ``SPAN_FILL_SHARE`` of the bridges with a fill (elastic or Mohr-Coulomb, half each)."""
    rng = np.random.default_rng([seed, index, 42])
    n = int(rng.integers(2, 6))
    spans = [round(float(rng.uniform(3.0, 20.0)), 3) for _ in range(n)]
    piers = [{"width": float(rng.random()), "height": round(float(math.exp(rng.uniform(math.log(0.2), math.log(3.0)))),
                                                            3),
              "batter": 0.0 if rng.random() < 0.5 else round(float(rng.uniform(0.0, 0.1)), 3),
              "blocks": int(rng.integers(1, 9))} for _ in range(n - 1)]
    fill = ("mohr-coulomb" if rng.random() < 0.5 else "elastic") if rng.random() < SPAN_FILL_SHARE else None
    return {"spans": spans, "piers": piers, "fill": fill, "position": float(rng.random())}


def span_arch(choice: dict, span: float, thickness: float) -> dict:
    """The ``[[span]]`` table of one span of a ``--spans`` draw: the base draw's shape, rise/span and voussoirs
    (at most ``SPAN_VOUSSOIRS``) at this span and thickness (m)."""
    shape = choice["shape"]
    return {"shape": shape, "span": span,
            **({} if shape == "semicircular" else {"rise": round(choice["rise"] / choice["span"] * span, 3)}),
            "thickness": round(thickness, 4), "width": 1.0, "voussoirs": min(choice["voussoirs"], SPAN_VOUSSOIRS),
            "joint_at_loads": choice["joint_at_loads"]}


def bridge_dict(choice: dict) -> tuple[dict, list[float | None]]:
    """The scene file (as a dictionary) of a ``--spans`` draw, and each span's least thickness (m; None where none
    stands): each span's thickness the base draw's fraction of its own range (:func:`thickness_above`), each pier's
    width the draw's fraction from 1.02 x the least its springings allow to 0.4 x the mean of its spans."""
    from bridgefem.scene.keys import springing_reach

    b = choice["bridge"]
    arches, least = [], []
    for span in b["spans"]:
        one = {**choice, "span": span, "rise": span / 2 if choice["shape"] == "semicircular"
               else round(choice["rise"] / choice["span"] * span, 3), "voussoirs": min(choice["voussoirs"],
                                                                                      SPAN_VOUSSOIRS)}
        t, t_min = thickness_of(one)
        arches.append(span_arch(choice, span, t))
        least.append(t_min)
    piers = []
    for k, pier in enumerate(b["piers"]):
        left, right = arches[k], arches[k + 1]
        reach = sum(springing_reach({**a, "rise": a.get("rise", a["span"] / 2)}) for a in (left, right))
        mean = 0.5 * (left["span"] + right["span"])
        low = 1.02 * reach + 1e-3
        piers.append({"width": round(low + pier["width"] * max(0.4 * mean - low, 0.0), 3),
                      "height": round(pier["height"] * mean, 3), "batter": pier["batter"], "blocks": pier["blocks"]})
    length = sum(a["span"] for a in arches) + sum(p["width"] for p in piers)
    patch = round(choice["patch"] / choice["span"] * arches[0]["span"], 3) if choice["patch"] or b["fill"] == \
        "mohr-coulomb" else 0.0
    if b["fill"] == "mohr-coulomb" and not patch:  # a point force on a plastic fill has no finite collapse load
        patch = round(0.1 * arches[0]["span"], 3)
    load = {"kind": "patch" if patch else "point",
            "x": round(patch / 2 + (length - patch) * b["position"], 4)}
    if patch:
        load["length"] = patch
    d = {"scene": {"name": f"campaign_{choice['index']}"}, "span": arches, "pier": piers,
         "masonry": {"young": choice["young"], "poisson": 0.2, "density": 2000.0},
         "joints": {"friction": choice["friction"]}, "load": [load]}
    if b["fill"]:
        top = max(b["spans"])
        d["fill"] = {"unit_weight": 18e3, "young": 50e6, "depth": round(0.05 * top, 3),
                     "extension": round(0.2 * arches[0]["span"], 3), "material": b["fill"],
                     **({"cohesion": 5e3} if b["fill"] == "mohr-coulomb" else {})}
    return d, least


def draw_strength(seed: int, index: int) -> float:
    """Scene ``index``'s compressive strength in a ``--crushing`` campaign, from its own stream (the base draw is
    :func:`draw`'s, unchanged), as a multiple of the self-weight stress scale density x g x the reference length
    (:func:`reference_length`): log-uniform from 2 (weak enough that a ring barely stands, or none does) to 2000
    (strong: the limit within a few per cent of the infinitely strong ring's)."""
    rng = np.random.default_rng([seed, index, 2])
    return float(f"{math.exp(rng.uniform(math.log(2.0), math.log(2000.0))):.3g}")


def strength_of(choice: dict) -> float:
    """The compressive strength (Pa) of a ``--crushing`` draw: its ratio x density x g x the reference length."""
    return float(f"{choice['strength'] * 2000.0 * 9.81 * reference_length(choice, 0.0):.4g}")


def with_option(d: dict, choice: dict) -> dict:
    """The scene dictionary ``d`` of a draw ``choice`` with its ``option`` (:func:`draw_option`): a second load (its
    share of the load pattern ``factor``; a point, or on a Mohr-Coulomb fill a patch as long as the first, on the
    span apart from it), elastic abutments of a ``height`` in m, a support movement of ``horizontal`` /
    ``vertical`` x the span (m/m), a speed-accuracy preset, quadratic elements, plane stress."""
    option, span = choice["option"], choice["span"]
    name = option["name"]
    if name == "second load":
        load = {"kind": "point", "position": option["position"], "factor": option["factor"]}
        if choice["fill"] == "mohr-coulomb":  # a point force on a plastic fill has no finite collapse load
            edge, first = choice["patch"] / 2 / span, choice["position"]  # in the other half, apart from the first
            low, high = (first + 2 * edge + 0.01, 1 - edge) if first < 0.5 else (edge, first - 2 * edge - 0.01)
            load.update(kind="patch", length=choice["patch"], position=round(low + (high - low) * load["position"], 4))
        d["load"].append(load)
    elif name == "elastic abutments":
        d["abutments"] = {"model": "elastic", "height": option["height"]}
    elif name == "support movement":
        d["abutments"] = {"movement_springing": option["springing"],
                          "movement_horizontal": round(option["horizontal"] * span, 6),
                          "movement_vertical": round(option["vertical"] * span, 6)}
    elif name == "preset":
        d["solver"] = {"preset": option["preset"]}
    elif name == "quadratic elements":
        d["mesh"] = {"degree": 2}
    else:
        d["model"] = {"plane": "stress"}
    return d


def scene_dict(choice: dict, thickness: float) -> dict:
    """The scene file (as a dictionary) of a draw at a thickness (m)."""
    load = {"kind": "patch" if choice["patch"] else "point", "position": choice["position"]}
    if choice["patch"]:
        load["length"] = choice["patch"]
    d = {"scene": {"name": f"campaign_{choice['index']}"},
         "arch": {"shape": choice["shape"], "span": choice["span"],
                  **({} if choice["shape"] == "semicircular" else {"rise": choice["rise"]}),
                  "thickness": round(thickness, 4), "width": 1.0, "voussoirs": choice["voussoirs"],
                  "joint_at_loads": choice["joint_at_loads"]},
         "masonry": {"young": choice["young"], "poisson": 0.2, "density": 2000.0,
                     **({"compressive_strength": strength_of(choice)} if choice.get("strength") else {})},
         "joints": {"friction": choice["friction"]},
         "load": [load]}
    if choice.get("rings"):
        r = choice["rings"]
        d["arch"].update(rings=r["rings"], ring_bond=r["bond"], voussoirs=min(choice["voussoirs"], RING_VOUSSOIRS))
        d["joints"].update(ring_friction=r["friction"], ring_cohesion=r["cohesion"])
    if choice["fill"]:
        d["fill"] = {"unit_weight": 18e3, "young": 50e6, "depth": round(0.05 * choice["span"], 3),
                     "extension": round(0.2 * choice["span"], 3), "material": choice["fill"],
                     **({"cohesion": 5e3} if choice["fill"] == "mohr-coulomb" else {})}
    if choice.get("vehicle"):  # an assessment: the vehicle instead of the loads
        d["load"], d["vehicle"] = [], choice["vehicle"]
    return with_option(d, choice) if choice.get("option") else d


def reference_length(choice: dict, thickness: float) -> float:
    """The centreline radius (circular shapes) or the rise (others), m: the scale of the thickest ring drawn."""
    span, rise = choice["span"], choice["rise"]
    if choice["shape"] in ("semicircular", "segmental"):
        return (span ** 2 / 4 + rise ** 2) / (2 * rise) + thickness / 2
    return rise


def thickness_of(choice: dict) -> tuple[float, float | None]:
    """The scene's thickness (m) and the least thickness that stands (m; None when none does)."""
    from bridgefem.limit.thickness import min_thickness
    from bridgefem.scene.reader import scene_from_dict

    try:
        bare = {**choice, "patch": 0.0, "joint_at_loads": False, "fill": None, "option": None}  # nor do loads
        # (a barrel of rings: the least thickness of the whole barrel, every ring scaled)
        least = min_thickness(scene_from_dict(scene_dict(bare, 0.1 * choice["rise"])),
                              rtol=RING_RTOL if choice.get("rings") else 1e-4).thickness
    except (RuntimeError, ValueError):  # no thickness stands at this mu
        least = None
    return thickness_above(choice, least), least


def thickness_above(choice: dict, least: float | None) -> float:
    """The scene's thickness (m) given the least thickness that stands (m; None when none does): the draw's fraction
    of the range from it to 0.4 x :func:`reference_length` (from 0.05 x that length when none stands)."""
    top = 0.4 * reference_length(choice, 0.0)
    bottom = 0.05 * top / 0.4 if least is None or least >= top else least
    return bottom + choice["thickness_fraction"] * (top - bottom)


def to_toml(d: dict) -> str:
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        return json.dumps(v)

    lines = []
    for section, body in d.items():
        for entry in body if isinstance(body, list) else [body]:
            lines.append(f"[[{section}]]" if isinstance(body, list) else f"[{section}]")
            lines += [f"{k} = {value(v)}" for k, v in entry.items()]
    return "\n".join(lines) + "\n"


def write_scene(choice: dict, out: Path) -> tuple[Path, dict]:
    """Write the scene of a draw (its thickness from :func:`thickness_of`; a bridge of spans: :func:`bridge_dict`)
    to ``out``/scene_NNNN/scene.toml; returns the folder and the row of the draw with its thickness and least
    thickness (a bridge of spans: the first span's)."""
    if choice.get("bridge"):
        scene, least = bridge_dict(choice)
        row = {**choice, "fill": choice["bridge"]["fill"], "thickness": scene["span"][0]["thickness"],
               "least_thickness": least[0], "span": scene["span"][0]["span"], "position": choice["bridge"]["position"],
               "patch": scene["load"][0].get("length", 0.0), "spans": len(scene["span"]),
               "piers": scene["pier"]}
    else:
        thickness, least = thickness_of(choice)
        scene = scene_dict(choice, thickness)
        row = {**choice, "thickness": scene["arch"]["thickness"], "least_thickness": least}
    folder = out.resolve() / f"scene_{choice['index']:04d}"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "scene.toml").write_text(to_toml(scene))
    return folder, row


def check_scene(choice: dict, out: Path) -> str:
    """Write the scene and run ``bridgefem check`` on it (every check ``run`` makes before its analysis, no analysis):
    "valid", or the line it was refused with."""
    folder, _ = write_scene(choice, out)
    proc = subprocess.run([sys.executable, "-m", "bridgefem.io.cli", "check", str(folder / "scene.toml")],
                          capture_output=True, text=True, cwd=folder)
    return "valid" if proc.returncode == 0 else proc.stderr.strip() or f"exit {proc.returncode}"


def run_scene(choice: dict, out: Path, timeout: float, ranks: int = 1) -> dict:
    """Write the scene, run ``bridgefem run`` on it in a subprocess (under ``mpirun -n ranks`` when ranks > 1),
    and judge the outcome."""
    folder, row = write_scene(choice, out)
    timeout *= row.get("spans", 1)  # a bridge of n spans is n arches' work, and their piers'
    command = [sys.executable, "-m", "bridgefem.io.cli", "run", str(folder / "scene.toml"), "--out",
               str(folder / "results"), "--quiet"]
    if choice.get("vehicle"):
        command = [sys.executable, "-m", "bridgefem.io.cli", "assess", str(folder / "scene.toml"), "--out",
                   str(folder / "results"), "--json"]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(["mpirun", "-n", str(ranks), *command] if ranks > 1 else command, capture_output=True,
                              text=True, timeout=timeout, env={**os.environ, **MPIRUN_ENV},
                              cwd=folder)  # not the source tree: PYTHONPATH may point at another copy
        code, stderr = proc.returncode, proc.stderr
    except subprocess.TimeoutExpired:
        code, stderr = None, f"timeout after {timeout:g} s"
    row["seconds"] = time.perf_counter() - t0
    row["exit"] = code
    if choice.get("vehicle"):
        row.update(judge_assessment(folder, code, stderr, fill=choice["fill"] is not None))
        return row
    row.update(judge(results_of(folder), code, stderr, fill=row["fill"] is not None))
    return row


def judge_assessment(folder: Path, code: int | None, stderr: str, fill: bool) -> dict:
    """An assessment (``--vehicles``) judged by :func:`judge` on the FE run at its critical position (results.json's
    entries in assessment.json), and its LP adequacy factor against the LP of that run (the same scene, the same
    loads: they must agree to 1e-6). Locked or unstable by the LP screen alone (no FE run): "lp only"."""
    path = folder / "results" / "assessment.json"
    data = json.loads(path.read_text()) if path.exists() else None
    if data is None or data["critical"] is None:
        if data is not None and code == 0 and data["status"] in ("locked", "unstable under self-weight"):
            return {"class": "lp only", "status": data["status"], "fe": None, "lp": None, "ratio": None,
                    "solves": None}
        return judge(None, code, stderr, fill)
    crit = data["critical"]
    out = judge(crit["results"], code, stderr, fill)
    confirmation = next(c for c in data["confirmations"] if c["x0"] == crit["x0"])
    lp_run = crit["results"]["lp"]["load"]
    if not fill and lp_run and confirmation["lp_factor"] is not None \
            and abs(lp_run / crit["load"] - confirmation["lp_factor"]) > 1e-6 * confirmation["lp_factor"]:
        out = {**out, "class": "wrong", "status": "the screen's LP factor differs from the run's LP"}
    return {**out, "adequacy": data["adequacy_factor"], "lp_adequacy": data["lp_adequacy_factor"]}


def results_of(folder: Path) -> dict | None:
    """A scene's results.json: in ``results/``, or in ``results-failed/`` after a solver failure (the output
    policy: a failed run never replaces results); None when the run wrote neither."""
    for path in (folder / "results", failed_target(folder / "results")):
        if (path / "results.json").exists():
            return json.loads((path / "results.json").read_text())
    return None


UNJUDGED = ("unjudged (LP failed)", "unjudged (bounds failed)")  # the reference failed: no verdict either way


def judge(data: dict | None, code: int | None, stderr: str, fill: bool = False) -> dict:
    """The class of a run (confirmed / solver failure / wrong / crash) and its numbers, from results.json."""
    if code == 2 and data is None and "Traceback" not in stderr:
        return {"class": "rejected", "status": stderr.strip()[:160], "fe": None, "lp": None, "ratio": None,
                "solves": None}
    if code not in (0, 1) or data is None or "Traceback" in stderr:
        tail = stderr.strip().splitlines()[-1] if stderr.strip() else f"exit {code}"
        return {"class": "crash", "status": tail[:160], "fe": None, "lp": None, "ratio": None, "solves": None}
    lim, lp = data["limit_load"], data["lp"]
    status, lp_status = data["status"], lp["status"]
    mid = 0.5 * (lim["lower"] + lim["upper"]) if lim["upper"] is not None else None
    ratio = mid / lp["load"] if mid and lp["load"] else None
    sliding = bool(data["mechanism"]["sliding"] or lp["mechanism"]["sliding"])
    # below the associative LP only with a proof or the non-associative rigid-block check (bridgefem/analysis/evidence.py)
    proved = data.get("evidence", "").startswith(("proof", "agreement: the non-associative"))
    out = {"status": status, "lp_status": lp_status, "fe": mid, "lp": lp["load"], "ratio": ratio,
           "sliding": sliding, "solves": data["solver"]["solves"] + sum(r["solves"] for r in data["mesh_refinements"]),
           "reason": data.get("failure_reason", "")}
    if status.startswith("solver failure"):
        cls = "solver failure"
        if code != 1 or lim["upper"] is not None:
            cls = "wrong"  # a failure must exit 1 without a bracket
    elif status.startswith("no collapse") and lp_status == "limit load found":
        # locked at the search's maximum load: confirmed when the LP collapses only above it (or a fill carries it)
        cls = "confirmed" if fill or lp["load"] >= (1 - NO_SLIP_TOL) * lim["lower"] else "wrong"
    elif status == "limit load found" and fill and (data.get("fill_bounds") or {}).get("lower"):
        # conic bounds of the bridge with its fill (N; upper None: no finite upper bound); the dead-load LP is no
        # floor and no ceiling
        bounds = data["fill_bounds"]
        out.update(bound_lower=bounds["lower"], bound_upper=bounds["upper"])
        if bounds["upper"] is not None and lim["upper"] > (1 + BOUND_TOL) * bounds["upper"]:
            cls = "wrong (fill mesh not converged)"
        else:
            cls = "confirmed" if bounds["lower"] * (1 - NO_SLIP_TOL) <= lim["lower"] else "wrong"
    elif status == "limit load found" and fill and (data.get("fill_bounds") or {}).get("programmes"):
        # conic bounds computed (a Mohr-Coulomb fill) without a lower bound: only the upper bound can contradict
        upper = data["fill_bounds"]["upper"]
        out.update(bound_lower=None, bound_upper=upper)
        cls = ("wrong (fill mesh not converged)" if upper is not None and lim["upper"] > (1 + BOUND_TOL) * upper
               else "unjudged (bounds failed)")
    elif fill and status == "unstable under self-weight" and (((data.get("fill_bounds") or {}).get("programmes") or {})
                                                                .get("upper") or {}).get("status") == INFEASIBLE:
        cls = "confirmed"  # the conic kinematic programme's certificate: the bridge with its fill cannot stand
    elif fill and not (data.get("fill_bounds") or {}).get("lower") and lp_status == "unstable under self-weight":
        cls = "confirmed"  # an elastic fill can hold up a ring that falls under the fill's weight alone: any verdict
        # is at or above that LP
    elif fill and status == "limit load found" and not (data.get("fill_bounds") or {}).get("lower") \
            and abs(((data.get("ring_under_transmitted_loads") or {}).get("ratio") or 0.0) - 1) <= NO_SLIP_TOL:
        cls = "confirmed"  # an elastic fill: the rings under the loads it transmits collapse at the FE's limit (it
        # spreads a load over a pier into the spans beside it, where the dead-load LP's load on the pier cannot)
    elif lp_status.startswith("LP failed"):
        cls = "unjudged (LP failed)"  # the reference failed: nothing confirms or contradicts the FE's verdict
    elif status != lp_status and not (status.startswith("no collapse") and lp_status.startswith("no collapse")):
        cls = "wrong"
    elif status == "limit load found":
        lower, upper, level = lim["lower"], lim["upper"], lp["load"]
        if fill:
            ok = upper >= (1 - NO_SLIP_TOL) * level
        elif sliding:
            ok = lower <= (1 + NO_SLIP_TOL) * level and (upper >= (1 - NO_SLIP_TOL) * level or proved)
        else:
            ok = reaches(lower, upper, level)
        cls = "confirmed" if ok else "wrong"
    else:
        cls = "confirmed"
    if cls not in ("solver failure", "wrong (fill mesh not converged)", *UNJUDGED) and code != 0:
        cls = "wrong"  # a verdict must exit 0
    return {**out, "class": cls}


def failure_cause(row: dict) -> str:
    """A short name for why a scene has no confirmed verdict (groups the worst cases)."""
    text = row["status"]
    if "End of error message" in text:
        return "Gmsh aborted (SIGABRT) while meshing"
    for key in ("unproven instability under self-weight", "unproven mechanism", "contradicted",
                "max iterations", "active set cycling", "no convergence", "bracket not closed", "timeout",
                "no mesh node"):
        if key in text:
            return key
    return text[:80]


def ring_text(rings: dict) -> str:
    """A ``--rings`` draw in words: "3 staggered rings, mu 0.42, c 12 kPa"."""
    return f"{rings['rings']} {rings['bond']} rings, mu {rings['friction']:g}, c {rings['cohesion'] / 1e3:g} kPa"


def report(rows: list[dict]) -> str:
    """The table, the classes, the success rate, solves per limit and the worst cases."""
    lines = [f"{'#':>4} {'shape':12} {'span':>6} {'t':>6} {'t_min':>6} {'n':>4} {'mu':>6} {'E':>8} {'load':>12} "
             f"{'jal':>3} {'fill':>5} {'status':28} {'FE/LP':>7} {'solves':>6} {'s':>6}  class"]
    for r in sorted(rows, key=lambda r: r["index"]):
        load = f"{'patch' if r['patch'] else 'point'}@{r['position']:.3f}"
        least = f"{r['least_thickness']:.3f}" if r["least_thickness"] else "none"
        ratio = f"{r['ratio']:.4f}" if r.get("ratio") else "-"
        lines.append(f"{r['index']:4d} {r['shape']:12} {r['span']:6.2f} {r['thickness']:6.3f} {least:>6} "
                     f"{r['voussoirs']:4d} {r['friction']:6.3f} {r['young']:8.2g} {load:>12} "
                     f"{'T' if r['joint_at_loads'] else 'F':>3} {str(r['fill'] or '-')[:5]:>5} "
                     f"{r['status'][:28]:28} {ratio:>7} {str(r.get('solves') or '-'):>6} {r['seconds']:6.1f}  "
                     f"{r['class']}{'  (' + r['option']['name'] + ')' if r.get('option') else ''}"
                     f"{'  (' + ring_text(r['rings']) + ')' if r.get('rings') else ''}")
    n = len(rows)
    classes = {c: sum(r["class"] == c for r in rows)
               for c in ("confirmed", "solver failure", "wrong", "wrong (fill mesh not converged)", "crash",
                         *UNJUDGED)}
    rejected = sum(r["class"] == "rejected" for r in rows)
    n -= rejected
    lines.append("")
    lines.append(f"scenes {n} (and {rejected} rejected as bad input): "
                 + ", ".join(f"{c} {k} ({100 * k / max(n, 1):.1f} %)" for c, k in classes.items()))
    for shape in SHAPES:
        mine = [r for r in rows if r["shape"] == shape and r["class"] != "rejected"]
        if mine:
            lines.append(f"  {shape:12}: confirmed {sum(r['class'] == 'confirmed' for r in mine)} of {len(mine)}")
    for name in OPTIONS:
        mine = [r for r in rows if (r.get("option") or {}).get("name") == name and r["class"] != "rejected"]
        if mine:
            lines.append(f"  {name:18}: confirmed {sum(r['class'] == 'confirmed' for r in mine)} of {len(mine)}")
    for n_spans in sorted({r["spans"] for r in rows if r.get("spans")}):
        mine = [r for r in rows if r.get("spans") == n_spans and r["class"] != "rejected"]
        lines.append(f"  {n_spans} spans: confirmed {sum(r['class'] == 'confirmed' for r in mine)} of {len(mine)} "
                     f"({sum(1 for r in mine if r['fill'])} with a fill)")
    for rings in sorted({(r["rings"]["rings"], r["rings"]["bond"]) for r in rows if r.get("rings")}):
        mine = [r for r in rows if r.get("rings") and (r["rings"]["rings"], r["rings"]["bond"]) == rings
                and r["class"] != "rejected"]
        lines.append(f"  {rings[0]} {rings[1]} rings: confirmed {sum(r['class'] == 'confirmed' for r in mine)} of "
                     f"{len(mine)}")
    causes: dict[str, int] = {}
    for r in rows:
        if r["class"] in ("solver failure", "crash", "wrong", "wrong (fill mesh not converged)", *UNJUDGED):
            key = f"{r['class']}: {failure_cause(r)}"
            causes[key] = causes.get(key, 0) + 1
    for key, k in sorted(causes.items(), key=lambda kv: -kv[1]):
        lines.append(f"  {k:3d} x {key}")
    limits = [r["solves"] for r in rows if r.get("status") == "limit load found" and r.get("solves")]
    if limits:
        lines.append(f"solves per limit (limit load found, {len(limits)} scenes): median {statistics.median(limits):g}, "
                     f"max {max(limits)}")
    times = [r["seconds"] for r in rows]
    lines.append(f"time per scene: median {statistics.median(times):.1f} s, max {max(times):.1f} s, "
                 f"total {sum(times):.0f} s")
    bad = [r for r in rows if r["class"] not in ("confirmed", "rejected")]
    off = sorted((r for r in rows if r["class"] == "confirmed" and r.get("ratio") and not r["fill"]),
                 key=lambda r: -abs(r["ratio"] - 1))[:5]
    lines.append("worst cases:")
    for r in bad + off:
        lines.append(f"  #{r['index']} {r['class']}: {r['status'][:200]} (LP {r.get('lp_status')}, "
                     f"FE/LP {r.get('ratio')}, {r.get('reason', '')[:160]})")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=50, help="scenes (default 50)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2, help="scenes run at once (default 2)")
    p.add_argument("--out", type=Path, default=Path("results/campaign"))
    p.add_argument("--timeout", type=float, default=TIMEOUT_S,
                   help="seconds per scene, per span of a --spans bridge (default %(default)g)")
    p.add_argument("--only", type=int, nargs="*", help="run only these scene indices")
    p.add_argument("--options", action="store_true",
                   help="each scene with one scene option drawn from OPTIONS (a second load, elastic abutments, a "
                        "support movement, a preset, quadratic elements, plane stress)")
    p.add_argument("--vehicles", action="store_true",
                   help="each scene an assessment (bridgefem assess) of a vehicle drawn by draw_vehicle")
    p.add_argument("--crushing", action="store_true",
                   help="every scene also gets a compressive strength (draw_strength), from strong to barely standing")
    p.add_argument("--rings", action="store_true",
                   help="every scene a barrel of 2-4 rings (draw_rings: bond, ring friction, ring cohesion)")
    p.add_argument("--spans", action="store_true",
                   help="every scene a bridge of 2-5 spans on piers (draw_spans: spans, piers, a fill for some)")
    p.add_argument("--ranks", type=int, default=1, help="MPI ranks per scene (mpirun -n; default 1: no mpirun)")
    p.add_argument("--report", action="store_true", help="judge the runs already in --out again and print the report")
    p.add_argument("--check-only", action="store_true",
                   help="write the scenes and run bridgefem check on each instead of run (no analysis): which scenes "
                        "a campaign would reject as bad input")
    args = p.parse_args(argv)
    if args.report:
        rows = json.loads((args.out / "campaign.json").read_text())["rows"]
        for r in rows:
            data = results_of(args.out.resolve() / f"scene_{r['index']:04d}")
            if r["class"] not in ("crash", "rejected") and data is not None:
                r.update(judge(data, r["exit"], "", fill=r["fill"] is not None))
        print(report(rows))
        return 0
    indices = args.only if args.only else range(args.count)
    rows = []
    if args.check_only:
        def checked(i):
            choice = draw(args.seed, i)
            if args.crushing:
                choice["strength"] = draw_strength(args.seed, i)
            if args.rings:
                choice["rings"] = draw_rings(args.seed, i)
            if args.spans:
                choice["bridge"] = draw_spans(args.seed, i, choice)
            verdict = check_scene({**choice, "option": draw_option(args.seed, i)} if args.options else choice, args.out)
            print(f"scene {i}: {verdict}", flush=True)
            return verdict

        with ThreadPoolExecutor(args.jobs) as pool:
            verdicts = list(pool.map(checked, indices))
        valid = verdicts.count("valid")
        print(f"scenes {len(verdicts)}: valid {valid}, rejected {len(verdicts) - valid}")
        return 0

    def one(i):
        choice = draw(args.seed, i)
        if args.vehicles:
            choice["vehicle"] = draw_vehicle(args.seed, i, choice["span"], choice["fill"])
        if args.crushing:
            choice["strength"] = draw_strength(args.seed, i)
        if args.rings:
            choice["rings"] = draw_rings(args.seed, i)
        if args.spans:
            choice["bridge"] = draw_spans(args.seed, i, choice)
        row = run_scene({**choice, "option": draw_option(args.seed, i)} if args.options else choice, args.out,
                        args.timeout, args.ranks)
        print(f"scene {i}: {row['class']}: {row['status'][:100]} ({row['seconds']:.1f} s)", flush=True)
        return row

    with ThreadPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(one, indices))
    text = report(rows)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "campaign.json").write_text(json.dumps({"seed": args.seed, "rows": rows}, indent=1))
    (args.out / "campaign.txt").write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
