"""The joint law is a seam (issue 38): a law written here alone, injected into a limit analysis, runs through the
whole solver and the rigid-block LP. The toy law is Coulomb friction with a tensile strength f_t (Pa): the Coulomb
law shifted along the normal by each pair's tensile capacity T = f_t x width x the pair's tributary length (N), so
that lam_n + T takes the place of lam_n:

    lam_n >= -T,   d_n >= 0,   (lam_n + T) d_n = 0,   |lam_t| <= mu (lam_n + T)

An open pair carries the tension T (a perfectly plastic tension cut-off); a rigid-block joint of length t carries
n >= -f_t w t, |m| <= (n + f_t w t) t / 2 and |s| <= mu (n + f_t w t) (the compression at an edge, the tension f_t
spread over the joint). With f_t = 0 the law is Coulomb's and the analysis must be the same to the last bit; with
f_t > 0 the ring carries more, as much as the rigid blocks with the same tensile strength."""
from dataclasses import dataclass, replace

import numpy as np
from conftest import SMALL_RING
from mpi4py import MPI

from bridgefem.analysis.build import Clock, build_model
from bridgefem.analysis.runner import run_analysis
from bridgefem.analysis.static_bound import fe_blocks
from bridgefem.laws.base import BlockYield, ContactState, ModeRules
from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.limit.rigid_block import solve_blocks
from bridgefem.scene.reader import scene_from_dict


@dataclass
class TensileJoints(CoulombJoints):
    """Coulomb friction with the tensile strength ``strength`` (Pa) over the joints' ``width`` (m); ``tension``: each
    pair's tensile capacity (N)."""

    strength: float = 0.0
    width: float = 1.0
    tension: np.ndarray | None = None

    def _shifted(self, lam: np.ndarray) -> np.ndarray:
        shifted = lam.copy()
        shifted[:, 0] += self.tension
        return shifted

    def classify(self, prev: ContactState, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray):
        return super().classify(prev, self._shifted(lam), d, slip_ref)

    def residual(self, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray) -> np.ndarray:
        return super().residual(self._shifted(lam), d, slip_ref)

    def rhs(self, active: ContactState, slip_ref: np.ndarray, ground: np.ndarray):
        """An open pair carries lam_n = -T, a sliding one lam_t = s mu (lam_n + T)."""
        r_n, r_t = super().rhs(active, slip_ref, ground)
        return (np.where(active.state == self.OPEN, r_n - self.tension, r_n),
                np.where(active.state == self.SLIP, r_t + active.sign * self.mu * self.tension, r_t))

    def sliding_forces(self, active: ContactState, lam_n: np.ndarray) -> np.ndarray:
        return super().sliding_forces(active, lam_n + self.tension)

    def mode_rules(self, active: ContactState) -> ModeRules:
        """An open pair carries its tension T: a mode that opens it does work against T."""
        return super().mode_rules(active)._replace(tension=self.tension)

    def block_yield(self, length: np.ndarray, mu: np.ndarray, capacity: np.ndarray) -> BlockYield:
        """Coulomb's rows with n + T in place of n, T = f_t w t."""
        rows = CoulombJoints.block_yield(length, mu, capacity)
        tension = self.strength * self.width * length
        rhs = rows.rhs + np.column_stack([tension * length / 2, tension * length / 2, mu * tension, mu * tension])
        return rows._replace(rhs=rhs, n_min=-tension)


def tensile_law(strength: float, width: float):
    """The factory of :func:`bridgefem.analysis.runner.run_analysis` that builds :class:`TensileJoints`."""
    def build(pairs, friction, c, force_tol) -> TensileJoints:
        mu = np.broadcast_to(np.asarray(friction, float), (len(pairs),)).copy()
        return TensileJoints(mu, c, force_tol, strength=strength, width=width,
                             tension=strength * width * pairs.length)
    return build


RING = {**SMALL_RING, "scene": {"name": "seam"}, "mesh": {"elements_through_thickness": 2}}


def analyse(law=None):
    scene = scene_from_dict(RING)
    an = run_analysis(scene, MPI.COMM_WORLD) if law is None else run_analysis(scene, MPI.COMM_WORLD, joint_law=law)
    return scene, an


def test_without_tensile_strength_the_injected_law_is_coulombs_to_the_last_bit():
    """f_t = 0: the same steps, active sets, solves and bracket as the built-in Coulomb law."""
    _, coulomb = analyse()
    _, toy = analyse(tensile_law(0.0, 1.0))
    assert type(toy.solver.law) is TensileJoints
    assert (toy.search.status, toy.search.lower, toy.search.upper) == \
        (coulomb.search.status, coulomb.search.lower, coulomb.search.upper)
    assert toy.solver.stats["solves"] == coulomb.solver.stats["solves"]
    assert [(s.level, s.converged, s.iterations, s.counts) for s in toy.search.steps] == \
        [(s.level, s.converged, s.iterations, s.counts) for s in coulomb.search.steps]
    assert np.array_equal(toy.converged[-1].pair_state, coulomb.converged[-1].pair_state)


def test_a_tensile_strength_raises_the_limit_to_the_rigid_blocks_with_the_same_strength():
    """f_t = 20 kPa: the ring carries almost twice as much, and its limit is the rigid-block LP's on the same joints
    under the FE's own loads with the same tensile strength (the law's own LP rows, :meth:`TensileJoints.block_yield`):
    the FE's converged equilibrium obeys those rows, so it lies below the LP (the static theorem), and its collapse
    is proved by a rigid-block mode on which the loads do more work than the open pairs' tension dissipates. Three
    pairs per joint with tributary lengths t/4, t/2, t/4 carry the LP's moment (n + f_t w t) t / 2 exactly."""
    _, coulomb = analyse()
    scene, toy = analyse(tensile_law(20e3, 1.0))
    law = TensileJoints(np.zeros(0), np.zeros(0), 0.0, strength=20e3, width=1.0)
    blocks = fe_blocks(scene, toy.model, toy.block_mesh)
    lp, lp_coulomb = solve_blocks(replace(blocks, law=law)), solve_blocks(blocks)
    assert toy.search.status == "limit load found" and toy.search.proved
    assert toy.search.lower > 1.5 * coulomb.search.upper and lp.level > 1.5 * lp_coulomb.level
    assert toy.search.lower <= lp.level * (1 + 1e-9) and toy.search.upper >= lp.level * (1 - 1e-3)


def test_a_clamp_on_coulombs_joints_is_the_tensile_strength_law():
    """The self-weight's tension continuation clamps each pair of Coulomb's joints by its tensile capacity T
    (ContactSolver.set_tension) instead of changing the law: the same steps as the toy law with f_t = 20 kPa, here a
    self-weight and a live-load step of the small ring, give the same active sets and displacements, and the clamped
    joint forces are the toy's plus (T, 0)."""
    scene = scene_from_dict(RING)
    clock = Clock(MPI.COMM_WORLD)
    toy = build_model(scene, MPI.COMM_WORLD, None, lambda name: None, clock, tensile_law(20e3, 1.0)).solver
    clamped = build_model(scene, MPI.COMM_WORLD, None, lambda name: None, clock).solver
    tension = 20e3 * 1.0 * clamped.pairs.length
    clamped.set_tension(tension)
    starts = [toy.initial_iterate(), clamped.initial_iterate()]
    for level in (0.0, 5e3):
        steps = [s.solve_step(level, start) for s, start in zip((toy, clamped), starts)]
        assert all(out.converged for out in steps)
        (u_toy, lam_toy, _), (u, lam, _) = (s.system.split(out.iterate.x) for s, out in zip((toy, clamped), steps))
        assert np.array_equal(steps[0].iterate.active.state, steps[1].iterate.active.state)
        assert np.allclose(u, u_toy, rtol=1e-9, atol=1e-12 * np.abs(u_toy).max())
        assert np.allclose(lam - lam_toy, np.column_stack([tension, np.zeros_like(tension)]), rtol=0,
                           atol=1e-7 * np.abs(lam_toy).max())
        starts = [s.converged_slip_reference(out.iterate) for s, out in zip((toy, clamped), steps)]
    clamped.set_tension(None)
    assert np.array_equal(clamped.system.loads(0.0), clamped.system.f_dead.array)
