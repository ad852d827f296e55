"""Shared harness of the speed studies (demos/speed_accuracy.py, benchmarks/cost_growth.py, mpi_speedup.py,
solves_per_limit.py): the built-in cases, timed runs of the limit analysis with peak memory per phase, fresh-process
workers (also under ``mpirun``), a scaled rigid-block guess, and the output files of a study.

Times are in s, memory in MB, loads in N unless a name says kN.

Run as a worker (what :func:`run_jobs` starts): ``python benchmarks/harness.py --worker JSON``, where JSON is
``{"jobs": [{"scene": {...}, "repeat_budget": 2.0, "guess_factor": 1.0}, ...]}``; it prints one ``RESULT {json}``
line per job.
"""
from __future__ import annotations

import copy
import csv
import json
import os
import resource
import shutil
import subprocess
import sys
import time
import tomllib
from contextlib import contextmanager, nullcontext
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PHASES = ("geometry", "mesh", "assembly", "pairing", "solver setup", "limit search")
# run_analysis calls these module-level names of bridgefem.analysis.<module> once each, in phase order
PHASE_CALLS = {("build", "scene_ring"): "geometry", ("build", "build_block_mesh"): "mesh",
               ("build", "build_elastic_model"): "assembly", ("build", "build_pairs"): "pairing",
               ("build", "ContactSolver"): "solver setup", ("runner", "find_limit_load"): "limit search"}
REPEAT_BUDGET_S = 2.0  # repeat a timed run (fastest kept) while the runs so far took less than this
MAX_RUNS = 5  # ... up to this many runs
SEGMENTAL = {
    "scene": {"name": "segmental_arch"},
    "arch": {"shape": "segmental", "span": 10.0, "rise": 2.5, "thickness": 0.5, "width": 1.0, "voussoirs": 16},
    "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0},
    "joints": {"friction": 0.6},
    "load": [{"kind": "point", "position": 0.25}],
}
"""The shallow segmental arch of the speed studies: rise/span = 1/4, span 10 m, t = 0.5 m, load at quarter span."""


# ------------------------------------------------------------------------------------------------ scenes
def builtin_cases() -> dict[str, dict]:
    """The built-in cases as scene dictionaries: the reference arch (demos/bare_arch.toml) and SEGMENTAL."""
    return {"semicircular": tomllib.loads((ROOT / "demos" / "bare_arch.toml").read_text()),
            "segmental": copy.deepcopy(SEGMENTAL)}


def scene_variant(base: dict, *, preset: str | None = None, ett: int | None = None, degree: int | None = None,
                  tolerance: float | None = None, petsc: dict | None = None, voussoirs: int | None = None,
                  friction: float | None = None) -> dict:
    """A copy of a scene dictionary with some knobs set (None: left as in ``base``). A preset only supplies the
    keys the scene does not give, so the mesh and tolerance keys of ``base`` are dropped when ``preset`` is set."""
    d = copy.deepcopy(base)
    mesh, solver = d.setdefault("mesh", {}), d.setdefault("solver", {})
    if preset is not None:
        for sec, key in ((mesh, "elements_through_thickness"), (mesh, "degree"), (solver, "tolerance")):
            sec.pop(key, None)
        solver["preset"] = preset
    for sec, key, value in ((mesh, "elements_through_thickness", ett), (mesh, "degree", degree),
                            (solver, "tolerance", tolerance)):
        if value is not None:
            sec[key] = value
    if petsc:
        solver["petsc"] = {**solver.get("petsc", {}), **petsc}
    if voussoirs is not None:
        d["arch"]["voussoirs"] = voussoirs
    if friction is not None:
        d["joints"]["friction"] = friction
    return d


# ------------------------------------------------------------------------------------------------ the guess
@contextmanager
def scaled_guess(factor: float | None):
    """Within the block :func:`bridgefem.analysis.runner.run_analysis` seeds the limit search with ``factor`` x the
    rigid-block LP level (None: no guess at all), by wrapping the search it calls."""
    from bridgefem.analysis import runner as analysis
    original = analysis.find_limit_load

    def search(*args, guides, **kwargs):
        guess = None if guides.guess is None or factor is None else factor * guides.guess
        return original(*args, guides=replace(guides, guess=guess), **kwargs)

    analysis.find_limit_load = search
    try:
        yield
    finally:
        analysis.find_limit_load = original


# ------------------------------------------------------------------------------------------------ memory
def _proc_status_kb(field: str) -> float | None:
    """A field of /proc/self/status in kB (None where there is no such file)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return float(line.split()[1])
    except OSError:
        pass
    return None


def _reset_peak() -> bool:
    """Reset VmHWM to the current resident size (Linux >= 4.0); False where not allowed."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def _analysis_module(name: str):
    """The module bridgefem.analysis.<name>."""
    import importlib

    return importlib.import_module(f"bridgefem.analysis.{name}")


class PhaseMemory:
    """Peak resident memory (MB above the level when entered) of each phase of run_analysis: the phase functions
    (:data:`PHASE_CALLS`) are wrapped so that VmHWM is reset when a phase starts and read when it ends."""

    def __init__(self):
        self.peaks: dict[str, float] = {}
        self._saved: dict[tuple[str, str], object] = {}

    def __enter__(self):
        self.base_kb = _proc_status_kb("VmRSS")
        self.enabled = self.base_kb is not None and _reset_peak()
        if self.enabled:
            for (module, name), phase in PHASE_CALLS.items():
                self._saved[module, name] = getattr(_analysis_module(module), name)
                setattr(_analysis_module(module), name, self._wrap(self._saved[module, name], phase))
        return self

    def _wrap(self, fn, phase):
        def wrapped(*args, **kwargs):
            _reset_peak()
            try:
                return fn(*args, **kwargs)
            finally:
                self.peaks[phase] = (_proc_status_kb("VmHWM") - self.base_kb) / 1024
        return wrapped

    def __exit__(self, *exc):
        for (module, name), fn in self._saved.items():
            setattr(_analysis_module(module), name, fn)
        return False

    @property
    def peak_mb(self) -> float | None:
        """The largest phase peak (MB), None where it cannot be measured."""
        return max(self.peaks.values()) if self.enabled and self.peaks else None


# ------------------------------------------------------------------------------------------------ timed runs
_WARM: set[str] = set()


def warm_up(scene_dict: dict) -> None:
    """Load Gmsh and JIT-compile the forms of this material and degree with a one-element-thick run (once per
    process and form-relevant part of the scene), so that the timed runs measure the analysis, not one-off
    library loading and form compilation."""
    import gmsh  # noqa: F401  (the mesh phase imports it lazily: ~0.5 s once per process)

    from bridgefem.analysis.runner import run_analysis
    from bridgefem.scene.reader import scene_from_dict
    d = copy.deepcopy(scene_dict)
    d.setdefault("mesh", {})["elements_through_thickness"] = 1
    d.pop("solver", None)
    key = json.dumps({**d, "arch": {k: v for k, v in d["arch"].items() if k != "voussoirs"}}, sort_keys=True)
    if key not in _WARM:
        run_analysis(scene_from_dict(d))
        _WARM.add(key)


def measure_once(scene, comm) -> tuple:
    """One timed FE limit analysis of a Scene: the Analysis and its record (bracket in N per unit load level,
    sizes, counts, wall and CPU time in total and per phase, peak memory)."""
    from mpi4py import MPI

    from bridgefem.analysis.runner import run_analysis

    with PhaseMemory() as pm:
        t0, c0 = time.perf_counter(), time.process_time()
        an = run_analysis(scene, comm)
        wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        cpu = comm.allreduce(time.process_time() - c0, op=MPI.SUM)
    s = an.search
    return an, {
        "status": s.status, "lower_N": s.lower, "upper_N": s.upper, "load_total": an.load_total,
        "dofs": an.n_dofs, "pairs": an.pairs.total, "load_steps": len(s.steps),
        "factorisations": an.solver.stats["factorisations"], "linear_solves": an.solver.stats["solves"],
        "time_s": wall, "cpu_s": cpu, "runs": 1, "peak_mb": pm.peak_mb, "mpi_ranks": comm.size,
        **{f"time_{p.replace(' ', '_')}_s": an.timings.get(p, 0.0) for p in PHASES},
    }


def _keep_fastest(rec: dict, again: dict) -> dict:
    """Merge a repeat into a record: the fastest wall time (with its phases) and the least CPU time; the bracket
    and memory stay those of the first run."""
    out = dict(rec)
    if again["time_s"] < rec["time_s"]:
        out.update({k: v for k, v in again.items() if k.startswith("time_")})
    out["cpu_s"] = min(rec["cpu_s"], again["cpu_s"])
    out["runs"] = rec["runs"] + 1
    return out


def measure(scene_dict: dict, repeat_budget: float = REPEAT_BUDGET_S, comm=None,
            guess_factor: float | None = 1.0):
    """Warm up, then run the FE limit analysis of a scene dictionary up to MAX_RUNS times (while the runs so far took
    less than ``repeat_budget`` s), the search seeded with ``guess_factor`` x the LP level (1: as a user runs
    it; None: no guess): the first Analysis and the merged record (fastest times)."""
    from mpi4py import MPI

    from bridgefem.scene.reader import scene_from_dict

    comm = comm or MPI.COMM_WORLD
    scene = scene_from_dict(scene_dict)
    warm_up(scene_dict)
    with scaled_guess(guess_factor) if guess_factor != 1.0 else nullcontext():
        first, rec = measure_once(scene, comm)
        spent = rec["time_s"]
        while rec["runs"] < MAX_RUNS and spent < repeat_budget:
            _, again = measure_once(scene, comm)
            rec, spent = _keep_fastest(rec, again), spent + again["time_s"]
    return first, rec


def worker(payload: dict, extra=None) -> None:
    """Measure each job of ``payload["jobs"]`` (:func:`measure`; ``extra(analysis)`` adds keys to its record) and
    print one ``RESULT {json}`` line per job, in order; a failed run is a record with ``error`` set."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    for job in payload["jobs"]:
        try:
            an, rec = measure(job["scene"], job.get("repeat_budget", REPEAT_BUDGET_S), comm,
                              job.get("guess_factor", 1.0))
            if extra is not None:
                rec.update(extra(an))
        except Exception as err:  # a failed run is a row with its reason, not a crashed study
            rec = {"error": f"{type(err).__name__}: {(str(err).strip().splitlines() or [''])[-1]}"}
        if comm.rank == 0:
            print("RESULT " + json.dumps(rec), flush=True)


def run_jobs(jobs: list[dict], ranks: int = 1, script: Path = Path(__file__).resolve(),
             timeout: float = 3600) -> list[dict]:
    """Run ``script --worker JSON`` (default: this module's :func:`worker`) in a fresh process, under
    ``mpirun -n ranks`` when ranks > 1, and return the records it prints; a failed process gives records with
    ``error`` set."""
    cmd = [sys.executable, str(script), "--worker", json.dumps({"jobs": jobs})]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    env = {**os.environ, "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT, env=env)
    except subprocess.TimeoutExpired:
        return [{"error": f"timeout after {timeout:g} s"} for _ in jobs]
    out = [json.loads(line[len("RESULT "):]) for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    if proc.returncode != 0 or len(out) != len(jobs):
        tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        out += [{"error": f"worker exit code {proc.returncode}: {tail}"} for _ in jobs[len(out):]]
    return out


def bracket_kn(rec: dict) -> tuple[float, float | None]:
    """The FE bracket of a record in kN (total live load; upper None when the search found none)."""
    kn = rec["load_total"] / 1e3
    return rec["lower_N"] * kn, None if rec["upper_N"] is None else rec["upper_N"] * kn


# ------------------------------------------------------------------------------------------------ outputs
def timed(cmd: list[str], env: dict | None = None, cwd: Path | str | None = None, timeout: float = 1800
          ) -> tuple[float, float, subprocess.CompletedProcess]:
    """Wall and CPU time (s, user + system of all the command's processes) of one run of ``cmd`` in a fresh process;
    a non-zero exit raises RuntimeError with the end of its stderr."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    run = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd, timeout=timeout)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if run.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))}: exit {run.returncode}: {run.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), run


def fmt(value, spec: str) -> str:
    """``value`` formatted by ``spec``, or "-" for None."""
    return "-" if value is None else format(value, spec)


def machine_line() -> str:
    """The code version, CPU count and load average (1 min) for the head of a study's output."""
    load = os.getloadavg()
    return f"Code: {git_state()}; {os.cpu_count()} CPU(s), load average {load[0]:.1f}"


def git_state() -> str:
    """The commit of the working tree and whether bridgefem/ has uncommitted changes."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout
        dirty = subprocess.run(["git", "status", "--porcelain", "bridgefem"], capture_output=True, text=True,
                               cwd=ROOT).stdout
    except OSError:
        return "unknown"
    return rev.strip() + (" + uncommitted changes in bridgefem/" if dirty.strip() else "")


def write_outputs(out: Path, stem: str, rows: list[dict], markdown: str, plot=None,
                  figures: Path | None = None) -> None:
    """Write OUT/STEM.csv (every key of every row), OUT/STEM.md and, with ``plot(path)``, OUT/STEM.png, atomically
    and under bridgefem's output policy (:func:`bridgefem.io.output.results_folder`); copy the .md and .png into
    ``figures`` when given; print the markdown and where the files went."""
    from bridgefem.io.output import results_folder

    made = [f"{stem}.md"] + ([f"{stem}.png"] if plot is not None else [])
    with results_folder(out) as tmp:
        with open(tmp / f"{stem}.csv", "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
            writer.writeheader()
            writer.writerows(rows)
        (tmp / f"{stem}.md").write_text(markdown)
        if plot is not None:
            plot(tmp / f"{stem}.png")
        if figures is not None:
            figures.mkdir(parents=True, exist_ok=True)
            for name in made:
                shutil.copy(tmp / name, figures / name)
    print(markdown)
    print(f"written to {out}/ ({stem}.csv, " + ", ".join(made) + ")")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--worker"]:
        worker(json.loads(sys.argv[2]))
    else:
        raise SystemExit(__doc__)
