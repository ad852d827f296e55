"""The rigid-block LP of a scene as it is reported: its result, a failed LP reported like any result, and its JSON
form (the ``lp`` entry of results.json, ``bridgefem lp --json``). Loads in N for the scene's width.

Nothing here imports the FE: ``bridgefem lp`` and :func:`bridgefem.lp` stay as light as the LP itself.
"""
from __future__ import annotations

from ..limit.collapse import collapse_load
from ..limit.rigid_block import LPFailure, LPResult
from ..scene.model import Scene
from ..status import Status


def rigid_block_result(scene: Scene, friction_model: str = "associative") -> LPResult:
    """The rigid-block LP of the scene (:func:`bridgefem.limit.collapse.collapse_load`); an LP that fails is a
    result with the status "solver failure: <reason>", no load and no mechanism."""
    try:
        return collapse_load(scene, friction_model=friction_model)
    except LPFailure as err:
        return LPResult(None, None, Status.failure(str(err)), friction_model)


def mechanism_summary(lp: LPResult) -> dict:
    """The JSON form of a rigid-block mechanism by the structure's joint ids (``LPResult.by_joint``): hinge joints,
    where each hinge sits, sliding joints, separated ring interfaces."""
    mech = lp.by_joint
    return {"hinges": mech.hinges, "hinge_positions": {str(k): v for k, v in sorted(mech.hinge_positions.items())},
            "sliding": mech.sliding, "separated": mech.separated}


def lp_summary(lp: LPResult) -> dict:
    """The JSON form of a rigid-block result: load (N), status, friction model, mechanism, seconds."""
    return {"load": lp.load, "unit": "N", "status": lp.status, "friction_model": lp.friction_model,
            "mechanism": mechanism_summary(lp), "seconds": lp.time_s}


def lp_label(scene: Scene) -> str:
    """What the rigid-block LP models of a scene: the ring (or the spans and the piers' courses of a bridge of
    several spans), the fill as dead load only, elastic abutments as rigid blocks, several rings with their
    interfaces as chords; it ignores a support movement (small support movements do
    not change a rigid-block collapse load)."""
    label = "fill as dead load only" if scene.fill else "bare ring" if not scene.spans else "bare bridge"
    if scene.spans:
        label += f", {len(scene.spans)} spans on piers of rigid courses"
    rings = max(len(a.ring_layers) for a in scene.arches)
    if rings > 1:
        label += f", up to {rings} rings (each ring interface as the chords of its curve)" if scene.spans else \
            f", {rings} rings (each ring interface as the chords of its curve)"
    if scene.abutments.elastic:
        label += ", abutments as rigid blocks"
    if scene.abutments.moves:
        label += ", support movement not modelled (no effect on the rigid-block collapse load)"
    return label


def lp_entry(lp: LPResult, scene: Scene) -> dict:
    """The ``lp`` entry of results.json: :func:`lp_summary` and what the LP models of the scene (``model``)."""
    return {**lp_summary(lp), "model": lp_label(scene)}
