"""A re-run's trials start from its coarser run's path (bridgefem.search.coarser_path): the transfer between meshes is
checked on made-up pairs against fields whose interpolation is exact, and on a campaign ring whose re-run it
makes cheaper."""
import numpy as np
from mpi4py import MPI

from bridgefem.fe.pairs import ARCH_FILL, FILL_KIND, JointPairs
from bridgefem.search.coarser_path import CoarserPath

THICKNESS = 0.6  # m, every joint's length


def joint_pairs(per_joint: int, joints: int = 3, fill: int = 0) -> JointPairs:
    """``joints`` ring joints of ``per_joint`` equally spaced pairs each (tributary lengths as a mesh gives them),
    then ``fill`` arch-fill pairs."""
    position = np.tile(np.linspace(0.0, THICKNESS, per_joint), joints)
    length = np.tile(np.r_[0.5, np.ones(per_joint - 2), 0.5] * THICKNESS / (per_joint - 1), joints)
    joint = np.repeat(np.arange(joints), per_joint)
    joint, position, length = (np.r_[a, np.full(fill, v)] for a, v in ((joint, ARCH_FILL), (position, 1.0),
                                                                         (length, 0.1)))
    n = len(joint)
    zeros = np.zeros((n, 2))
    kind = np.where(joint == ARCH_FILL, FILL_KIND, "voussoir")
    return JointPairs(joint, kind, np.zeros(n, int), np.zeros(n, int), zeros, zeros, length, position, zeros,
                      np.zeros((n, 2), int), 0, n)


def fields(pairs: JointPairs, level: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint forces (N) and relative displacements (m) whose tractions and displacements are linear along each
    joint and in the level (the transfer is exact for them)."""
    s, j = pairs.position, pairs.joint.astype(float)
    traction = np.stack([-1e5 * level * (1 + j) * (1 - s), 2e4 * level * s], axis=1)
    d = np.stack([1e-4 * level * s * (j + 2), -3e-5 * level * (1 + s)], axis=1)
    return traction * pairs.length[:, None], d


def coarse_path(levels=(0.0, 1.0, 3.0)) -> CoarserPath:
    coarse = joint_pairs(3)
    return CoarserPath.of(coarse, [(level, *fields(coarse, level)) for level in levels], MPI.COMM_WORLD)


def test_a_trial_starts_from_the_finer_state_plus_the_coarser_paths_increment():
    """Coarse joints of 3 pairs, fine of 5: the fine start at 2.5 from a fine state at 1.0 is that state plus the
    increment of the linear fields from 1.0 to 2.5 (the path is linear between its levels 1 and 3), forces scaled
    by the fine pairs' tributary lengths; arch-fill pairs keep their state."""
    fine = joint_pairs(5, fill=2)
    lam, d = fields(fine, 1.0)
    lam[-2:], d[-2:] = 7.0, 8.0
    start = coarse_path().start(fine, lam, d, 1.0, 2.5)
    want_lam, want_d = fields(fine, 2.5)
    ring = fine.joint >= 0
    assert np.allclose(start.lam[ring], want_lam[ring], rtol=1e-12, atol=1e-9)
    assert np.allclose(start.d[ring], want_d[ring], rtol=1e-12, atol=1e-15)
    assert np.all(start.lam[~ring] == 7.0) and np.all(start.d[~ring] == 8.0)
    assert lam[-1, 0] == 7.0 and np.allclose(lam[:-2], fields(fine, 1.0)[0][:-2])  # the state is not changed


def test_the_start_is_the_increment_not_the_coarser_state():
    """A fine state that differs from the coarse one (another mesh's elastic displacements) keeps its difference:
    over a step the start moves by the coarse path's increment only."""
    fine = joint_pairs(5)
    lam, d = fields(fine, 1.0)
    start = coarse_path().start(fine, lam + 3.0, d + 1e-3, 1.0, 2.0)
    want_lam, want_d = fields(fine, 2.0)
    assert np.allclose(start.lam, want_lam + 3.0) and np.allclose(start.d, want_d + 1e-3)


def test_a_start_up_to_the_paths_last_level_and_none_beyond_it_or_without_live_load():
    """The path's last converged level (3.0) starts a trial, exactly its fields there; a level beyond it is not
    extrapolated."""
    fine = joint_pairs(5)
    lam, d = fields(fine, 1.0)
    path = coarse_path()
    start = path.start(fine, lam, d, 1.0, 3.0)
    want_lam, want_d = fields(fine, 3.0)
    assert np.allclose(start.lam, want_lam, rtol=1e-12, atol=1e-9) and np.allclose(start.d, want_d, atol=1e-15)
    assert path.start(fine, lam, d, 1.0, 3.0 * (1 + 1e-9)) is None
    coarse = joint_pairs(3)
    assert CoarserPath.of(coarse, [(0.0, *fields(coarse, 0.0))], MPI.COMM_WORLD) is None


def test_a_level_reached_again_takes_the_later_state():
    """A level converged twice (a self-weight continuation's steps at live load 0, a backtrack) is the later
    state."""
    coarse = joint_pairs(3)
    lam0, d0 = fields(coarse, 0.0)
    stale = (0.0, lam0 + 1e6, d0 + 1.0)
    path = CoarserPath.of(coarse, [stale] + [(level, *fields(coarse, level)) for level in (0.0, 2.0)],
                          MPI.COMM_WORLD)
    assert list(path.levels) == [0.0, 2.0]
    traction, d = path.at(0.0)
    assert np.allclose(d, 0.0) and np.allclose(traction, 0.0)


def test_the_search_starts_only_its_far_trials_from_the_coarser_path():
    """On the one-degree-of-freedom fake: every trial more than the width above ``lower`` starts from the path's start
    (the solver is given it), the closing trials from their converged state (a closing failure stays the Newton
    method's own evidence), and the bracket is the one the fake's limit gives."""
    from test_bracket import LIMIT, SETTINGS, OneDof, assert_bracket, search

    from bridgefem.solver.newton import PairPrediction

    start = PairPrediction(np.zeros((0, 2)), np.zeros((0, 2)))
    asked = []

    class Recording(OneDof):
        def solve_step(self, level, begin, predictor=None, give_up=False, iterations=None):
            asked.append((level, float(begin.x.array[0]), predictor))
            return super().solve_step(level, begin, predictor, give_up, iterations)

    s = search(Recording(), coarser=LIMIT, coarser_path=lambda trial, lower, state: start)
    assert_bracket(s)
    live = asked[1:]  # after the self-weight
    far = [(level, lower, p) for level, lower, p in live if level - lower > SETTINGS.tolerance * lower]
    assert far and all(p is start for _, _, p in far)
    closing = [p for level, lower, p in live if level - lower <= SETTINGS.tolerance * lower]
    assert closing and all(p is None for p in closing)
