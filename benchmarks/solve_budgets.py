"""Solve-count budgets: the work the solver and the limit search spend, against the budget each is held to.

The tests (tests/) check answers: a bracket that holds a known limit, a verdict, an equality with an independent
value. How many linear solves, Newton iterations or load steps a correct answer took is no such check: a change to
the method may spend more and still be right. Those counts are kept here, each against its budget, in one table (the
count, the budget, kept or not); the script exits with 1 when any count exceeds its budget, 0 otherwise.

Two groups of rows:

- *unit* (seconds): the made-up solvers of the tests. The one-degree-of-freedom structure of tests/test_bracket.py,
  whose limit is known exactly: the limit search's solves and steps with a good guess, a static bound, a
  collapse-state estimate, a predicted state, a plastic fill (tests/test_fill_steps.py); the Newton iterations each
  trial is given (:mod:`bridgefem.search.pathfollow`, *Failures without proof*) on the wandering Newton method of
  tests/test_pathfollow_budget.py. The elastic block on rigid ground of tests/test_block.py: what the condensation of
  a cycle costs (:mod:`bridgefem.solver.cycles`: 2p + 1 solves for p pairs, one when the same pairs and held states
  come again, only the normal columns up to a pair that declines it) and how the solver counts its solves apart.
- *campaign* (minutes): scenes of benchmarks/campaign.py whose linear solves per limit load (every run of the scene,
  the coarser meshes an automatic re-run replaced included, as the campaign counts them) are held to the 150 that
  issue 12 allows (80 for one), a scene whose self-weight the static theorem rules out in one load step, and a scene
  whose collapse-state check spares the retries of its closing trial. The tests named in each row check the same
  scene's answer.

Run:

    ./run python benchmarks/solve_budgets.py               # every row (about 2 min on one core)
    ./run python benchmarks/solve_budgets.py --quick       # the unit rows only (about 10 s)
    ./run python benchmarks/solve_budgets.py --only "#146"  # the rows whose name contains TEXT
"""
from __future__ import annotations

import argparse
import contextlib
import logging
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the made-up solvers of the tests
sys.path.insert(0, str(ROOT / "benchmarks"))


@dataclass
class Row:
    """One budget: what is counted, the count as shown, the budget as shown, and whether the count keeps it."""

    name: str
    count: str
    budget: str
    kept: bool


def check(name: str, count: float, op: str, bound: float, note: str = "") -> Row:
    """A row for ``count op bound`` (op one of "<=", "<", "==")."""
    kept = {"<=": count <= bound, "<": count < bound, "==": count == bound}[op]
    return Row(name, f"{count:g}", f"{op} {bound:g}" + (f" ({note})" if note else ""), bool(kept))


@contextlib.contextmanager
def patched(obj, name: str, value):
    """``obj.name`` set to ``value`` within the block."""
    old = getattr(obj, name)
    setattr(obj, name, value)
    try:
        yield
    finally:
        setattr(obj, name, old)


# ------------------------------------------------------------------------------------------------ unit rows
def search_rows() -> list[Row]:
    """The limit search on the one-degree-of-freedom structure of tests/test_bracket.py (limit LIMIT, exact)."""
    from test_bracket import LIMIT, PREDICTED, OneDof, Predicted, search, static_cap
    from test_fill_steps import PlasticFillOneDof

    from bridgefem.search.pathfollow import FUTILE_PREDICTIONS
    from bridgefem.search.records import CollapseCheck
    from bridgefem.search.selfweight import SELF_WEIGHT_RETRIES

    rows = []
    good = OneDof()
    search(good, guess=LIMIT)
    rows.append(check("search, the exact limit as the guess: linear solves", good.solves, "<=", 12))
    plain, capped = OneDof(), OneDof()
    search(plain, guess=LIMIT)
    search(capped, guess=LIMIT, bound=static_cap(LIMIT)[0])
    rows.append(check("search, a static bound at the limit: solves", capped.solves, "<", plain.solves,
                      "the solves without the bound"))
    ruled_out, failing = OneDof(stalls_at=-1.0), OneDof(stalls_at=-1.0)
    search(ruled_out, bound=static_cap(None, falls=True)[0])
    search(failing)
    rows.append(check("self-weight the static theorem rules out: solves (no retry)", ruled_out.solves, "==", 1))
    rows.append(check("self-weight that fails without proof: solves", failing.solves, "==",
                      1 + len(SELF_WEIGHT_RETRIES), "1 + one per self-weight retry"))
    estimates = {"exact": lambda it: LIMIT, "falling": lambda it: LIMIT + 0.5 * (LIMIT - it.x.array[0]),
                 "rising": lambda it: 1.002 * it.x.array[0]}
    for name, level in estimates.items():
        plain, estimated = OneDof(proves=False), OneDof(proves=False)
        bound = static_cap(1.3 * LIMIT)[0]
        search(plain, guess=1.3 * LIMIT, bound=bound)
        search(estimated, guess=1.3 * LIMIT, bound=bound,
               collapse=CollapseCheck(level, lambda lower, trial, it: (False, "no collapse state")))
        if name == "rising":  # never settled: the search as without an estimate
            rows.append(check("collapse-state estimate rising with the load: solves", estimated.solves, "==",
                              plain.solves, "as without an estimate"))
        else:
            rows.append(check(f"collapse-state estimate {name}: solves", estimated.solves, "<=", plain.solves / 2,
                              f"half of {plain.solves} without it"))
    calls = []

    def predicted(level, start):
        calls.append(level)
        return PREDICTED

    plain = search(OneDof(reach=0.05 * LIMIT), guess=1.3 * LIMIT)
    helped = search(Predicted(True, reach=0.05 * LIMIT), guess=1.3 * LIMIT, predicted=predicted)
    rows.append(check("a predicted state that reaches a failed long step: load steps", len(helped.steps), "<",
                      len(plain.steps), "the steps without it"))
    calls.clear()
    search(Predicted(False, reach=0.05 * LIMIT), guess=1.3 * LIMIT, predicted=predicted)
    rows.append(check("a predicted state that never helps: predictions asked", len(calls), "==", FUTILE_PREDICTIONS,
                      "FUTILE_PREDICTIONS in a row, then no more"))
    fill = search(PlasticFillOneDof(), guess=0.3 * LIMIT)
    rows.append(check("plastic fill, 12 Newton iterations every step: load steps", len(fill.steps), "<", 60,
                      "steps that never doubled: about 23 000"))
    return rows


def trial_budget_rows() -> list[Row]:
    """The Newton iterations a trial is given (bridgefem.search.pathfollow, *Failures without proof*) on the wandering
    Newton method of tests/test_pathfollow_budget.py: steps longer than 100 N never converge."""
    from test_bracket import LIMIT, search
    from test_pathfollow_budget import EASY, Wandering

    from bridgefem.search.schedule import BUDGET, BUDGET_FLOOR, RETRY_FLOOR

    rows = []
    solver = Wandering(reach=100.0, band=1e-3 * LIMIT, slow=30)
    search(solver)
    wandering = [(spent, hardest) for length, spent, ended, hardest in solver.trials if not ended and length > 100.0]
    over = [spent - max(BUDGET_FLOOR, BUDGET * hardest) for spent, hardest in wandering]
    rows.append(Row("wandering trials: iterations spent beyond max(BUDGET_FLOOR, BUDGET x hardest step)",
                    f"{max(over, default=0):g} (of {len(wandering)} trials)", "== 0",
                    bool(wandering) and max(over) == 0 and min(over) == 0))
    kept = max((spent for _, spent, ended, _ in solver.trials if ended), default=0)
    rows.append(check("a trial within the width: iterations kept (its band needs 30)", kept, "==", 30))
    solver = Wandering(reach=100.0, band=0.0, slow=EASY)
    s = search(solver, guess=LIMIT)
    tried, again, first = set(), [], []
    for step, (length, spent, ended, _) in zip(s.steps, solver.trials):
        if not ended and length > 100.0:
            (again if step.level in tried else first).append(spent)
        tried.add(step.level)
    retry = max(RETRY_FLOOR, BUDGET * EASY)
    rows.append(Row("a level that failed before, retried: iterations", f"{sorted(set(again))} ({len(again)} trials)",
                    f"== {retry:g} (max(RETRY_FLOOR, BUDGET x {EASY}))", bool(again) and set(again) == {retry}))
    rows.append(Row("a new level that wanders: iterations", f"{sorted(set(first))} ({len(first)} trials)",
                    f"== {BUDGET_FLOOR:g} (BUDGET_FLOOR)", bool(first) and set(first) == {BUDGET_FLOOR}))
    return rows


def condensation_rows() -> list[Row]:
    """What a cycle's condensation costs on the elastic block (three pairs: 2 x 3 + 1 = 7 solves)."""
    from test_cycle_compliance import settled_block

    from bridgefem.solver import cycles as cycles_module
    from bridgefem.solver import newton as solver_module

    rows = []
    solver, start, pairs, level = settled_block()

    def cost(pairs_, solver_=solver):
        before = solver_.stats["solves"]
        solver_.cycles.pair_response(level, start.active, pairs_, start.slip_ref)
        return solver_.stats["solves"] - before

    rows.append(check("condensation of 3 pairs: solves", cost(pairs), "==", 7, "2p + 1"))
    rows.append(check("the same pairs and held states again: solves", cost(pairs), "==", 1, "d0 only"))
    fewer = pairs.copy()
    fewer[np.flatnonzero(pairs)[0]] = False
    rows.append(check("two of the three pairs: solves", cost(fewer), "==", 5, "2p + 1"))
    for change in ("friction", "setting"):
        solver, start, pairs, level = settled_block()
        cost(pairs, solver)
        if change == "friction":
            solver.set_friction_factor(2.0)
        else:
            solver.use(solver_module.Setting(scale=10.0))
        rows.append(check(f"the same pairs after a changed {change}: solves", cost(pairs, solver), "==", 7,
                          "computed again"))
    with patched(cycles_module, "opens_when_pulled", lambda block: len(block) < 4):
        solver, start, pairs, level = settled_block()
        rows.append(check("a condensation declined at the second pair: solves", cost(pairs, solver), "==", 2,
                          "the normal columns of the first two"))
        rows.append(check("the same declined condensation again: solves", cost(pairs, solver), "==", 0))
        solver, start, pairs, level = settled_block()
        a, b, _ = np.flatnonzero(pairs)
        system, unit_rows = solver.system, []
        solve = system._solve

        def recorded(active, x):
            unit_rows.append(np.flatnonzero(system.b.array)[0])
            return solve(active, x)

        both = np.zeros_like(pairs)
        both[[a, b]] = True
        orders = []
        with patched(system, "_solve", recorded):
            for chosen in (pairs, both):
                unit_rows.clear()
                solver.cycles.pair_response(level, start.active, chosen, start.slip_ref)
                orders.append([int(row - solver.n_u) // 2 for row in unit_rows])
        want = [[int(a), int(b)], [int(b), int(a)]]
        rows.append(Row("pairs (a, b, c) declined at b, then (a, b): pairs of the unit solves, in order", str(orders),
                        f"== {want} (the declining pair first the next time)", orders == want))
    solver, start, pairs, level = settled_block()
    solver.use(solver_module.Setting(scale=10.0))
    out = solver.solve_step(level, start)
    solver.use(solver_module.DEFAULT_SETTING)
    solver.solve_step(level, start)
    rows.append(check("a step solved with another setting: retry solves", solver.stats["retry_solves"], "==",
                      out.iterations, "its Newton iterations, the default step's not counted"))
    solver.cycles.condensed(level, start.active, pairs, start.slip_ref, start.active)
    rows.append(check("a condensation of 3 pairs: condensation solves", solver.stats["condensation_solves"], "==", 7))
    return rows


UNIT = (search_rows, trial_budget_rows, condensation_rows)


# ------------------------------------------------------------------------------------------------ campaign rows
@dataclass(frozen=True)
class Case:
    """A campaign scene (seed, index, thickness in m as the campaign gave it), its budget of linear solves per limit
    load, how many re-runs on finer meshes it may make, and the test that checks its answer."""

    seed: int
    index: int
    thickness: float
    budget: int
    test: str
    max_refinements: int | None = None


CASES = (
    Case(1, 104, 2.0383, 150, "test_sliders_leaps.py"),
    Case(1, 270, 0.0908, 150, "test_solver_cycles.py"),
    Case(2, 41, 1.5501, 150, "test_solver_cycles.py"),
    Case(3, 35, 1.3969, 150, "test_sliding_modes.py"),
    Case(4, 10, 0.0444, 150, "test_robustness_cases.py"),
    Case(5, 75, 5.4509, 150, "test_robustness_cases.py"),
    Case(6, 146, 4.1524, 80, "test_robustness_cases.py", max_refinements=0),
    Case(6, 146, 4.1524, 150, "test_refinement.py"),
    Case(4, 38, 3.2503, 150, "test_refinement.py"),
    Case(7, 166, 5.9455, 150, "test_refinement.py"),
    Case(1, 193, 1.8177, 150, "test_refinement.py"),
    Case(9, 159, 0.5711, 150, "test_tresca_predictor.py"),
)


def scene_of(seed: int, index: int, thickness: float, **sections):
    import campaign

    from bridgefem.scene.reader import scene_from_dict

    return scene_from_dict({**campaign.scene_dict(campaign.draw(seed, index), thickness), **sections})


def case_name(case: Case) -> str:
    runs = "first mesh only" if case.max_refinements == 0 else "all runs"
    return f"seed {case.seed} #{case.index} ({runs}; answer: tests/{case.test}): linear solves per limit"


def campaign_row(case: Case) -> Row:
    from bridgefem.analysis.runner import run_analysis

    options = {} if case.max_refinements is None else {"max_refinements": case.max_refinements}
    an = run_analysis(scene_of(case.seed, case.index, case.thickness), **options)
    final = an.solver.stats["solves"]
    coarser = [r.solves for r in an.refinements]
    total = final + sum(coarser)
    shown = f"{total}" + (f" ({' + '.join(map(str, coarser))} + {final})" if coarser else "")
    return Row(case_name(case), f"{shown}; {an.search.status}", f"<= {case.budget}", total <= case.budget)


UNSTABLE_NAME = "seed 1 #111 (answer: tests/test_static_bound.py): load steps to 'unstable under self-weight'"


def unstable_row() -> Row:
    """Campaign seed 1, scene 111: the static theorem rules its self-weight out, so the failed self-weight step is
    the answer (the continuation and the retries cost 259 solves before the bound)."""
    from bridgefem.analysis.runner import run_analysis

    an = run_analysis(scene_of(1, 111, 1.5887))
    row = check(UNSTABLE_NAME, len(an.search.steps), "==", 1, "the failed self-weight step")
    row.count += f"; {an.search.status}"
    return row


RETRIES_NAME = "seed 1 #220, 4 elements (answer: tests/test_nonassociative.py): with the collapse-state check"


def spared_retries_rows() -> list[Row]:
    """Campaign seed 1, scene 220 with 4 elements through the thickness, with and without the collapse-state check
    of the search: with it the closing trial needs no retry, and the limit fewer solves."""
    from mpi4py import MPI

    from bridgefem.analysis import runner as analysis

    scene = scene_of(1, 220, 3.2045, mesh={"elements_through_thickness": 4})

    def run():
        return analysis._analyse(scene, MPI.COMM_WORLD, None, lambda s: None, lambda p: None)

    checked = run()
    with patched(analysis, "collapse_check", lambda *args: None):
        retried = run()
    a, b = checked.solver.stats, retried.solver.stats
    return [check(f"{RETRIES_NAME}: retry solves", a["retry_solves"], "==", 0,
                  f"{b['retry_solves']} without the check"),
            check(f"{RETRIES_NAME}: linear solves", a["solves"], "<", b["solves"], "the solves without the check")]


# ------------------------------------------------------------------------------------------------ the table
def table(rows: list[Row]) -> str:
    lines = ["| budget | count | held to | kept |", "|---|---|---|---|"]
    lines += [f"| {r.name} | {r.count} | {r.budget} | {'yes' if r.kept else 'NO'} |" for r in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="the unit rows only (seconds)")
    p.add_argument("--only", default="", metavar="TEXT", help="only the rows whose name contains TEXT")
    args = p.parse_args(argv)
    logging.getLogger().setLevel(logging.WARNING)  # no JIT compiler chatter
    rows = [r for group in UNIT for r in group()]
    if not args.quick:
        rows += [campaign_row(c) for c in CASES if args.only in case_name(c)]
        if args.only in UNSTABLE_NAME:
            rows.append(unstable_row())
        if args.only in RETRIES_NAME:
            rows += spared_retries_rows()
    rows = [r for r in rows if args.only in r.name]
    print("# Solve-count budgets\n")
    print(table(rows))
    over = [r for r in rows if not r.kept]
    print(f"\n{len(rows) - len(over)} of {len(rows)} budgets kept" + (f"; exceeded: {len(over)}" if over else ""))
    return 1 if over else 0


if __name__ == "__main__":
    raise SystemExit(main())
