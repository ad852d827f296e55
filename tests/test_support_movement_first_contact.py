"""The repair of an inadmissible diverging mode closes the pairs that close first along it
(bridgefem.solver.mechanism.first_contact; bridgefem/solver/newton.py, *First contact*): a support movement that closes the span leaves the ring at its maximum thrust, four hinges with
the thrust line through all four, and the first live-load increment must close one hinge, not two."""
import json

import numpy as np
import pytest
from conftest import bridgefem, write_toml
from test_block import block_solver

from bridgefem.fe.pairs import GROUND
from bridgefem.laws.coulomb import ContactState, CoulombJoints
from bridgefem.solver.mechanism import FIRST_CONTACT, first_contact

OPEN, STICK = CoulombJoints.OPEN, CoulombJoints.STICK


def _lifted_block(lift: float, tilt: float):
    """The block of tests/test_block.py (8 elements through its base), every base pair open: its base nodes lifted
    by lift + tilt x position (m; position from the base's intrados corner, m), the gaps of their pairs; the mode:
    a unit downward translation of those nodes (closing rate 1 at every pair). One rank (global node indices)."""
    solver, _ = block_solver(2.0, 1.0, elements=8)
    pairs = solver.pairs
    node = np.where(pairs.left == GROUND, pairs.right, pairs.left)
    origin = solver.initial_iterate().x.copy()
    origin.set(0.0)
    origin.array[2 * node + 1] = lift + tilt * pairs.position
    solver.system._mode.set(0.0)
    solver.system._mode.array[2 * node + 1] = -1.0
    active = ContactState(np.full(len(pairs), OPEN, dtype=np.int8), np.zeros(len(pairs), dtype=np.int8))
    return solver, origin, active


def test_the_repair_keeps_the_pairs_that_close_first_along_the_mode():
    """Made-up case: gaps 1 mm + 0.3 mm/m x position (positions 0, 0.125, ..., 1 m), every pair closing at rate 1.
    The pairs whose gap is within FIRST_CONTACT (10 %) of the least, 1 mm, close first: positions 0, 0.125 and
    0.25 m (gaps 1, 1.0375, 1.075 mm; the next, 1.1125 mm, is beyond), whether the verdict's repair named every
    pair or the last alone (gap 1.3 mm). A repair that only sticks a closed pair (one sliding backwards) stays."""
    lift, tilt = 1e-3, 3e-4
    solver, origin, active = _lifted_block(lift, tilt)
    gap = solver.system.split(origin)[2][:, 0]
    assert gap == pytest.approx(lift + tilt * solver.pairs.position, rel=1e-9)  # the made-up state's gaps
    system = solver.system
    rate = -(system.split(system._mode)[2][:, 0] - system.ground[:, 0])  # the mode's closing, 1 at every pair
    assert rate == pytest.approx(np.ones(len(solver.pairs)), rel=1e-12)
    everything = np.ones(len(solver.pairs), dtype=bool)
    first = first_contact(everything, rate, gap, active.state == OPEN)
    assert np.flatnonzero(first).tolist() == np.flatnonzero(tilt * solver.pairs.position
                                                            <= FIRST_CONTACT * lift).tolist() == [0, 1, 2]
    last = np.arange(len(solver.pairs)) == len(solver.pairs) - 1
    assert np.flatnonzero(first_contact(last, rate, gap, active.state == OPEN)).tolist() == [0, 1, 2]
    active.state[4] = STICK
    kept = first_contact(np.arange(len(solver.pairs)) == 4, rate, gap, active.state == OPEN)
    assert np.flatnonzero(kept).tolist() == [4]


@pytest.mark.slow
def test_a_ring_pushed_to_its_maximum_thrust_by_a_closing_support_reaches_the_lp(tmp_path):
    """Campaign seed 1 #147 with its --options support movement (semicircle, span 11.274 m, t = 0.9166 m, 39
    voussoirs, mu = 0.525): the right springing moves 8.06 mm inwards and settles 9.43 mm. From 0.6 of that movement
    on, the ring is at its maximum thrust: hinges at both springings' extrados and at joints 10 and 29's intrados,
    the thrust line through all four (equal forces at joints 10 and 29 though the movement is not symmetric). A live
    load of 0.13 N opened the last pair next to joint 29's hinge, and the repair of the four-hinge mode closed
    joints 0 and 10 together, which the mode closes at amplitudes 28 % apart: every trial failed down to 0.13 N, a
    solver failure. The rigid-block collapse load does not depend on a support movement (small displacements; the LP
    does not model it): the ring reaches the LP's limit (within 0.5 %, the evidence rule's agreement)."""
    scene = {"scene": {"name": "moved"},
             "arch": {"shape": "semicircular", "span": 11.274, "thickness": 0.9166, "width": 1.0, "voussoirs": 39,
                      "joint_at_loads": True},
             "masonry": {"young": 3.66e10, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 0.525},
             "load": [{"kind": "point", "position": 0.2269}],
             "abutments": {"movement_springing": "right", "movement_horizontal": -0.008061,
                           "movement_vertical": -0.009425}}
    proc = bridgefem("run", str(write_toml(tmp_path / "s.toml", scene)), "--out", str(tmp_path / "out"))
    data = json.loads((tmp_path / "out" / "results.json").read_text())
    assert proc.returncode == 0 and data["status"] == "limit load found", data["status"]
    lower, upper, lp = data["limit_load"]["lower"], data["limit_load"]["upper"], data["lp"]["load"]
    assert lower <= 1.005 * lp and upper >= 0.995 * lp
