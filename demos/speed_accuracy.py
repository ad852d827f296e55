"""Speed-accuracy map of the FE limit analysis: what each knob buys in accuracy and costs in time and memory.

The limit search (bridgefem/search/pathfollow.py) is seeded with the rigid-block LP value, and at a loose bracket
tolerance its bracket is [(1 - tol) LP, LP] whatever the mesh: an error measured against that LP would only show
the tolerance. So the knobs are measured apart, against references the seed cannot bias:

- **Discretisation** (elements through the ring thickness t/1 ... t/16, degree P1/P2, number of voussoirs): at a
  tight bracket tolerance, DISCRETISATION_TOLERANCE = 1e-4, so that the bracket is far narrower than the error.
- **References**: the LP on the same joints, and a fine FE run (t/32, P1, tolerance 1e-4: REFERENCE; P2 at t/16
  ends in a solver failure on the semicircular arch with mu = 10). For the voussoirs, also the LP with N = 4096 joints (the N -> large
  limit of the ring with hinges anywhere).
- **Seed**: the bracket of the seed check configuration is recomputed with the seed scaled x0.5, x2 and without a
  seed; the table shows that it does not depend on the seed beyond the tolerance.
- **Bracket tolerance and linear solver**: swept on the P1 meshes; the error of such a run is its bound against
  the fine-FE reference: ``err_bound = |midpoint - reference| / reference + half-width / reference``.

Per run: ``err_lp`` = |midpoint - LP| / LP, ``err_ref`` = |midpoint - FE reference| / FE reference, ``half`` =
half the bracket width / midpoint, ``err_bound``, and for the voussoir sweep ``err_inf`` = |midpoint - LP(N = 4096)|
/ LP(N = 4096). Cost: CPU and wall time of :func:`bridgefem.analysis.runner.run_analysis` after a warm-up (fastest of up to
5 runs within 2 s), peak resident memory above the level before the run, linear solves. The Pareto front is on
(CPU time, err_bound), errors compared to two significant digits. Presets (:func:`recommend_presets`): on the
front of the worst err_bound and the summed CPU time over the cases; the table marks the presets in
:data:`bridgefem.scene.schema.PRESETS` next to the picks, so a preset that has fallen off the front shows.

Cases: ``semicircular`` (demos/bare_arch.toml) and ``segmental`` (rise/span = 1/4; benchmarks/harness.py).
The fill case (``--fill``): the Prestwood bridge with its Mohr-Coulomb fill (demos/prestwood.toml) on P1/P2 meshes,
each limit against the Richardson extrapolation of the P2 meshes (benchmarks/fill_cost.py, docs/fill.md), the
fill presets marked; its limit converges far more slowly than the bare arches', so it has a table of its own.

Run:

    ./run python demos/speed_accuracy.py                          # both cases, about 2 min on 2 cores
    ./run python demos/speed_accuracy.py --quick                  # coarse meshes, about 15 s (used by the tests;
                                                                  # no voussoir sweep, so no LP with N = 4096)
    ./run python demos/speed_accuracy.py --figures demos/figures  # also copy the PNG and MD for docs/benchmarks.md
    ./run python demos/speed_accuracy.py --fill                   # the fill case only (several minutes)

Writes DIR/speed_accuracy.csv (every number), .md (tables) and .png (log-log error bound against CPU time per case
with the Pareto front and the presets; error against N); DIR defaults to results/speed_accuracy. Loads in kN.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from harness import bracket_kn, builtin_cases, fmt, machine_line, run_jobs, scene_variant, write_outputs  # noqa: E402

DISCRETISATION_TOLERANCE = 1e-4  # bracket tolerance of the mesh, degree, voussoir and seed runs
MESHES = ((1, 1), (2, 1), (4, 1), (8, 1), (16, 1), (1, 2), (2, 2), (4, 2), (8, 2))  # (elements, degree)
REFERENCE = (32, 1)  # (elements, degree) of the fine-FE reference, at DISCRETISATION_TOLERANCE
TOLERANCES = (0.02, 0.01, 0.005, 0.002, 0.001, 0.0005)  # swept on the P1 meshes TOLERANCE_MESHES
TOLERANCE_MESHES = (1, 2, 4, 8)
SEED_CHECK = (8, 1)  # (elements, degree) whose bracket is recomputed with other seeds
SEEDS = (0.5, 2.0, None)  # factors on the LP seed (None: no seed)
VOUSSOIRS = (8, 16, 32, 64)
LP_MANY_JOINTS = 4096
SOLVERS = {  # label -> PETSc options of the contact solver (prefix bridgefem_) on top of the MUMPS defaults
    "mumps-metis": {"mat_mumps_icntl_7": 5},
    "mumps-amd": {"mat_mumps_icntl_7": 0},
    "mumps-pord": {"mat_mumps_icntl_7": 4},
    "superlu_dist": {"pc_factor_mat_solver_type": "superlu_dist"},
}
QUICK = {"meshes": ((1, 1), (2, 1), (4, 1)), "reference": (8, 1), "tolerances": (0.005,),
         "tolerance_meshes": (2,), "seed_check": (2, 1)}
COST_NOISE = 0.2  # CPU times of runs this short differ by up to this fraction between repeats on a shared machine
ACCURATE_ERROR = 0.0002  # the accurate preset: the cheapest configuration whose worst err_bound is at most this
DEFAULT_ERROR = 0.0005  # the default preset: the cheapest configuration whose worst err_bound is at most this


# ------------------------------------------------------------------------------------------------ the runs
def plan(quick: bool) -> dict:
    """The sweep's settings (QUICK or the module constants)."""
    full = {"meshes": MESHES, "reference": REFERENCE, "tolerances": TOLERANCES,
            "tolerance_meshes": TOLERANCE_MESHES, "seed_check": SEED_CHECK}
    return QUICK if quick else full


def job(kind: str, label: str, scene: dict, guess_factor: float | None = 1.0) -> dict:
    """One run of the sweep: its kind (mesh, reference, tolerance, seed, solver, voussoirs), label and scene."""
    return {"kind": kind, "label": label, "scene": scene, "guess_factor": guess_factor}


def discretisation_jobs(base: dict, settings: dict) -> list[dict]:
    """The mesh and degree runs, the fine-FE reference and the seed check, all at DISCRETISATION_TOLERANCE."""
    tol = DISCRETISATION_TOLERANCE
    jobs = [job("mesh", f"t/{e} P{d}", scene_variant(base, ett=e, degree=d, tolerance=tol))
            for e, d in settings["meshes"]]
    e, d = settings["reference"]
    jobs.append(job("reference", f"t/{e} P{d}", scene_variant(base, ett=e, degree=d, tolerance=tol)))
    e, d = settings["seed_check"]
    for factor in SEEDS:
        name = "no seed" if factor is None else f"seed x{factor:g}"
        jobs.append(job("seed", f"t/{e} P{d} {name}", scene_variant(base, ett=e, degree=d, tolerance=tol), factor))
    return jobs


def tolerance_jobs(base: dict, settings: dict) -> list[dict]:
    """The bracket tolerance swept on P1 meshes."""
    return [job("tolerance", f"t/{e} P1 tol {t:g}", scene_variant(base, ett=e, degree=1, tolerance=t))
            for e in settings["tolerance_meshes"] for t in settings["tolerances"]]


def solver_jobs(base: dict) -> list[dict]:
    """The other linear solvers at the default preset."""
    return [job("solver", label, scene_variant(base, preset="default", petsc=opts)) for label, opts in SOLVERS.items()]


def voussoir_jobs(base: dict) -> list[dict]:
    """The number of voussoirs at DISCRETISATION_TOLERANCE, P1, at least 4 elements through the thickness and
    at least one element along each voussoir."""
    from bridgefem.scene.reader import scene_from_dict

    jobs = []
    for n in VOUSSOIRS:
        scene = scene_variant(base, voussoirs=n, degree=1, tolerance=DISCRETISATION_TOLERANCE)
        ett = max(4, elements_for_voussoirs(scene_from_dict(scene)))
        jobs.append(job("voussoirs", f"N = {n}, t/{ett}", scene_variant(scene, ett=ett)))
    return jobs


def elements_for_voussoirs(scene) -> int:
    """Elements through the thickness that make the shortest voussoir at least one element long."""
    import numpy as np

    from bridgefem.geometry.ring import build_ring

    a = scene.arch
    ring = build_ring(a.shape, a.span, a.rise, a.thickness, a.voussoirs, scene.load_edges_x(), a.joint_at_loads)

    def length(p):
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())

    shortest = min(0.5 * (length(v.intrados) + length(v.extrados)) for v in ring.voussoirs)
    return max(1, math.ceil(a.thickness / shortest - 1e-9))


def case_jobs(base: dict, quick: bool) -> list[dict]:
    """Every run of one case."""
    settings = plan(quick)
    jobs = discretisation_jobs(base, settings) + tolerance_jobs(base, settings)
    return jobs if quick else jobs + solver_jobs(base) + voussoir_jobs(base)


def measure_case(jobs: list[dict], quick: bool) -> list[dict]:
    """The records of a case's jobs, measured in one fresh process (--quick: one run each)."""
    budget = {"repeat_budget": 0.0} if quick else {}  # the harness's default: repeats within REPEAT_BUDGET_S
    return run_jobs([{"scene": j["scene"], "guess_factor": j["guess_factor"], **budget} for j in jobs])


# ------------------------------------------------------------------------------------------------ errors
def lp_kn(scene_dict: dict, voussoirs: int | None = None) -> float | None:
    """The rigid-block LP collapse load (kN) of a scene dictionary, optionally with another number of voussoirs."""
    from bridgefem.limit.collapse import collapse_load
    from bridgefem.scene.reader import scene_from_dict

    lp = collapse_load(scene_from_dict(scene_variant(scene_dict, voussoirs=voussoirs)))
    return None if lp.load is None else lp.load / 1e3


def relative(value: float | None, ref: float | None) -> float | None:
    """|value - ref| / ref, None when either is missing."""
    return None if value is None or not ref else abs(value / ref - 1.0)


def make_row(case: str, j: dict, rec: dict, lp_cache: dict) -> dict:
    """A table row: the job's knobs, the LP on the same joints and the measurement (loads in kN). The errors
    against the references are added by :func:`add_errors`."""
    from bridgefem.scene.reader import scene_from_dict

    sc = scene_from_dict(j["scene"])
    n = sc.arch.voussoirs
    if n not in lp_cache:
        lp_cache[n] = lp_kn(j["scene"])
    row = {"case": case, "kind": j["kind"], "label": j["label"], "voussoirs": n,
           "ett": sc.mesh.elements_through_thickness, "degree": sc.mesh.degree, "tolerance": sc.solver.tolerance,
           "seed": "none" if j["guess_factor"] is None else f"x{j['guess_factor']:g}",
           "solver": j["label"] if j["kind"] == "solver" else "mumps", "lp_kN": lp_cache[n]}
    if "error" in rec:
        return {**row, "status": rec["error"]}
    lower, upper = bracket_kn(rec)
    found = rec["status"] == "limit load found" and upper is not None
    mid = 0.5 * (lower + upper) if found else None
    row.update({k: v for k, v in rec.items() if k not in ("lower_N", "upper_N", "load_total")})
    row.update(fe_lower_kN=lower, fe_upper_kN=upper, fe_mid_kN=mid,
               half=None if mid is None else 0.5 * (upper - lower) / mid, err_lp=relative(mid, lp_cache[n]))
    return row


def add_errors(rows: list[dict], lp_many: float | None) -> None:
    """Set err_ref and err_bound (against the case's fine-FE reference midpoint, for the rows with its number of
    voussoirs; None when the reference run failed) and err_inf (against the LP with many joints) of every row."""
    reference = next(r for r in rows if r["kind"] == "reference")
    ref = reference.get("fe_mid_kN")
    for r in rows:
        r["fe_reference_kN"], r["lp_many_joints_kN"] = ref, lp_many
        same_joints = r["voussoirs"] == reference["voussoirs"]
        r["err_ref"] = relative(r.get("fe_mid_kN"), ref) if same_joints else None
        r["err_bound"] = None if r["err_ref"] is None else r["err_ref"] + r["half"] * r["fe_mid_kN"] / ref
        r["err_inf"] = relative(r.get("fe_mid_kN"), lp_many) if r["kind"] == "voussoirs" else None


# ------------------------------------------------------------------------------------------------ the front
def _err_key(err: float) -> float:
    """An error to two significant digits: brackets that differ in the fourth digit are equally accurate."""
    return float(f"{err:.2g}")


def pareto(points: list[dict]) -> list[dict]:
    """The points (rows or configurations) not dominated in (cpu_s, err_bound): none other is at least as cheap
    and as accurate and better in one of them. Returned by increasing cost."""
    front, best = [], math.inf
    for p in sorted((p for p in points if p.get("err_bound") is not None),
                    key=lambda p: (p["cpu_s"], _err_key(p["err_bound"]))):
        if _err_key(p["err_bound"]) < best:
            front.append(p)
            best = _err_key(p["err_bound"])
    return front


def front_excess(point: dict, points: list[dict]) -> float | None:
    """How much more CPU time (fraction) a point takes than the cheapest point at least as accurate: 0 on the
    front."""
    if point.get("err_bound") is None:
        return None
    key = _err_key(point["err_bound"])
    rivals = [p["cpu_s"] for p in points if p.get("err_bound") is not None and _err_key(p["err_bound"]) <= key]
    return point["cpu_s"] / min(rivals) - 1.0


def map_points(rows: list[dict]) -> list[dict]:
    """The rows of the base arch with the MUMPS defaults and the LP seed: the configurations of the front."""
    return [r for r in rows if r["kind"] in ("mesh", "tolerance") and r.get("err_bound") is not None]


def configurations(rows: list[dict], cases: list[str]) -> list[dict]:
    """Per configuration (elements, degree, tolerance) measured on every case: the summed CPU time (s) and the
    worst err_bound over the cases."""
    by_cfg: dict[tuple, dict[str, dict]] = {}
    for r in map_points(rows):
        by_cfg.setdefault((r["ett"], r["degree"], r["tolerance"]), {})[r["case"]] = r
    return [{"config": cfg, "cpu_s": sum(v[c]["cpu_s"] for c in cases),
             "err_bound": max(v[c]["err_bound"] for c in cases)}
            for cfg, v in sorted(by_cfg.items()) if all(c in v for c in cases)]


def recommend_presets(configs: list[dict], min_elements: int) -> dict[str, dict]:
    """Presets on the front, among the configurations with at least ``min_elements`` through the thickness (fewer
    make a voussoir of a case shorter than one element, and the run warns):

    - fast: the most accurate configuration that costs at most (1 + COST_NOISE) x the cheapest one;
    - accurate: the cheapest configuration whose worst err_bound is at most ACCURATE_ERROR;
    - default: the cheapest within DEFAULT_ERROR.

    Errors are compared to two digits and ties go to the cheaper configuration, so each pick is on the front."""
    eligible = [c for c in configs if c["config"][0] >= min_elements]
    if not eligible:
        return {}
    budget = (1.0 + COST_NOISE) * min(c["cpu_s"] for c in eligible)
    affordable = [c for c in eligible if c["cpu_s"] <= budget]
    picks = {"fast": min(affordable, key=lambda c: (_err_key(c["err_bound"]), c["cpu_s"])),
             "default": cheapest_within(eligible, DEFAULT_ERROR),
             "accurate": cheapest_within(eligible, ACCURATE_ERROR)}
    return {name: c for name, c in picks.items() if c is not None}


def cheapest_within(configs: list[dict], bound: float) -> dict | None:
    """The cheapest configuration whose worst err_bound (to two digits) is at most ``bound``."""
    ok = [c for c in configs if _err_key(c["err_bound"]) <= bound]
    return min(ok, key=lambda c: (c["cpu_s"], c["err_bound"])) if ok else None


def preset_config(values: dict) -> tuple:
    """(elements, degree, tolerance) of a PRESETS entry."""
    return (values[("mesh", "elements_through_thickness")], values[("mesh", "degree")],
            values[("solver", "tolerance")])


# ------------------------------------------------------------------------------------------------ outputs
def _pct(v) -> str:
    return fmt(None if v is None else 100 * v, ".3f")


def _bracket(r: dict) -> str:
    return "-" if r.get("fe_upper_kN") is None else f"[{r['fe_lower_kN']:.3f}, {r['fe_upper_kN']:.3f}]"


def _front(r: dict) -> str:
    mark = "**front**" if r.get("on_front") else fmt(r.get("front_excess"), "+.0%")
    return mark + (f", preset {r['preset']}" if r.get("preset") else "")


COLUMNS = {  # header -> cell of a row
    "case": lambda r: r["case"], "kind": lambda r: r["kind"], "configuration": lambda r: r["label"],
    "N": lambda r: str(r["voussoirs"]), "tol": lambda r: f"{r['tolerance']:g}", "seed": lambda r: r["seed"],
    "dofs": lambda r: str(r.get("dofs", "-")), "FE bracket kN": _bracket, "LP kN": lambda r: fmt(r["lp_kN"], ".3f"),
    "err vs LP %": lambda r: _pct(r.get("err_lp")), "err vs fine FE %": lambda r: _pct(r.get("err_ref")),
    "half-width %": lambda r: _pct(r.get("half")), "err bound %": lambda r: _pct(r.get("err_bound")),
    f"err vs LP(N={LP_MANY_JOINTS}) %": lambda r: _pct(r.get("err_inf")),
    "CPU s": lambda r: fmt(r.get("cpu_s"), ".2f"), "wall s": lambda r: fmt(r.get("time_s"), ".2f"),
    "peak MB": lambda r: fmt(r.get("peak_mb"), ".0f"), "solves": lambda r: str(r.get("linear_solves", "-")),
    "front": _front, "status": lambda r: r["status"],
}
COMPACT = ("case", "kind", "configuration", "tol", "seed", "N", "FE bracket kN", "err vs LP %", "err vs fine FE %",
           "half-width %", f"err vs LP(N={LP_MANY_JOINTS}) %", "CPU s", "wall s", "peak MB", "solves", "front")


def markdown_table(rows: list[dict], columns=tuple(COLUMNS)) -> str:
    """A markdown table of rows with the given COLUMNS."""
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(COLUMNS[c](r) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def compact_rows(rows: list[dict]) -> list[dict]:
    """The rows of the docs/benchmarks.md table: each case's front, the presets, the reference, the seed check, the other
    solvers, the voussoirs."""
    return [r for r in rows if r.get("on_front") or r.get("preset") or r["kind"] in ("reference", "seed", "solver",
                                                                                      "voussoirs")]


def configurations_table(configs: list[dict], presets: dict, recommended: dict) -> str:
    """The configurations on every case: summed CPU time, worst err_bound, front, presets (current/recommended)."""
    front = {id(c) for c in pareto(configs)}
    named = {preset_config(v): name for name, v in presets.items()}
    advice = {c["config"]: name for name, c in recommended.items()}
    lines = ["| elements | degree | tol | CPU s (sum over cases) | worst err bound % | front | preset now | "
             "recommended |", "|---|---|---|---|---|---|---|---|"]
    for c in configs:
        e, d, t = c["config"]
        mark = "**front**" if id(c) in front else fmt(front_excess(c, configs), "+.0%")
        lines.append(f"| t/{e} | P{d} | {t:g} | {c['cpu_s']:.2f} | {_pct(c['err_bound'])} | {mark} | "
                     f"{named.get(c['config'], '')} | {advice.get(c['config'], '')} |")
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], cases: list[str], presets: dict, path: Path) -> None:
    """Per case: err_bound against CPU time (log-log), the mesh sweep at the tight tolerance as lines, the Pareto
    front and the presets; last panel: the voussoir sweep against N."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    vous = [r for r in rows if r["kind"] == "voussoirs" and r.get("err_lp") is not None]
    fig, axes = plt.subplots(1, len(cases) + bool(vous), figsize=(5.6 * (len(cases) + bool(vous)), 4.8),
                             squeeze=False)
    for ax, case in zip(axes[0], cases):
        plot_case(ax, [r for r in rows if r["case"] == case], presets)
        ax.set_title(case, fontsize=10)
    if vous:
        plot_voussoirs(axes[0][-1], vous, cases)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_case(ax, rows: list[dict], presets: dict) -> None:
    """One case's panel of :func:`plot`."""
    pts = map_points(rows)
    for d, marker in ((1, "o"), (2, "s")):
        mesh = sorted((r for r in pts if r["kind"] == "mesh" and r["degree"] == d), key=lambda r: r["ett"])
        ax.plot([r["cpu_s"] for r in mesh], [100 * r["err_bound"] for r in mesh], marker + "-", ms=5,
                label=f"P{d}, tol {DISCRETISATION_TOLERANCE:g}: t/1 ... t/{mesh[-1]['ett'] if mesh else '?'}")
    tol = [r for r in pts if r["kind"] == "tolerance"]
    ax.scatter([r["cpu_s"] for r in tol], [100 * r["err_bound"] for r in tol], marker="x", c="grey", s=22,
               label="P1, tol 0.02 ... 0.0005")
    front = pareto(pts)
    ax.step([r["cpu_s"] for r in front], [100 * r["err_bound"] for r in front], where="post", color="crimson",
            lw=1.2, label="Pareto front")
    for name, values in presets.items():
        cfg = preset_config(values)
        hit = [r for r in pts if (r["ett"], r["degree"], r["tolerance"]) == cfg]
        for r in hit[:1]:
            ax.scatter([r["cpu_s"]], [100 * r["err_bound"]], s=160, facecolors="none", edgecolors="crimson")
            ax.annotate(name, (r["cpu_s"], 100 * r["err_bound"]), textcoords="offset points", xytext=(8, 5),
                        fontsize=9, color="crimson", weight="bold")
    ax.set(xscale="log", yscale="log", xlabel="CPU time of the limit analysis (s)",
           ylabel="error bound vs fine-FE reference (%)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)


def plot_voussoirs(ax, rows: list[dict], cases: list[str]) -> None:
    """The voussoir panel of :func:`plot`: midpoint error against the LP on the same joints and with N = 4096."""
    for case in cases:
        sel = sorted((r for r in rows if r["case"] == case), key=lambda r: r["voussoirs"])
        n = [r["voussoirs"] for r in sel]
        line, = ax.loglog(n, [max(100 * r["err_inf"], 1e-4) for r in sel], "o-",
                          label=f"{case}: vs LP, N = {LP_MANY_JOINTS}")
        ax.loglog(n, [max(100 * r["err_lp"], 1e-4) for r in sel], "s--", mfc="none", color=line.get_color(),
                  label=f"{case}: vs LP, same joints")
    ax.set(xlabel="voussoirs N", ylabel="midpoint error (%)",
           title=f"number of voussoirs (P1, >= t/4, tol {DISCRETISATION_TOLERANCE:g})")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)


def report(rows: list[dict], case_dicts: dict[str, dict], quick: bool, elapsed: float) -> str:
    """The markdown of the study: references, every run, the configurations on every case with the presets."""
    from bridgefem.scene.reader import scene_from_dict
    from bridgefem.scene.schema import PRESETS

    cases = list(case_dicts)
    configs = configurations(rows, cases)
    min_elements = max(elements_for_voussoirs(scene_from_dict(case_dicts[c])) for c in cases)
    recommended = {} if quick else recommend_presets(configs, min_elements)
    refs = "".join(f"- {c}: fine FE {fmt(r['fe_reference_kN'], '.3f')} kN, LP on the same joints "
                   f"{fmt(r['lp_kN'], '.3f')} kN"
                   + ("" if r["lp_many_joints_kN"] is None else
                      f", LP with N = {LP_MANY_JOINTS}: {fmt(r['lp_many_joints_kN'], '.3f')} kN") + "\n"
                   for c in cases for r in rows if r["case"] == c and r["kind"] == "reference")
    md = (f"# Speed-accuracy map: {', '.join(cases)}" + (" (quick)" if quick else "") + "\n\n"
          f"{machine_line()} at the end; sweep wall time {elapsed:.0f} s.\n\n## References\n\n{refs}\n"
          "## Front, presets, references, seed check, solvers, voussoirs\n\n"
          + markdown_table(compact_rows(rows), COMPACT) + "\n## Configurations on every case\n\n"
          f"Presets need at least {min_elements} element(s) through the thickness (one element along the shortest "
          f"voussoir); fast: the most accurate within {1 + COST_NOISE:g} x the cheapest CPU time; accurate: the "
          f"cheapest within {100 * ACCURATE_ERROR:g} %; default: the cheapest within "
          f"{100 * DEFAULT_ERROR:g} %.\n\n" + configurations_table(configs, PRESETS, recommended)
          + "\n## Every run\n\n" + markdown_table(rows))
    return md


def study(case_dicts: dict[str, dict], quick: bool) -> list[dict]:
    """Run every case and return the table rows with their errors, front and preset marks."""
    from bridgefem.scene.schema import PRESETS

    named = {preset_config(v): name for name, v in PRESETS.items()}
    rows = []
    for case, base in case_dicts.items():
        jobs = case_jobs(base, quick)
        print(f"{case}: {len(jobs)} runs", flush=True)
        recs = measure_case(jobs, quick)
        lp_cache: dict[int, float | None] = {}
        case_rows = [make_row(case, j, r, lp_cache) for j, r in zip(jobs, recs)]
        add_errors(case_rows, None if quick else lp_kn(base, LP_MANY_JOINTS))  # only the voussoir sweep uses it
        pts = map_points(case_rows)
        front = {id(r) for r in pareto(pts)}
        for r in case_rows:
            r["on_front"] = id(r) in front
            r["front_excess"] = front_excess(r, pts) if r in pts else None
            r["preset"] = named.get((r["ett"], r["degree"], r["tolerance"])) if r in pts else None
        rows += case_rows
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", nargs="+", default=None, metavar="CASE", help="semicircular, segmental (default both)")
    p.add_argument("--quick", action="store_true", help="coarse meshes only, one run each (about 15 s)")
    p.add_argument("--out", type=Path, default=Path("results/speed_accuracy"))
    p.add_argument("--figures", type=Path, help="also copy speed_accuracy.png and .md into this folder")
    p.add_argument("--fill", action="store_true", help="the fill case (Prestwood) only: speed_accuracy_fill.csv, .md")
    args = p.parse_args(argv)
    if args.fill:
        from fill_cost import DEFAULT_CASES, fill_table
        rows, lines = fill_table(list(DEFAULT_CASES))
        write_outputs(args.out, "speed_accuracy_fill", rows, "\n".join(lines) + "\n", None, args.figures)
        return 0
    from bridgefem.scene.schema import PRESETS

    builtin = builtin_cases()
    names = args.cases or list(builtin)
    unknown = [c for c in names if c not in builtin]
    if unknown:
        p.error(f"--cases: unknown case {unknown[0]!r}; built-in cases are {', '.join(builtin)}")
    start = time.perf_counter()
    case_dicts = {c: builtin[c] for c in names}
    rows = study(case_dicts, args.quick)
    md = report(rows, case_dicts, args.quick, time.perf_counter() - start)
    write_outputs(args.out, "speed_accuracy", rows, md, lambda path: plot(rows, names, PRESETS, path), args.figures)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
