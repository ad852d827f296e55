"""results.json describes the structure (#41): its blocks, joints and loads alone rebuild the rigid-block model, whose
LP gives the collapse load results.json reports."""
import json
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import SMALL_RING, scene_dict

import bridgefem
from bridgefem.laws.coulomb import CoulombJoints
from bridgefem.laws.crushing import CrushingJoints, fe_stations
from bridgefem.limit.rigid_block import BlockModel, solve_blocks


def rebuilt_model(data: dict) -> BlockModel:
    """The rigid-block model of results.json's ``blocks``, ``joints`` and ``loads`` alone: a block's weight at its
    polygon's centroid (shoelace), each load's forces on their blocks, each joint as its chords (a ring interface:
    its curve's), with its friction, its cohesion (Pa) over the chord's length and the width, and crushing where it
    has a compressive strength (the LP check's rows: the polygon of the FE's pairs through a joint, from the model's
    elements through the thickness and degree)."""
    width = data["limit_load"]["width"]
    refs = []
    for b in data["blocks"]:
        p = np.array(b["polygon"])
        x, y, xn, yn = p[:, 0], p[:, 1], np.roll(p[:, 0], -1), np.roll(p[:, 1], -1)
        cross = x * yn - xn * y
        refs.append([((x + xn) * cross).sum() / (3 * cross.sum()), ((y + yn) * cross).sum() / (3 * cross.sum())])
    ref = np.array(refs)
    dead = np.column_stack([np.zeros(len(ref)), [-b["weight"] for b in data["blocks"]], np.zeros(len(ref))])
    live = np.zeros((len(ref), 3))
    for load in data["loads"]:
        for f in load["forces"]:
            k, (px, _) = f["block"], f["point"]
            live[k] += [0.0, f["force"], (px - ref[k, 0]) * f["force"]]
    pieces = []
    for j in data["joints"]:
        pts = np.array(j.get("curve") or j["points"])
        for a, b in zip(pts[:-1], pts[1:]):
            pieces.append((j, a, b, np.linalg.norm(b - a)))
    strengths = {j["compressive_strength"] for j in data["joints"]} - {None}
    mesh = SimpleNamespace(**{k: data["model"][k] for k in ("elements_through_thickness", "degree")})
    stations = fe_stations(SimpleNamespace(mesh=mesh), data["model"]["joint_nodes"])  # the FE's joints' stations
    law = (CrushingJoints.blocks(strengths.pop(), width, stations=stations)
           if strengths else CoulombJoints)
    interface = np.array([j["kind"] == "ring" for j, *_ in pieces])
    return BlockModel(ref=ref, dead=dead, live=live, joint_a=np.array([a for _, a, _, _ in pieces]),
                      joint_b=np.array([b for _, _, b, _ in pieces]),
                      joint_left=np.array([-1 if j["blocks"][0] is None else j["blocks"][0] for j, *_ in pieces]),
                      joint_right=np.array([-1 if j["blocks"][1] is None else j["blocks"][1] for j, *_ in pieces]),
                      friction=np.array([j["friction"] for j, *_ in pieces]), law=law,
                      interface=interface if interface.any() else None,
                      cohesion=np.array([j["cohesion"] * length * width for j, _, _, length in pieces]))


def rebuilt_load(data: dict) -> float:
    res = solve_blocks(rebuilt_model(data))
    return res.level * sum(ld["factor"] for ld in data["loads"])


@pytest.fixture(scope="module")
def small_ring():
    """The small ring of conftest on elastic abutments, analysed: its results.json."""
    scene = bridgefem.scene_from_dict({**SMALL_RING, "abutments": {"model": "elastic", "height": 1.0, "length": 1.5}})
    return json.loads(bridgefem.analyse(scene).to_json())


def test_results_rebuild_the_rigid_block_model(small_ring):
    """The LP of the model rebuilt from results.json (voussoirs, abutments and their bases) is results.json's LP."""
    data = small_ring
    assert {b["kind"] for b in data["blocks"]} == {"voussoir", "abutment"}
    assert data["lp"]["load"] == pytest.approx(rebuilt_load(data), rel=1e-9)


def test_results_describe_each_joint_and_load(small_ring):
    """Every joint names its kind, its blocks and its law; every load where it acts on the extrados."""
    data = small_ring
    kinds = [j["kind"] for j in data["joints"]]
    n = SMALL_RING["arch"]["voussoirs"]
    assert kinds == ["springing"] + ["voussoir"] * (n - 1) + ["springing", "base", "base"]
    assert [j["blocks"] for j in data["joints"]][:n + 1] == ([[n, 0]] + [[i, i + 1] for i in range(n - 1)]
                                                             + [[n - 1, n + 1]])
    assert [set(j["blocks"]) for j in data["joints"][n + 1:]] == [{None, n}, {None, n + 1}]
    assert all(j["friction"] == 0.6 and j["cohesion"] == 0.0 for j in data["joints"])
    (load,) = data["loads"]
    assert load["point"][0] == pytest.approx(-3.0 + 0.3 * 6.0)
    assert load["point"] == pytest.approx(np.mean([f["point"] for f in load["forces"]], axis=0).tolist())
    ring = [b for b in data["blocks"] if b["kind"] == "voussoir"]
    assert [b["ring"] for b in ring] == [0] * n and all(b["span"] == 0 for b in ring)


@pytest.mark.slow  # an end-to-end run of more than a second
def test_a_bare_ring_with_crushing_rebuilds_too():
    """With a compressive strength the joints' law crushes; the rebuilt model uses it."""
    scene = bridgefem.scene_from_dict(scene_dict(masonry={"compressive_strength": 2e6}, solver={"preset": "fast"}))
    data = json.loads(bridgefem.analyse(scene).to_json())
    assert {j["compressive_strength"] for j in data["joints"]} == {2e6}
    assert data["lp"]["load"] == pytest.approx(rebuilt_load(data), rel=1e-9)
