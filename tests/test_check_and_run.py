"""``bridgefem check`` and ``bridgefem run`` agree: a scene check calls valid is never refused by run before its
analysis, and a refusal names what is wrong. Where joints go under loads (``joint_at_loads``), and the notice of a
point load moved onto a joint. Run's side of each comparison is its own code path up to the mesh, the analysis's
first phase, stopped there (:func:`run_until_the_mesh`)."""
from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from conftest import bridgefem, campaign_module, scene_dict, write_toml

from bridgefem.analysis import build as analysis
from bridgefem.geometry.ring import (
    AT_JOINT_TOL,
    _centreline_length,
    _place_joints_at_loads,
    _samples,
    build_ring,
)
from bridgefem.geometry.shapes import make_shape
from bridgefem.io import cli
from bridgefem.scene.reader import scene_from_dict
from bridgefem.structure.ring import scene_ring, snapped_loads

SEED = 20261129  # the campaign seed whose single-patch scenes check called valid and run refused


class ReachedTheMesh(Exception):
    """Run got past every check it makes before its analysis."""


def command(capsys, *argv) -> tuple[int | str, str, str]:
    """``bridgefem *argv`` in this process: exit code, stdout, stderr."""
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def run_until_the_mesh(capsys, monkeypatch, scene, out) -> tuple[int | str, str, str]:
    """``bridgefem run`` on ``scene`` up to the meshing of its analysis: "accepted" when it gets there, else its exit
    code (and its output)."""
    def stop(*args, **kwargs):
        raise ReachedTheMesh

    monkeypatch.setattr(analysis, "build_block_mesh", stop)
    try:
        return command(capsys, "run", scene, "--out", out, "--quiet")
    except ReachedTheMesh:
        out, err = capsys.readouterr()
        return "accepted", out, err


def check_and_run(capsys, monkeypatch, tmp_path, d: dict, name: str = "scene") -> tuple[tuple, tuple]:
    """The scene ``d`` written to a file, then ``check`` and ``run`` (up to the mesh) on it."""
    path = tmp_path / f"{name}.toml"
    write_toml(path, d)
    check = command(capsys, "check", path)
    return ("accepted" if check[0] == 0 else check[0], *check[1:]), \
        run_until_the_mesh(capsys, monkeypatch, path, tmp_path / f"{name}-out")


@pytest.mark.slow  # 200 scenes checked and meshed (about 20 s)
def test_campaign_draw_check_and_run_agree(capsys, monkeypatch, tmp_path):
    """The random campaign's scenes (150 drawn, 50 more with an option each: a second load, elastic abutments...)
    at thicknesses across the campaign's range (without the LP that puts its lower end at the least thickness that
    stands: the joints need only the geometry): check and run accept or refuse each alike, with the same line."""
    campaign = campaign_module()
    choices = [campaign.draw(SEED, i) for i in range(150)]
    choices += [{**campaign.draw(SEED, i), "option": campaign.draw_option(SEED, i)} for i in range(150, 200)]
    verdicts = []
    for k, choice in enumerate(choices):
        check, run = check_and_run(capsys, monkeypatch, tmp_path,
                                   campaign.scene_dict(choice, campaign.thickness_above(choice, None)), f"s{k}")
        assert check[0] == run[0], (k, check, run)
        assert check[2] == run[2]  # the same refusal, one line
        verdicts.append(check[0])
    assert verdicts.count("accepted") >= 0.95 * len(choices)
    single_patches = [c for c, v in zip(choices, verdicts) if c["patch"] and c["joint_at_loads"] and not c.get("option")
                      and v == "accepted"]
    assert len(single_patches) > 20


def test_twenty_point_loads_on_sixteen_voussoirs(capsys, monkeypatch, tmp_path):
    """20 point loads need 20 joints under them and 16 voussoirs have 15 between the springings: check refuses
    as run does, naming the key, the count and what is allowed; the allowed scenes pass both."""
    loads = [{"kind": "point", "position": (i + 0.5) / 20} for i in range(20)]
    check, run = check_and_run(capsys, monkeypatch, tmp_path, scene_dict(load=loads), "twenty")
    assert check[0] == run[0] == 2
    assert check[2] == run[2]
    assert check[2].startswith("bridgefem: error: [arch] voussoirs = 16: ") and check[2].count("\n") == 1
    assert "20 positions" in check[2] and "15 joints" in check[2] and "at least 21 voussoirs" in check[2]
    assert "joint_at_loads = false" in check[2]
    for allowed in ({"voussoirs": 21}, {"joint_at_loads": False}):
        check, run = check_and_run(capsys, monkeypatch, tmp_path, scene_dict(arch=allowed, load=loads), "allowed")
        assert check[0] == run[0] == "accepted", (allowed, check, run)
    ring = scene_ring(scene_from_dict(scene_dict(arch={"voussoirs": 21}, load=loads)))
    corners = np.array([j.extrados[0] for j in ring.joints[1:-1]])
    for ld in loads:  # a joint under every load
        assert np.abs(corners - (ld["position"] - 0.5) * 9.0).min() < 1e-6


# campaign seed 20261129, scene 114: a parabolic ring of 5 voussoirs under one patch near its right springing
SCENE_114 = {"arch": {"shape": "parabolic", "span": 25.251, "rise": 7.801, "thickness": 1.7826, "width": 1.0,
                      "voussoirs": 5, "joint_at_loads": True},
             "masonry": {"young": 1e10, "poisson": 0.2, "density": 2000.0}, "joints": {"friction": 0.6},
             "load": [{"kind": "patch", "position": 0.8443, "length": 1.741}]}


def test_single_patch_whose_edges_are_nearest_one_joint(capsys, monkeypatch, tmp_path):
    """Both edges of the patch are nearest joint 4. Taken one at a time, the left edge took joint 4 and the right
    edge the nearest joint still free, joint 3, left of it: the joints crossed, a voussoir got a negative length and
    run refused the scene as "loads too close together" after check had called it valid. Kept in order (the least
    movement), joints 3 and 4 go under the two edges, the others stay where they were, and both commands accept
    the scene."""
    check, run = check_and_run(capsys, monkeypatch, tmp_path, SCENE_114, "scene114")
    assert check[0] == run[0] == "accepted", (check, run)
    sc = scene_from_dict(SCENE_114)
    a = sc.arch
    even = build_ring(a.shape, a.span, a.rise, a.thickness, a.voussoirs, joint_at_loads=False)
    corners = np.array([j.extrados[0] for j in even.joints])
    edges = sc.load_edges_x()
    assert [int(np.argmin(np.abs(corners - x))) for x in edges] == [4, 4]  # the case: one nearest joint
    ring = scene_ring(sc)
    moved = np.array([j.extrados[0] for j in ring.joints])
    assert np.all(np.diff(ring.params) > 0)
    assert moved[3:5] == pytest.approx(edges, abs=1e-6)
    assert ring.params[[0, 1, 2, 5]] == pytest.approx(even.params[[0, 1, 2, 5]], abs=0)


def greedy(params, s_of_p, load_params):
    """Each load, left to right, on the nearest joint not yet taken (the joints may cross)."""
    params, taken = params.copy(), set()
    s_joints = s_of_p(params)
    for pl in sorted(set(load_params)):
        order = np.argsort(np.abs(s_joints - s_of_p(np.array([pl]))[0]))
        j = next(j for j in order if 0 < j < len(params) - 1 and j not in taken)
        params[j] = pl
        taken.add(j)
    return params


def test_joints_at_loads_stay_in_order_with_the_least_movement_where_loads_compete():
    """Random loads on random rings: the joints stay in order with one under each load. Wherever each load's nearest
    free joint keeps the order, the same joints move to the same places; where it does not (two loads nearest one
    joint, the second's next joint beyond the first's), the layout moves the joints least in total of every
    order-keeping one (all tried)."""
    rng = np.random.default_rng(SEED)
    same = competed = 0
    for _ in range(400):
        shape = ("semicircular", "segmental", "pointed", "elliptical", "parabolic")[rng.integers(5)]
        rise = {"semicircular": 5.0, "segmental": 2.5, "pointed": 7.0}.get(shape, 3.0)
        n = int(rng.integers(3, 16))
        curve = make_shape(shape, 10.0, rise)
        p = _samples(curve)
        s = _centreline_length(curve, 0.5, p)
        params = np.interp(np.linspace(0.0, s[-1], n + 1), s, p)
        params[0], params[-1] = 0.0, 1.0
        loads = sorted(rng.uniform(0.02, 0.98, rng.integers(1, min(n, 5))))

        def s_of_p(q):
            return np.interp(q, p, s)

        placed, moved = _place_joints_at_loads(params, s_of_p, loads)
        assert np.all(np.diff(placed) > 0)
        assert sorted(moved.values()) == loads and all(placed[j] == q for j, q in moved.items())
        before = greedy(params, s_of_p, loads)
        if np.all(np.diff(before) > 0):
            assert np.array_equal(placed, before)
            same += 1
            continue
        competed += 1
        s_joints, s_loads = s_of_p(params), s_of_p(np.array(loads))
        least = min(np.abs(s_joints[list(js)] - s_loads).sum()
                    for js in itertools.combinations(range(1, n), len(loads)))
        assert np.abs(s_of_p(placed) - s_joints).sum() == pytest.approx(least, rel=1e-12)
    assert same > 100 and competed > 10  # both kinds of case were drawn


def test_joints_too_close_along_the_ring_name_both_loads(capsys, monkeypatch, tmp_path):
    """Two point loads at the crown 1.2 mm apart: more than 1e-4 x span (0.9 mm) in x, but their joints would be
    1.1 mm apart along the centreline, less than 1e-4 x its length (1.57 mm): the voussoir between them would
    vanish. Both commands refuse it alike, naming both loads and what is allowed."""
    loads = [{"kind": "point", "position": 0.5}, {"kind": "point", "position": 0.5 + 0.0012 / 9.0}]
    check, run = check_and_run(capsys, monkeypatch, tmp_path, scene_dict(load=loads), "crown")
    assert check[0] == run[0] == 2 and check[2] == run[2]
    assert check[2].startswith("bridgefem: error: [[load]] #1 (point at x = 0 m) and [[load]] #2 (point at x = ")
    assert "would be 0.00109 m apart along the ring's centreline" in check[2]
    assert "put the loads further apart or at one position, or set [arch] joint_at_loads = false" in check[2]


# the reference arch (16 voussoirs, t = 1 m on a 5 m radius) with joint_at_loads = false: joint 4's extrados corner
JOINT_4 = build_ring("semicircular", 9.0, 4.5, 1.0, 16, joint_at_loads=False).joints[4].extrados[0]


def near_joint_4(offset: float, joint_at_loads: bool = False) -> dict:
    """The reference arch with a point load ``offset`` m right of joint 4's extrados corner."""
    return scene_dict(arch={"joint_at_loads": joint_at_loads},
                      load=[{"kind": "point", "position": (JOINT_4 + offset + 4.5) / 9.0}])


def test_load_moved_onto_a_joint_is_reported_by_check(capsys, tmp_path):
    """A point load 0.59 mm from a joint (within 1e-4 x span = 0.9 mm) acts at the joint's corner: check says so in
    one comment line naming the load, its position, the joint and the distance (m); results.json's ``loads``
    entry has the joint and the distance. 1 mm away, with the joint moved under the load, or over a fill (the load
    on the road), nothing is moved."""
    from bridgefem.io.results import load_entries

    write_toml(tmp_path / "near.toml", near_joint_4(0.00059))
    code, out, _ = command(capsys, "check", tmp_path / "near.toml")
    notes = [line for line in out.splitlines() if line.startswith("# note: ")]
    assert code == 0 and len(notes) == 1
    x = JOINT_4 + 0.00059
    assert notes[0].startswith(f"# note: [[load]] #1 (point at x = {x:.9g} m) is 0.00059 m from joint 4's extrados "
                               f"corner (x = {JOINT_4:.9g} m), within 0.0001 x span = 0.0009 m: it is moved onto the "
                               "joint, on the side where it is least favourable")
    sc = scene_from_dict(near_joint_4(0.00059))
    (entry,) = load_entries(sc, scene_ring(sc), ["right"])
    assert entry["snapped_to_joint"] == 4 and entry["moved_by"] == pytest.approx(0.00059, rel=1e-9)
    assert entry["side"] == "right" and entry["x"] == pytest.approx(x, rel=1e-12)
    for far in (near_joint_4(0.001), near_joint_4(0.00059, joint_at_loads=True)):
        write_toml(tmp_path / "far.toml", far)
        code, out, _ = command(capsys, "check", tmp_path / "far.toml")
        assert code == 0 and "# note:" not in out
        sc = scene_from_dict(far)
        assert snapped_loads(sc, scene_ring(sc)) == []
        (entry,) = load_entries(sc, scene_ring(sc), [None])
        assert entry["snapped_to_joint"] is None and entry["moved_by"] == 0.0
    assert 0.00059 < AT_JOINT_TOL * 9.0 < 0.001
    filled = scene_from_dict({**near_joint_4(0.00059), "fill": {"unit_weight": 18e3, "young": 50e6, "depth": 0.5,
                                                                "extension": 2.0}})
    (entry,) = load_entries(filled, scene_ring(filled), ["right"])  # over a fill the load acts on the road
    assert entry["snapped_to_joint"] is None and entry["side"] is None


@pytest.mark.slow
def test_run_reports_a_load_moved_onto_a_joint(tmp_path):
    """End to end: run prints the notice (with --quiet too) and results.json records the joint, the distance and
    the side that carries the load; the FE and the LP load the same side."""
    write_toml(tmp_path / "near.toml", near_joint_4(0.00059))
    proc = bridgefem("run", tmp_path / "near.toml", "--out", tmp_path / "out", "--quiet")
    assert proc.returncode == 0, proc.stderr
    notices = [line for line in proc.stdout.splitlines() if "from joint 4's extrados corner" in line]
    assert len(notices) == 1 and notices[0].startswith("bridgefem: [[load]] #1 (point at x = ")
    data = json.loads((tmp_path / "out" / "results.json").read_text())
    (load,) = data["loads"]
    assert load["snapped_to_joint"] == 4 and load["moved_by"] == pytest.approx(0.00059, rel=1e-9)
    assert load["side"] in ("left", "right", "split")
