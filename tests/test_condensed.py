"""The joint problem condensed onto the joint forces (bridgefem.solver.condensed) against a bar on the ground, by hand,
and end to end on a barrel of rings whose self-weight the active-set method cannot reach from the bonded start.

The bar: two nodes (u_x, u_y each) joined by springs k_x, k_y (N/m) along x and y, no other support: the bar is free
to translate (two rigid-body modes). Each node rests on the ground through one pair (normal +y: d_n = u_y, opening;
tangent +x: d_t = u_x), friction mu. Loads: -W on each node along y, a push H on node 1 along x. By hand (Coulomb, no
dilatancy): both pairs closed with lam_n = W; for H <= mu W pair 1 holds the push (lam_t1 = -H, nothing moves); for
mu W < H <= 2 mu W pair 1 slides (lam_t1 = -mu W), node 1 moves (H - mu W) / k_x and the spring hands H - mu W to
pair 2, which holds it; past 2 mu W both slide and no equilibrium exists.
"""
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import ROOT, scene_dict
from mpi4py import MPI

from bridgefem.analysis.build import Clock, build_model
from bridgefem.fe.pairs import GROUND
from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.scene.reader import scene_from_dict
from bridgefem.search.selfweight import condensed_self_weight, self_weight_budget
from bridgefem.solver.condensed import BlockCompliance, CondensedPredictor

K_X, K_Y, MU, W = 2.0e8, 5.0e8, 0.6, 1.0e4
BAR = BlockCompliance.of(
    sp.csr_matrix(np.array([[K_X, 0, -K_X, 0], [0, K_Y, 0, -K_Y], [-K_X, 0, K_X, 0], [0, -K_Y, 0, K_Y]])),
    sp.csr_matrix(np.array([[0, 1.0, 0, 0], [1.0, 0, 0, 0], [0, 0, 0, 1.0], [0, 0, 1.0, 0]])))
NO_OFFSET = np.zeros((2, 2))
LAW = CoulombJoints(np.full(2, MU), np.full(2, K_Y), 1e-9 * W, cohesion=np.zeros(2))


def loads(push: float) -> np.ndarray:
    return np.array([push, -W, 0.0, -W])


@pytest.mark.parametrize("share", [0.5, 1.5])
def test_a_bar_on_the_ground_holds_its_push_as_by_hand(share):
    """Tresca with g = mu W at both pairs (the Coulomb law at these normal forces): the hand solution above."""
    push = share * MU * W
    u, lam = BAR.solve(loads(push), NO_OFFSET, np.full(2, MU * W))
    assert lam[:, 0] == pytest.approx([W, W], rel=1e-7)
    slide = max(push - MU * W, 0.0)
    assert lam[:, 1] == pytest.approx([-min(push, MU * W), -slide], rel=1e-7, abs=1e-7 * W)
    assert u[0] - u[2] == pytest.approx(slide / K_X, rel=1e-6, abs=1e-9 * W / K_X)  # the spring's stretch
    assert abs(u[2]) < 1e-9 * W / K_X and abs(u[1]) < 1e-9 * W / K_Y and abs(u[3]) < 1e-9 * W / K_Y


def test_a_bar_pushed_past_both_pairs_friction_has_no_equilibrium():
    assert BAR.solve(loads(2.2 * MU * W), NO_OFFSET, np.full(2, MU * W)) is None


def test_the_coulomb_fixed_point_of_the_bar_reaches_the_hand_solution():
    """The associative problem lets pair 1 dilate as it slides, so its normal forces are not W (12.37 and 7.63 kN
    here); the first Tresca state, at those capacities, has the normal forces W, and the second, at mu W, is the
    hand solution (the first Tresca normal forces are taken whole)."""
    states = BAR.coulomb_states(loads(1.5 * MU * W), NO_OFFSET, LAW)
    first, second = next(states), next(states)
    assert first[1][:, 0] == pytest.approx([W, W], rel=1e-7)
    assert abs(first[1][0, 1]) > 1.2 * MU * W  # the associative normal force's capacity, not the hand one
    assert second[1][:, 0] == pytest.approx([W, W], rel=1e-7)
    assert second[1][:, 1] == pytest.approx([-MU * W, -0.5 * MU * W], rel=1e-6)


def test_a_stiffness_with_large_blocks_is_not_condensed(monkeypatch):
    """Blocks whose dense inverses exceed ``DENSE_BYTES`` in all are not condensed: five 1 x 1 blocks (40 bytes)
    are, one 2 x 2 block (32 bytes) is not under a 31-byte limit."""
    from bridgefem.solver import condensed
    monkeypatch.setattr(condensed, "DENSE_BYTES", 40.0)
    assert condensed.BlockCompliance.of(sp.identity(5, format="csr"), sp.csr_matrix((2, 5))) is not None
    monkeypatch.setattr(condensed, "DENSE_BYTES", 31.0)
    assert condensed.BlockCompliance.of(sp.csr_matrix(np.ones((2, 2))), sp.csr_matrix((2, 2))) is None


# Three staggered rings of 8 voussoirs over a parabola (seed 20261221 #0 of the rings campaign with fewer voussoirs
# and rings): from the bonded start the ring interfaces' active set keeps changing, whatever the friction.
BARREL = scene_dict(arch={"shape": "parabolic", "span": 7.547, "rise": 3.177, "thickness": 0.1999, "voussoirs": 8,
                          "joint_at_loads": False, "rings": 3, "ring_bond": "aligned"},
                    masonry={"young": 1.02e9}, joints={"friction": 5.142, "ring_friction": 0.781,
                                                       "ring_cohesion": 1680.0},
                    load=[{"kind": "point", "position": 0.8999}], mesh={"elements_through_thickness": 2})


@pytest.mark.slow  # an end-to-end run of more than a second
def test_a_barrel_carries_its_weight_from_the_condensed_states():
    """The self-weight's one step of the barrel from the bonded start does not converge (the ring interfaces' active
    set keeps changing); solved again from the condensed states it converges, and the ground's reactions carry the
    applied weight (conservation: the vertical reactions sum to the vertical nodal forces)."""
    comm = MPI.COMM_WORLD
    solver = build_model(scene_from_dict(BARREL), comm, None, lambda name: None, Clock(comm)).solver
    solver.max_iterations = self_weight_budget(solver)
    start = solver.initial_iterate()
    assert not solver.solve_step(0.0, start).converged
    out = condensed_self_weight(lambda level, begin, **options: solver.solve_step(level, begin, **options),
                                start, CondensedPredictor(solver).states)
    assert out is not None and out.converged
    _, lam, _ = solver.system.split(out.iterate.x)
    pairs = solver.pairs
    ground = (pairs.left == GROUND) | (pairs.right == GROUND)
    side = np.where(pairs.right[ground] == GROUND, 1.0, -1.0)  # the force on the ground's face, up positive
    reaction = side * (lam[ground, 0] * pairs.normal[ground, 1] + lam[ground, 1] * pairs.tangent[ground, 1])
    weight = -float(solver.system.loads(0.0)[1::2].sum())
    assert abs(abs(reaction.sum()) - weight) <= 1e-6 * weight


MPI_SCRIPT = """
import json, sys
from mpi4py import MPI
from bridgefem.analysis.build import Clock, build_model
from bridgefem.scene.reader import scene_from_dict
from bridgefem.search.selfweight import condensed_self_weight, self_weight_budget
from bridgefem.solver.condensed import CondensedPredictor
comm = MPI.COMM_WORLD
solver = build_model(scene_from_dict(json.loads(sys.argv[1])), comm, None, lambda name: None, Clock(comm)).solver
solver.max_iterations = self_weight_budget(solver)
start = solver.initial_iterate()
out = condensed_self_weight(lambda level, begin, **o: solver.solve_step(level, begin, **o), start,
                            CondensedPredictor(solver).states)
_, lam, _ = solver.system.split(out.iterate.x)
normal = comm.allreduce(float(abs(lam[:, 0]).sum()), op=MPI.SUM)
print(json.dumps([comm.rank, out.converged, normal]))
"""


@pytest.mark.slow
def test_two_ranks_carry_the_barrels_weight_from_the_same_condensed_states():
    """Under ``mpirun -n 2`` (K and G gathered on rank 0, the states scattered) both ranks converge, with the serial
    run's joint forces (the sum of |lam_n| over all pairs, to 1e-6)."""
    comm = MPI.COMM_WORLD
    solver = build_model(scene_from_dict(BARREL), comm, None, lambda name: None, Clock(comm)).solver
    solver.max_iterations = self_weight_budget(solver)
    start = solver.initial_iterate()
    serial = condensed_self_weight(lambda level, begin, **o: solver.solve_step(level, begin, **o), start,
                                   CondensedPredictor(solver).states)
    total = float(np.abs(solver.system.split(serial.iterate.x)[1][:, 0]).sum())
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    proc = subprocess.run(["mpirun", "-n", "2", sys.executable, "-c", MPI_SCRIPT, json.dumps(BARREL)],
                          capture_output=True, text=True, timeout=600, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    ranks = [json.loads(found) for found in re.findall(r"\[[^\]]*\]", proc.stdout)]  # lines may interleave
    assert sorted(r[0] for r in ranks) == [0, 1]
    for _, converged, normal in ranks:
        assert converged and normal == pytest.approx(total, rel=1e-6)
