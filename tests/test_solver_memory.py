"""A long search holds its memory: the PETSc objects a run drops are freed as it goes. petsc4py 3.18 (Debian 12)
frees a PETSc object that Python drops only in ``PETSc.garbage_cleanup``; a vector per fill evaluation or per Newton
iteration left to it grew a Mohr-Coulomb fill's run by about one system vector per iteration (a 38k-unknown bridge
from 0.35 to 0.9 GB in 28 load steps, docs/robustness.md). Measured here as the process's resident memory over many
evaluations and load steps, against the size of the vectors that would pile up."""
import gc

import numpy as np
import pytest
from conftest import scene_dict
from mpi4py import MPI
from petsc4py import PETSc

from bridgefem.analysis.build import Clock, build_model
from bridgefem.scene.reader import scene_from_dict

MOHR_COULOMB = {"unit_weight": 18000.0, "young": 5e7, "depth": 0.5, "extension": 2.0, "material": "mohr-coulomb",
                "friction_angle": 35.0, "cohesion": 5e3}


def resident_mb() -> float:
    """The process's resident memory (MB)."""
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) / 1e3 for line in f if line.startswith("VmRSS"))


def settled_mb() -> float:
    """The resident memory (MB) once what the earlier tests dropped is collected and its PETSc objects freed: a model
    that an earlier test left in reference cycles, collected during the measurement, would count there."""
    gc.collect()
    PETSc.garbage_cleanup()
    return resident_mb()


def growth_mb(work) -> float:
    """The resident memory (MB) that a second run of ``work`` adds. The first run warms up what is allocated once and
    kept (the allocator's pools, caches of the forms and their PETSc objects: about 3 MB for the fill's evaluations),
    so that what the second adds is what every run would add."""
    work()
    before = settled_mb()
    work()
    return resident_mb() - before


@pytest.fixture(scope="module")
def model():
    """The FE model of the reference arch under a Mohr-Coulomb fill, quadratic elements (about 10k unknowns)."""
    scene = scene_from_dict(scene_dict(fill=MOHR_COULOMB, load=[{"kind": "patch", "position": 0.3, "length": 0.5}],
                                       mesh={"degree": 2, "elements_through_thickness": 4}))
    return build_model(scene, MPI.COMM_WORLD, None, lambda _: None, Clock(MPI.COMM_WORLD))


@pytest.mark.slow  # an end-to-end run of more than a second
def test_the_fills_evaluations_free_their_vectors(model):
    """150 evaluations of the fill (internal force and tangent), after as many to warm up: the resident memory grows
    by less than a tenth of the 150 vectors of the displacements that one new vector per evaluation would hold."""
    fill, n_u = model.solver.material, model.solver.n_u
    plastic = fill.initial_plastic_strain()
    u = np.zeros(fill.n_owned)

    def evaluations():
        for k in range(150):
            fill.evaluate(u + 1e-9 * k, plastic)

    grown, piled = growth_mb(evaluations), 150 * 8 * n_u / 1e6
    assert grown < 0.1 * piled, (grown, piled)


@pytest.mark.slow
def test_newton_steps_free_the_vectors_they_drop(model):
    """20 self-weight steps of 3 Newton iterations from the unloaded state (each copies its start and makes its
    iterate), after as many to warm up: the resident memory grows by less than a tenth of two system vectors per
    step."""
    solver = model.solver
    start = solver.initial_iterate()

    def steps():
        for _ in range(20):
            solver.solve_step(0.0, start, iterations=3)

    grown, piled = growth_mb(steps), 20 * 2 * 8 * solver.system.N / 1e6
    assert grown < 0.1 * piled, (grown, piled)
