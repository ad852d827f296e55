"""The reduced system's solves for a new active set by the factorisation of an earlier one and a low-rank correction
(bridgefem.solver.low_rank) against the whole system factorised afresh by MUMPS: the same solution while the
factorisation is kept, a singular system found singular as a factorisation finds it, and a factorisation once the
correction's columns would cost more than one."""
import numpy as np
import pytest
from conftest import assert_two_ranks_give, scene_dict, write_toml
from mpi4py import MPI
from petsc4py import PETSc
from test_interior import both_solves

from bridgefem.analysis.build import Clock, build_model
from bridgefem.analysis.runner import run_analysis
from bridgefem.laws.base import ContactState
from bridgefem.scene.reader import scene_from_dict


@pytest.fixture
def system():
    """A fresh contact system (its own factorisation and update) of the reference arch, condensed (t/8)."""
    scene = scene_from_dict(scene_dict(mesh={"elements_through_thickness": 8}))
    model = build_model(scene, MPI.COMM_WORLD, None, lambda name: None, Clock(MPI.COMM_WORLD))
    return model.solver.system


def stuck(system) -> ContactState:
    m = len(system.pairs)
    return ContactState(np.full(m, system.law.STICK, dtype=np.int8), np.zeros(m, dtype=np.int8))


def changed(active: ContactState, pairs: np.ndarray, state: int, sign: int = 0) -> ContactState:
    out = active.copy()
    out.state[pairs], out.sign[pairs] = state, sign
    return out


def assert_same(x: PETSc.Vec, y: PETSc.Vec) -> None:
    """The condensed solve's displacements and forces are the whole system's to 1e-8 of each kind's largest."""
    scale = y.norm(PETSc.NormType.INFINITY)
    assert (x - y).norm(PETSc.NormType.INFINITY) <= 1e-8 * scale


def test_active_sets_a_few_pairs_apart_are_solved_by_one_factorisation(system):
    """From every pair stuck: a few pairs open, then more, then the later ones slide instead, as many pairs as the
    factorisation's flops buy columns of the correction (two rows a pair); each solve is the whole system's fresh
    factorisation's, and the reduced system is factorised for none of them."""
    law, update = system.law, system.linear.condensation.update
    active = stuck(system)
    (x, fail), (y, whole) = both_solves(system, active, level=5e4)
    assert fail is None and whole is None
    first = system.linear.stats["factorisations"]
    n = int(1.0 / update.column_cost) // 2
    assert n >= 4
    pairs = np.random.default_rng(20261201).choice(len(system.pairs), n, replace=False)
    for active in (changed(active, pairs[:n // 2], law.OPEN), changed(active, pairs, law.OPEN),
                   changed(changed(active, pairs[:n // 2], law.OPEN), pairs[n // 2:], law.SLIP, 1)):
        (x, fail), (y, whole) = both_solves(system, active, level=5e4)
        assert fail is None and whole is None
        assert_same(x, y)
    assert system.linear.stats["factorisations"] == first
    assert update.updates == 3 and update.fallbacks == 0 and len(update.columns) == 2 * n


def test_a_change_that_makes_a_mechanism_is_found_singular_as_by_a_factorisation(system):
    """Two joints opened whole cut a piece of the arch free: the condensed solve after the update fails as the whole
    system's does (MUMPS: numerically singular), by a factorisation of the new set."""
    law = system.law
    active = stuck(system)
    assert both_solves(system, active, level=0.0)[0][1] is None
    joints = system.pairs.joint
    cut = np.flatnonzero(np.isin(joints, np.unique(joints)[[3, 7]]))
    before = system.linear.stats["factorisations"]
    (x, condensed), (y, whole) = both_solves(system, changed(active, cut, law.OPEN), level=0.0)
    assert (condensed is None) == (whole is None)
    if whole is None:  # both return the free piece's displacements of kilometres
        u = slice(0, system.n_u)
        assert np.abs(x.array[u]).max() > 1e3 and np.abs(y.array[u]).max() > 1e3
    else:
        assert condensed.singular and whole.singular
    assert system.linear.stats["factorisations"] == before + 1


def test_the_factorisation_is_renewed_once_the_correction_would_cost_more(system):
    """Rent or buy: with the columns a factorisation's flops buy (MUMPS's counts) spent, the next new pair's rows
    make a factorisation, and the reduced system then holds that set's rows."""
    law, update = system.law, system.linear.condensation.update
    active = stuck(system)
    both_solves(system, active, level=5e4)
    budget = int(1.0 / update.column_cost)
    assert 2 < budget < len(system.pairs)
    order = np.random.default_rng(7).permutation(len(system.pairs))
    first = system.linear.stats["factorisations"]
    for k in range(1, len(system.pairs)):
        active = changed(active, order[:k], law.OPEN)
        (x, fail), (y, whole) = both_solves(system, active, level=5e4)
        assert (fail is None) == (whole is None)
        if system.linear.stats["factorisations"] > first:
            break
        assert_same(x, y)
    assert len(update.columns) == 0 and np.array_equal(update.base, update.current)
    assert 2 * (k - 1) <= budget < 2 * k  # each pair opened changes its normal and tangential rows


@pytest.mark.mpi
@pytest.mark.slow  # a limit analysis, serial and under mpirun -n 2
def test_a_limit_analysis_with_updated_solves_gives_its_bracket_on_two_ranks(tmp_path):
    """The reference arch condensed (t/16): the serial limit analysis solves some active sets by an update, and two
    ranks, each computing a share of the correction's columns, give its bracket."""
    d = scene_dict(mesh={"elements_through_thickness": 16})
    serial = run_analysis(scene_from_dict(d), MPI.COMM_WORLD)
    assert serial.search.status == "limit load found" and serial.solver.stats["updates"] > 0
    assert_two_ranks_give(write_toml(tmp_path / "arch.toml", d), serial)
