"""Multi-ring barrels in the FE (#41): the mesh of rings laid one over the other, the node pairs of their curved
interfaces (a forest where three block copies meet), the ring interfaces' law (friction, cohesion, no tension, no
crushing), and the limit load against the rigid-block LP on the same blocks.

The FE/LP checks: frictionless ring interfaces are exact for rigid blocks (associated and non-associated flow
coincide), so there the FE equals the LP within the usual FE/LP agreement (0.5 %); with friction the FE is at or
below the associative LP; aligned rings bonded by a large cohesion are the monolithic ring."""

import numpy as np
import pytest
from conftest import assert_two_ranks_give, scene_dict, write_toml
from mpi4py import MPI

from bridgefem.analysis.checks import PairCheck, collapse_check
from bridgefem.analysis.runner import run_analysis
from bridgefem.analysis.static_bound import fe_blocks
from bridgefem.fe.mesh import _gmsh_bridge, build_block_mesh, ring_element_sizes
from bridgefem.fe.model import build_elastic_model
from bridgefem.fe.pairs import GROUND, build_pairs
from bridgefem.geometry.ring import add_abutments, build_ring, fill_outline
from bridgefem.laws.base import ContactState
from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.laws.crushing import CrushingJoints, scene_law_factory
from bridgefem.scene.reader import scene_from_dict
from bridgefem.solver.condensation import consistent_states, lcp_active_set

AGREEMENT = 5e-3  # the FE/LP agreement on the same blocks


def barrel(rings: int, bond: str, shape: str = "semicircular", rise: float = 4.5, abutments: bool = False):
    ring = build_ring(shape, 9.0, rise, 1.0, 8, [-2.5], ring_thicknesses=(1.0 / rings,) * rings, bond=bond)
    return add_abutments(ring, 1.0, 1.5) if abutments else ring


# ----------------------------------------------------------------------------------------------------- the mesh
@pytest.mark.parametrize("rings,bond,shape,rise,abutments,fill", [
    (2, "staggered", "semicircular", 4.5, False, False), (2, "aligned", "semicircular", 4.5, True, False),
    (3, "staggered", "pointed", 7.0, False, True), (3, "aligned", "segmental", 2.0, True, True)])
def test_every_block_is_meshed_and_every_joint_is_a_chain_of_edges(rings, bond, shape, rise, abutments, fill):
    """Each block has cells, each joint's edges lie on the joint (its chord, or its curve) and join its two ends;
    each ring's voussoir joints have elements_through_thickness segments; the fill lies on the outer ring."""
    ring = barrel(rings, bond, shape, rise, abutments)
    outline = fill_outline(ring, 0.5, 1.0, [-2.5]) if fill else None
    raw = _gmsh_bridge(ring, 2, outline, 0.3)
    assert set(np.unique(raw.blocks)) == set(range(ring.n_blocks + (1 if fill else 0)))
    for j in ring.joints:
        seg = raw.joints[j.id]
        ends, count = np.unique(seg, return_counts=True)
        tips = raw.x[ends[count == 1]]
        assert len(tips) == 2 and {tuple(np.round(t, 9)) for t in tips} == {tuple(np.round(j.intrados, 9)),
                                                                             tuple(np.round(j.extrados, 9))}
        if j.kind in ("voussoir", "springing"):
            assert len(seg) == 2
        midpoints = raw.x[seg].mean(axis=1)
        a, b = j.chords
        gap = np.min([np.abs(np.cross(b[k] - a[k], midpoints - a[k])) / np.linalg.norm(b[k] - a[k])
                      for k in range(len(a))], axis=0)
        assert gap.max() < 0.02 * ring.thickness  # on the joint, up to the spline through its polyline
    extrados = raw.x[np.unique(raw.extrados)]
    outer = np.vstack([v.extrados for v in ring.outer_voussoirs])
    assert np.abs(extrados[:, 1] - np.interp(extrados[:, 0], outer[:, 0], outer[:, 1])).max() < 1e-2


def test_a_single_ring_keeps_its_structured_mesh():
    """One ring: every voussoir a structured grid of 2 x per_thickness x n_along triangles (the mesh it always had);
    two rings: each ring has per_thickness elements through its own thickness."""
    one = build_ring("semicircular", 9.0, 4.5, 1.0, 8)
    raw = _gmsh_bridge(one, 2, None, 0.0)
    per_voussoir = np.bincount(raw.blocks)
    assert np.all(per_voussoir % 4 == 0) and len(set(per_voussoir)) == 1
    two = barrel(2, "aligned")
    assert ring_element_sizes(two, 4) == (0.125, 0.125)
    raw = _gmsh_bridge(two, 4, None, 0.0)
    assert all(len(raw.joints[j.id]) == 4 for j in two.joints if j.kind == "voussoir")


# ----------------------------------------------------------------------------------------------------- the pairs
@pytest.fixture(scope="module", params=[("staggered", False), ("aligned", True)])
def paired(request):
    bond, abutments = request.param
    ring = barrel(2, bond, abutments=abutments)
    scene = scene_from_dict(scene_dict(arch={"rings": 2, "ring_bond": bond, "voussoirs": 8}))
    bm = build_block_mesh(ring, 2, MPI.COMM_SELF)
    model = build_elastic_model(bm, ring, scene)
    return ring, build_pairs(model.V, bm, ring, 1e-9 * 9.0), model.V


def test_interface_pairs_take_the_curves_normal(paired):
    """On a semicircular barrel the ring interfaces are circles about the origin: each pair's normal is radial,
    pointing out (from the inner ring into the outer), to within the polyline's chords."""
    ring, pairs, V = paired
    on = pairs.kind == "ring"
    xy = V.tabulate_dof_coordinates()[:, :2]
    at = xy[pairs.left[on]]
    radial = at / np.linalg.norm(at, axis=1)[:, None]
    assert np.einsum("ij,ij->i", radial, pairs.normal[on]).min() > np.cos(np.radians(3))
    assert np.allclose(np.einsum("ij,ij->i", pairs.normal, pairs.tangent), 0.0)


def test_pairs_at_a_point_form_a_forest(paired):
    """No pairs close a cycle of block copies at any point (with hard constraints a closed cycle is a singular
    system); a dropped interface pair gave its length to the kept one at its point, so the interface pairs'
    lengths add up to the interfaces' lengths but for the halves of an element lost at their two ends."""
    ring, pairs, V = paired
    xy = V.tabulate_dof_coordinates()[:, :2]
    node = np.where(pairs.left != GROUND, pairs.left, pairs.right)
    keys = np.round(xy[node] / 1e-9).astype(np.int64)
    for key in np.unique(keys, axis=0):
        here = np.flatnonzero((keys == key).all(axis=1))
        parent = {}

        def root(n):
            while parent.get(n, n) != n:
                n = parent[n]
            return n

        for k in here:
            a, b = root(int(pairs.left[k])), root(int(pairs.right[k]))
            assert a != b, f"pairs {here} close a cycle at {xy[node[k]]}"
            parent[a] = b
    interfaces = [j for j in ring.joints if j.kind == "ring"]
    total = sum(j.length for j in interfaces)
    h = min(ring_element_sizes(ring, 2))
    assert total - 1.5 * h < pairs.length[pairs.kind == "ring"].sum() <= total + 1e-9


# ----------------------------------------------------------------------------------------------------- the law
def cohesive_law(mu=0.5, k=100.0):
    """Two pairs, the second cohesive (k N)."""
    return CoulombJoints(np.array([mu, mu]), np.array([1e6, 1e6]), 1e-9, cohesion=np.array([0.0, k]))


def test_cohesion_is_shear_strength_open_or_closed():
    """|lam_t| <= mu lam_n + k, closed or open (the rigid-block rows' convex set): an open cohesive pair holds its
    shear (sign 0) or slides with lam_t = s k; an open plain pair carries nothing; a released one is free."""
    law = cohesive_law()
    zero = np.zeros((2, 2))
    lam = np.array([[1000.0, 540.0], [1000.0, 540.0]])  # mu lam_n = 500: the plain pair slips, the cohesive one not
    state, _ = law.classify(law.bonded(2), lam, zero, np.zeros(2))
    assert list(state.state) == [law.SLIP, law.STICK]
    assert np.allclose(law.residual(np.array([[1000.0, 500.0], [1000.0, 600.0]]), zero, np.zeros(2)), 0.0)
    assert law.residual(np.array([[1000.0, 500.0], [1000.0, 601.0]]), zero, np.zeros(2))[1, 1] == pytest.approx(1.0)
    opened = np.array([[1e-3, 0.0], [1e-3, 0.0]])  # both open: the cohesive one may carry up to k = 100 N
    assert np.allclose(law.residual(np.array([[0.0, 0.0], [0.0, 50.0]]), opened, np.zeros(2)), 0.0)
    state, _ = law.classify(law.bonded(2), np.array([[0.0, 30.0], [0.0, 150.0]]), opened, np.zeros(2))
    assert list(state.state) == [law.OPEN, law.OPEN] and list(state.sign) == [0, 1]
    rows, (_, r_t) = law.rows(state), law.rhs(state, np.zeros(2), zero)
    assert list(rows.b_t) == [1.0, 1.0] and np.allclose(r_t, [0.0, 100.0])  # lam_t = 0 and lam_t = k
    held = state.copy()
    law.hold(held, np.ones(2, bool))
    assert list(law.rows(held).a_t) == [0.0, 1.0]  # the open cohesive pair holds its shear, the plain one is free
    law.release(held, np.ones(2, bool))
    assert not law.rows(held).a_t.any() and np.allclose(law.rhs(held, np.zeros(2), zero)[1], 0.0)
    slipping = ContactState(np.array([law.SLIP, law.SLIP], np.int8), np.array([1, -1], np.int8))
    assert np.allclose(law.rhs(slipping, np.zeros(2), zero)[1], [0.0, -100.0])
    assert np.allclose(law.sliding_forces(slipping, np.array([1000.0, 1000.0])), [500.0, -600.0])
    assert law.mode_rules(slipping).rough.all()
    assert (law.OPEN, 1) in law.candidates()


@pytest.mark.parametrize("gap,push,expected", [(1e-4, 5e-5, (0, 0)), (1e-4, 5e-4, (0, -1)), (-1e-4, 2e-3, (2, -1))])
def test_the_cohesive_lcp_and_the_enumeration_agree(gap, push, expected):
    """One pair with cohesion k = 100 N on d = d0 + C lam: the law's LCP (Lemke) and the enumeration of its states
    find the same state, open holding, open sliding at lam_t = k, or closed sliding at mu lam_n + k."""
    law = CoulombJoints(np.array([0.5]), np.array([1e6]), 1e-9, cohesion=np.array([100.0]))
    C = np.diag([1e-6, 1e-6])  # m/N: the pair's compliance
    d0 = np.array([[gap, push]])  # opening and slip with no force (m)
    by_lcp = lcp_active_set(law, d0, C)
    assert (int(by_lcp.state[0]), int(by_lcp.sign[0])) == expected
    found = consistent_states(law, d0, C, law.bonded(1), law.bonded(1))
    assert found is not None and (int(found[0].state[0]), int(found[0].sign[0])) == expected


def test_the_scene_law_puts_cohesion_and_crushing_where_they_belong(paired):
    """Ring interfaces: the ring cohesion x width x tributary length, no crushing; masonry joints: no cohesion, the
    crushing force."""
    _, pairs, _ = paired
    d = scene_dict(arch={"rings": 2}, joints={"ring_cohesion": 5e4}, masonry={"compressive_strength": 5e6})
    law = scene_law_factory(scene_from_dict(d))(pairs, 0.6, np.ones(len(pairs)), 0.0)
    assert isinstance(law, CrushingJoints)
    ring = pairs.kind == "ring"
    assert np.allclose(law.cohesion[ring], 5e4 * pairs.length[ring]) and np.all(law.cohesion[~ring] == 0)
    assert np.all(np.isinf(law.capacity[ring])) and np.allclose(law.capacity[~ring], 5e6 * pairs.length[~ring])


# ----------------------------------------------------------------------------------------------------- the limit
def analyse(rings, bond, thickness, ring_friction=None, cohesion=0.0, voussoirs=16):
    joints = {"friction": 0.6, "ring_cohesion": cohesion, **({} if ring_friction is None else
                                                             {"ring_friction": ring_friction})}
    d = scene_dict(arch={"thickness": thickness, "rings": rings, "ring_bond": bond, "voussoirs": voussoirs},
                   joints=joints, mesh={"elements_through_thickness": 2})
    return run_analysis(scene_from_dict(d), MPI.COMM_WORLD)


# The known failures of #41 item 5 below are marked xfail and not run (run=False): a non-strict xfail cannot fail,
# so running it checks nothing. Whoever works on the item runs them as ordinary tests with
# ./run test tests/test_ring_fe.py --runxfail


@pytest.mark.slow
@pytest.mark.parametrize("rings,bond,thickness", [
    (2, "staggered", 1.5), (2, "aligned", 1.5), (3, "aligned", 2.5),
    pytest.param(3, "staggered", 2.5, marks=pytest.mark.xfail(
        reason="the active-set search stops 1.3 % below the LP with an unproven mode (the LP under the FE's forces "
               "finds a reserve: a solver failure, not a weaker model); the frictionless middle ring of a staggered "
               "bond is the hard case of #41 item 5 (not run: --runxfail runs it)", strict=False, run=False))])
def test_frictionless_ring_interfaces_give_the_lp(rings, bond, thickness):
    """Frictionless ring interfaces: the FE's bracket within the FE/LP agreement of the LP on the same blocks."""
    an = analyse(rings, bond, thickness, ring_friction=0.0)
    total = an.load_total
    assert an.search.upper is not None, an.search.status
    assert an.search.lower * total == pytest.approx(an.lp.load, rel=AGREEMENT)
    assert an.search.upper * total == pytest.approx(an.lp.load, rel=AGREEMENT)


@pytest.mark.slow
@pytest.mark.parametrize("bond", [
    pytest.param("staggered", marks=pytest.mark.xfail(
        reason="the FE's path stops about 0.5 % below its own frozen pair LP, at the agreement threshold: the "
               "machine's rounding decides the verdict (confirmed [126.392, 126.394] kN, frozen 127.022 kN on one "
               "machine; unproven at 126.474 kN, frozen 127.12 kN on another; #41 item 5, docs/robustness.md, "
               "*Rings*; not run: --runxfail runs it)", strict=False, run=False)),
    "aligned"])
def test_rough_ring_interfaces_stay_below_the_associative_lp(bond):
    """Ring friction 0.6: the FE (non-associative) closes its bracket at or below the associative LP on the same
    blocks, confirmed (by the LP, or where it stops below it by the frozen LP on its own pairs: evidence 3); and the
    FE's last converged forces are admissible for that frozen LP, whose level is therefore at least the FE's (the
    lower-bound property the check rests on; it fails if a pair's force acted on the wrong block or point)."""
    an = analyse(2, bond, 1.5)
    assert an.search.upper is not None, an.search.status
    assert an.search.upper * an.load_total <= (1 + AGREEMENT) * an.lp.load
    assert an.verdict.evidence.startswith(("proof", "agreement")), an.verdict.evidence
    blocks = fe_blocks(an.scene, an.model, an.block_mesh, an.ring)
    contacts = PairCheck.of(an.scene, MPI.COMM_WORLD, an.lp, blocks, an.solver, an.pairs, an.ring)
    check = contacts.state(an.search.last)
    lower = an.search.lower
    assert check.frozen_level >= (1 - 1e-6) * lower
    assert check.frozen_level <= (1 + AGREEMENT) * an.search.upper  # the FE stopped at that collapse state
    # a closing trial that fails from this state is settled when the frozen reserve is within the bracket's width
    reserve = check.frozen_level / lower - 1
    for tolerance, settled in ((2 * reserve + 1e-9, True), (reserve / 2, False)):
        collapse = collapse_check(an.scene, MPI.COMM_WORLD, an.lp, blocks, an.solver, an.pairs, an.ring, tolerance,
                                  an.load_total, contacts)
        assert collapse.settles(lower, (1 + tolerance) * lower, an.search.last)[0] is settled


@pytest.mark.slow
def test_aligned_rings_bonded_by_cohesion_are_the_monolithic_ring():
    """Aligned rings whose interfaces have a cohesion far above any shear they carry: the one ring's limit load (the
    highest load the FE carries; the run's own LP check has no cohesion yet, so its verdict is not asked for)."""
    bonded = analyse(2, "aligned", 1.5, cohesion=1e7)
    one = analyse(1, "aligned", 1.5)
    assert bonded.search.lower == pytest.approx(one.search.lower, rel=AGREEMENT)
    assert bonded.search.lower == pytest.approx(one.lp.load, rel=AGREEMENT)


@pytest.mark.mpi
@pytest.mark.slow
def test_two_ranks_give_the_serial_bracket(tmp_path):
    """mpirun -n 2 on a two-ring barrel: every rank has the serial bracket."""
    d = scene_dict(arch={"thickness": 1.5, "rings": 2, "ring_bond": "staggered"}, joints={"ring_friction": 0.0},
                   mesh={"elements_through_thickness": 2})
    path = write_toml(tmp_path / "rings.toml", d)
    assert_two_ranks_give(path, run_analysis(scene_from_dict(d), MPI.COMM_WORLD))
