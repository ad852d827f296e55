"""The non-associative rigid-block check (bridgefem.limit.rigid_block, ``friction_model="non-associative"``: the Tresca
fixed point of Gilbert, Casapulla & Ahmed 2006) against closed forms and hand-derived collapse states, and its use
as evidence for an FE limit with sliding joints (bridgefem.analysis.evidence, rule 3).

A fixed point is a non-associative collapse state: joint forces in equilibrium obeying no tension and
|s| <= mu n, and a mechanism of hinges and slips without dilatancy whose load work equals the friction
dissipation mu n |slip| of those same forces. The tests check that property directly, and the level against
independent values: a block on an incline (W tan(theta + phi)), the keystone pushed through between two voussoirs
(tests/test_joint_loads.py's closed form), three blocks wedged by friction (30/19, hand-derived), whatever the
seed of the normal forces."""
import numpy as np
import pytest
from test_joint_loads import push_through, three_voussoirs
from test_rigid_block import THREE_BLOCK_JOINTS, three_blocks

from bridgefem.analysis.evidence import coulomb_limited
from bridgefem.limit.collapse import collapse_load, collapse_state_from
from bridgefem.limit.rigid_block import (
    BlockModel,
    frozen_capacity_collapse,
    generalised_loads,
    relative_motion,
    solve_blocks,
    statics,
)
from bridgefem.limit.ring_blocks import ring_model
from bridgefem.scene.reader import load_scene, scene_from_dict


def incline(theta, friction, weight=10.0, b=2.0, h=1.0):
    """A b x h block (weight ``weight``, N) on a plane rising at ``theta`` (rad) to the right, pushed horizontally
    (unit load, +x, up the slope) through its centroid. The base joint runs up the slope, so its normal
    (T_y, -T_x) points down into the ground: the block is its left side."""
    t, up = np.array([np.cos(theta), np.sin(theta)]), np.array([-np.sin(theta), np.cos(theta)])
    centre = (b / 2) * t + (h / 2) * up
    ref = centre[None, :]
    return BlockModel(ref=ref, dead=generalised_loads(ref, [0], ref, [[0.0, -weight]]),
                      live=generalised_loads(ref, [0], ref, [[1.0, 0.0]]),
                      joint_a=np.zeros((1, 2)), joint_b=(b * t)[None, :], joint_left=np.array([0]),
                      joint_right=np.array([-1]), friction=np.array([friction]))


def assert_collapse_state(res, model, rtol=1e-6):
    """The fixed-point property: |s| <= mu n, and load work = friction dissipation of the state's own forces,
    with no dilatancy (the mechanism's slips are tangential; its hinges open at the thrust's edge)."""
    n, s = res.joint_forces["n"], res.joint_forces["s"]
    scale = n.max()
    assert np.all(np.abs(s) <= model.friction * n + rtol * scale)
    _, slip = relative_motion(model, res.block_velocities)
    dissipation = float(np.sum(model.friction * n * np.abs(slip)))
    assert res.work_dead + res.level * res.work_live == pytest.approx(dissipation, rel=1e-5, abs=1e-6 * res.level)


@pytest.mark.parametrize("theta_deg, friction", [(0.0, 0.5), (20.0, 0.5), (10.0, 0.3)])
@pytest.mark.parametrize("seed", [None, 0.0, 50.0])
def test_block_on_incline(theta_deg, friction, seed):
    """Sliding up the slope: P cos(theta) = W sin(theta) + mu (W cos(theta) + P sin(theta)), P = W tan(theta + phi),
    from any starting normal force (None: the associative one)."""
    theta = np.radians(theta_deg)
    model = incline(theta, friction)
    res = solve_blocks(model, "non-associative", seed=None if seed is None else np.array([seed]))
    assert res.converged and res.sliding == [0] and res.hinges == []
    assert res.level == pytest.approx(10.0 * np.tan(theta + np.arctan(friction)), rel=1e-6)
    assert_collapse_state(res, model)


@pytest.mark.parametrize("fraction", [0.5, 0.9, 1.0])
def test_frozen_capacities_of_a_state_bound_its_load_and_meet_it_at_collapse(fraction):
    """The block on an incline (theta 20 deg, mu 0.5, W 10 N) in equilibrium under a push P' = fraction x
    W tan(theta + phi): n' = W cos(theta) + P' sin(theta), shear on the ground s' = P' cos(theta) - W sin(theta)
    (up the slope). With the shear capacity frozen at mu n' the block slides at (W sin(theta) + mu n') / cos(theta):
    at least P' (the state is admissible: lower-bound theorem), equal to it only where the state is at collapse,
    and only there is the sliding joint at its Coulomb limit against the slip (evidence rule 3)."""
    theta, mu, weight = np.radians(20.0), 0.5, 10.0
    p_collapse = weight * np.tan(theta + np.arctan(mu))
    p = fraction * p_collapse
    n, s = weight * np.cos(theta) + p * np.sin(theta), p * np.cos(theta) - weight * np.sin(theta)
    res = frozen_capacity_collapse(incline(theta, mu, weight), np.array([n]))
    assert res.level == pytest.approx((weight * np.sin(theta) + mu * n) / np.cos(theta), rel=1e-7)
    assert res.level >= p * (1 - 1e-9) and res.sliding == [0]
    assert (res.level == pytest.approx(p, rel=1e-7)) == (fraction == 1.0)
    limited = coulomb_limited(np.array([n]), np.array([s]), np.array([mu]), res.joint_slip, res.sliding)
    assert limited == ((0,) if fraction == 1.0 else ())


@pytest.mark.parametrize("thickness, friction", [(2.0, 0.33), (2.5, 0.35)])
@pytest.mark.parametrize("seed_scale", [1.0, 1.5, 3.0])
def test_keystone_push_through(thickness, friction, seed_scale):
    """The keystone pushed down between the two side voussoirs (closed form of tests/test_joint_loads.py; 1e-3:
    the voussoirs' polygonal edges) from seeds 1, 1.5 and 3 x the associative normal forces (with much less,
    the friction cannot carry the self-weight and the first LP has no solution)."""
    sc = three_voussoirs(thickness, friction)
    assoc = collapse_load(sc, load_at_joint="right")
    res = collapse_state_from(sc, seed_scale * assoc.joint_forces["n"], ["right"])
    assert res.converged and res.load_sides == ["right"]
    assert res.load == pytest.approx(push_through(thickness, friction), rel=1e-3)
    assert res.hinges == [] and len(res.sliding) == 3
    assert_collapse_state(res, ring_model(sc, load_at_joint="right"))


@pytest.mark.parametrize("seed", [None, [0, 0, 0, 0, 0], [3, 3, 0, 2, 2], [1, 3, 0.5, 0, 2]])
def test_three_blocks_wedged_by_friction(seed):
    """Three blocks (tests/test_rigid_block.py): the associative LP gives 25/14 (dilatancy at the sliding joints);
    without dilatancy the left block is wedged by friction at its limit on both contacts and the top and right
    blocks tip about (1, 0): 1.9 P = 2 x 1 + 1 x 0.5 + 0.5, P = 30/19, from every seed tried."""
    model = three_blocks(THREE_BLOCK_JOINTS)
    res = solve_blocks(model, "non-associative", seed=None if seed is None else np.array(seed, float))
    assert res.level_associative == pytest.approx(25 / 14, rel=1e-9)
    assert res.converged and res.level == pytest.approx(30 / 19, rel=1e-6)
    assert_collapse_state(res, model)


def test_no_fixed_point_is_reported():
    """An iteration stopped before its fixed point says so (converged False): the evidence rule refuses it."""
    res = solve_blocks(three_blocks(THREE_BLOCK_JOINTS), "non-associative", seed=np.zeros(5), max_iterations=2)
    assert not res.converged


def test_ring_without_sliding_keeps_the_associative_load():
    """A four-hinge collapse (reference arch, mu = 10) slides nowhere: the fixed point is the associative
    state, from the associative normal forces and from twice them."""
    sc = scene_from_dict({
        "arch": {"shape": "semicircular", "span": 9.0, "rise": 4.5, "thickness": 1.0, "voussoirs": 16},
        "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 10.0},
        "load": [{"kind": "point", "position": 0.22222}]})
    assoc = collapse_load(sc)
    for seed in (assoc.joint_forces["n"], 2 * assoc.joint_forces["n"]):
        res = collapse_state_from(sc, seed, assoc.load_sides)
        assert res.converged and res.sliding == []
        assert res.level == pytest.approx(assoc.level, rel=1e-6)


SCENE_124 = {  # campaign seed 1, scene 124
    "arch": {"shape": "pointed", "span": 14.929, "rise": 11.901, "thickness": 4.2291, "voussoirs": 49,
             "joint_at_loads": False},
    "masonry": {"young": 2.35e8, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 1.775},
    "load": [{"kind": "point", "position": 0.7744}]}


def test_ring_where_non_associative_friction_matters():
    """Scene 124's ring: from the associative seed the fixed point is a different mechanism (joint 27 sliding with
    hinges 0, 28, 44 instead of 0, 20, 43) 4.2 % below the associative load, and a collapse state."""
    sc = scene_from_dict(SCENE_124)
    res = collapse_load(sc, "non-associative")
    assert res.converged and res.sliding == [27] and res.hinges == [0, 28, 44]
    assert 0.95 * res.level_associative < res.level < 0.97 * res.level_associative
    assert collapse_load(sc).hinges == [0, 20, 43]
    assert_collapse_state(res, ring_model(sc))


@pytest.mark.slow
def test_fe_sliding_limit_below_the_associative_lp_is_a_collapse_state():
    """Campaign seed 1, scene 124 (pointed, 49 voussoirs, mu 1.775, point load at 0.774): the FE stops 4.2 %
    below the associative LP with joint 27 sliding. Its joint forces balance the blocks under its own assembled
    loads (equilibrium to 1e-6 of the weight), so the rigid blocks with its frozen friction capacities collapse
    at no less than its last converged load (lower-bound theorem) and within 0.5 % of it, sliding at joint 27
    where the FE's forces are at their Coulomb limit: the FE's state is a collapse state (evidence rule 3); the
    associative collapse state (hinges 0, 20, 43) is a different mechanism."""
    from bridgefem.analysis.runner import run_analysis
    from bridgefem.analysis.static_bound import fe_blocks
    from bridgefem.status import Status

    sc = scene_from_dict(SCENE_124)
    an = run_analysis(sc)
    s = an.search
    assert s.status == Status.LIMIT, s.status
    assert an.verdict.evidence.startswith("agreement: the non-associative rigid-block check")
    assert [j.id for j in an.joints if j.sliding] == [27]
    assert s.upper < 0.97 * an.lp.level and an.lp.hinges == [0, 20, 43]
    blocks = fe_blocks(sc, an.model, an.block_mesh)
    q = np.zeros((len(an.ring.joints), 3))
    q[[j.id for j in an.joints]] = [(j.normal_force, j.shear_force, j.normal_force * j.eccentricity)
                                    for j in an.joints]
    residual = statics(blocks, s.lower, q).equilibrium
    weight = -blocks.dead[:, 1].sum()
    assert np.abs(residual).max() < 1e-6 * weight
    frozen = frozen_capacity_collapse(blocks, q[:, 0])
    assert s.lower * (1 - 1e-9) <= frozen.level <= s.upper * (1 + 5e-3) and frozen.sliding == [27]
    assert coulomb_limited(q[:, 0], q[:, 1], blocks.friction, frozen.joint_slip, frozen.sliding) == (27,)


@pytest.mark.slow
def test_a_collapse_state_below_the_closing_failure_settles_the_bracket_its_retries_reach(monkeypatch):
    """Campaign seed 1, scene 220 (parabolic, 156 voussoirs, mu 0.979, 4 elements through the thickness): without
    the collapse-state check the closing trial fails without proof and every retry of it fails again (74 of its 198
    linear solves). With the check the search aims at the level where its states' rigid blocks with
    their frozen friction capacities collapse, and its closing failure starts from a state whose blocks collapse
    within the bracket's width of it (computed here independently): a bracket that overlaps the other, and the
    verdict confirms both by the same evidence. (No retries and fewer solves: benchmarks/solve_budgets.py.)"""
    from conftest import campaign_scene
    from mpi4py import MPI

    from bridgefem.analysis import runner as analysis
    from bridgefem.analysis.static_bound import fe_blocks
    from bridgefem.status import Status

    scene = scene_from_dict({**campaign_scene(220, 3.2045), "mesh": {"elements_through_thickness": 4}})
    checked = analysis._analyse(scene, MPI.COMM_WORLD, None, lambda s: None, lambda p: None)
    monkeypatch.setattr(analysis, "collapse_check", lambda *args: None)
    retried = analysis._analyse(scene, MPI.COMM_WORLD, None, lambda s: None, lambda p: None)
    for an in (checked, retried):
        assert an.search.status == Status.LIMIT and an.verdict.evidence.startswith("agreement: the non-associative")
    a, b = checked.search, retried.search
    assert a.lower <= b.upper and b.lower <= a.upper
    normal = np.zeros(len(checked.ring.joints))
    normal[[j.id for j in checked.joints]] = [j.normal_force for j in checked.joints]
    frozen = frozen_capacity_collapse(fe_blocks(scene, checked.model, checked.block_mesh), normal)
    assert a.lower * (1 - 1e-9) <= frozen.level <= a.lower * (1 + a.tolerance) and frozen.sliding


@pytest.mark.mpi
def test_the_collapse_state_check_is_collective(tmp_path):
    """Campaign seed 2, scene 12, whose searches read their states' collapse levels and settle their closing
    failure with them (rank 0's LPs, broadcast): under mpirun -n 2 the same bracket, the same linear solves and the
    same re-run as in serial."""
    import json

    from conftest import bridgefem, campaign_scene, write_toml

    scene = write_toml(tmp_path / "s12.toml", campaign_scene(12, 0.8584, seed=2))
    runs = []
    for ranks in (1, 2):
        proc = bridgefem("run", scene, "--out", tmp_path / f"r{ranks}", "--quiet", ranks=ranks)
        assert proc.returncode == 0, proc.stderr
        runs.append(json.loads((tmp_path / f"r{ranks}" / "results.json").read_text()))
    serial, parallel = runs
    assert parallel["mpi_ranks"] == 2 and serial["status"] == parallel["status"] == "limit load found"
    for end in ("lower", "upper"):
        assert parallel["limit_load"][end] == pytest.approx(serial["limit_load"][end], rel=1e-9)
    assert parallel["solver"]["solves"] == serial["solver"]["solves"]
    assert [r["solves"] for r in parallel["mesh_refinements"]] == [r["solves"] for r in serial["mesh_refinements"]]


@pytest.mark.slow  # an end-to-end run of more than a second
def test_lp_command_states_the_associative_load_when_no_fixed_point_stands(tmp_path, capsys):
    """A barrel of four staggered rings whose rings slide along each other: the associative LP finds it standing
    (the rings' dilatancy lets friction hold them), the non-associative iteration finds no state that carries the
    self-weight. ``bridgefem lp --friction-model non-associative`` says so and states the associative collapse load
    in kN: the associative LP's own, the point load on the crown joint shared by both voussoirs, within 1 %."""
    from bridgefem.io.cli import main
    scene = tmp_path / "barrel.toml"
    scene.write_text('[scene]\nname = "barrel"\n[arch]\nshape = "semicircular"\nspan = 18.0\nthickness = 0.4\n'
                     'width = 1.0\nvoussoirs = 6\nrings = 4\nring_bond = "staggered"\n[masonry]\nyoung = 9e8\npoisson = 0.2\n'
                     'density = 2000.0\n'
                     '[joints]\nfriction = 0.99\nring_friction = 0.336\nring_cohesion = 11000.0\n'
                     '[[load]]\nkind = "point"\nposition = 0.5\n')
    assert main(["lp", str(scene), "--friction-model", "non-associative"]) == 0
    out = capsys.readouterr().out
    assert "non-associative friction): unstable under self-weight" in out
    stated = float(out.split("associative friction: ")[-1].split(" kN")[0])
    associative = collapse_load(load_scene(scene))
    assert associative.status == "limit load found"
    assert stated == pytest.approx(associative.load / 1e3, rel=0.01)


def test_a_joint_at_its_coulomb_limit_with_a_pair_sticking_needs_the_non_associative_check():
    """A joint that does not count as sliding (a pair of it sticks) but whose shear is mu x its normal force carries
    its Coulomb capacity (bridgefem.analysis.checks.coulomb_loaded); one at 0.9 mu N does not, nor one in tension."""
    from types import SimpleNamespace

    from bridgefem.analysis.checks import coulomb_loaded
    from bridgefem.analysis.mechanism import JointState

    blocks = SimpleNamespace(friction=np.array([0.5, 0.5]))

    def joint(id, normal, shear):
        return JointState(id, normal, shear, eccentricity=0.0, open_fraction=0.0, opening=0.0, sliding=0)

    assert coulomb_loaded([joint(0, 100.0, 20.0), joint(1, 100.0, -50.0)], blocks)
    assert not coulomb_loaded([joint(0, 100.0, 20.0), joint(1, 100.0, -45.0)], blocks)
    assert not coulomb_loaded([joint(0, 0.0, 1.0)], blocks)


TWO_SEGMENTAL_SPANS = {
    "span": [{"shape": "segmental", "span": 4.829, "rise": 1.571, "thickness": 0.7313, "voussoirs": 64},
             {"shape": "segmental", "span": 18.845, "rise": 6.13, "thickness": 2.8539, "voussoirs": 64}],
    "pier": [{"width": 4.407, "height": 21.437, "blocks": 7}],
    "masonry": {"young": 15.7e9, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 0.383},
    "load": [{"kind": "patch", "x": 10.7398, "length": 1.334}], "mesh": {"elements_through_thickness": 4}}
"""Two segmental spans on a pier whose collapse slides at the short span's springings and by the load, 19 % below
the associative LP (spans campaign seed 20261263, scene 78, with masonry a hundred times stiffer: the same limit)."""


@pytest.mark.slow
def test_a_collapse_state_whose_sliding_joints_hold_at_their_coulomb_limit_is_evidence():
    """At the last converged state the joints that slide in the collapse carry mu x their normal force
    (bridgefem.analysis.checks.coulomb_loaded; whether a pair of each still sticks, so that no joint counts as
    sliding, depends on the rounding of the machine's BLAS), the non-associative check confirms the bracket: the
    frozen LP on the FE's joint forces, computed here, collapses within 0.5 % above it, sliding only where the FE's
    forces are at their Coulomb limit; the FE lies between the non-associative fixed point and the associative LP."""
    from mpi4py import MPI

    from bridgefem.analysis import runner as analysis
    from bridgefem.analysis.checks import coulomb_loaded
    from bridgefem.analysis.static_bound import fe_blocks
    from bridgefem.status import Status

    scene = scene_from_dict(TWO_SEGMENTAL_SPANS)
    an = analysis._analyse(scene, MPI.COMM_WORLD, None, lambda s: None, lambda p: None)
    s = an.search
    assert s.status == Status.LIMIT and an.verdict.evidence.startswith("agreement: the non-associative")
    blocks = fe_blocks(scene, an.model, an.block_mesh, an.ring)
    assert an.verdict.slides and coulomb_loaded(an.joints, blocks)
    normal, shear = np.zeros(blocks.n_joints), np.zeros(blocks.n_joints)
    normal[[j.id for j in an.joints]] = [j.normal_force for j in an.joints]
    shear[[j.id for j in an.joints]] = [j.shear_force for j in an.joints]
    frozen = frozen_capacity_collapse(blocks, normal)
    assert s.lower * (1 - 1e-9) <= frozen.level <= s.lower * 1.005 and frozen.sliding
    assert coulomb_limited(normal, shear, blocks.friction, frozen.joint_slip, frozen.sliding) == tuple(frozen.sliding)
    associative = collapse_load(scene)
    fixed = collapse_load(scene, friction_model="non-associative")
    assert fixed.level <= s.lower and s.upper <= associative.level  # levels: N per unit load factor
