"""Results of a run: results.json, XDMF fields for ParaView and PNG plots, written atomically.

Everything goes to a temporary folder beside the target, which replaces the target only when complete,
so an interrupted or failed run never leaves a half-written folder and never overwrites earlier results.
Loads are in N (for the scene's width), lengths in m.
"""
from __future__ import annotations

import json
import platform
import shutil
import tempfile
from importlib import metadata
from pathlib import Path

import numpy as np
from dolfinx import fem, io
from petsc4py import PETSc

from .analysis import Analysis, springing_reactions, transmitted_load_check
from .contact import OPEN, SLIP
from .model import node_blocks

JOINT_STATE_CODES = {"none": 0, "stick": 1, "slip": 2, "open": 3}


def versions() -> dict:
    """Versions of the software that produced a result."""
    import dolfinx
    import gmsh
    import scipy

    out = {"python": platform.python_version(), "dolfinx": dolfinx.__version__,
           "petsc": ".".join(map(str, PETSc.Sys.getVersion())), "gmsh": gmsh.__version__,
           "numpy": np.__version__, "scipy": scipy.__version__}
    try:
        out["bridgefem"] = metadata.version("bridgefem")
    except metadata.PackageNotFoundError:
        out["bridgefem"] = "source tree"
    return out


def summary(an: Analysis, extra: dict | None = None) -> dict:
    """The JSON-ready summary of an analysis (identical on every rank)."""
    s, total = an.search, an.load_total
    hinges = [j for j in an.joints if j.hinge]
    steps = [{"step": st.index, "load": st.level * total, "converged": st.converged, "reason": st.reason,
              "newton_iterations": st.iterations, "factorisations": st.factorisations,
              "residual": st.residual if np.isfinite(st.residual) else None,
              "deflection": st.deflection, "pairs": st.counts, "support_movement": st.movement,
              "fill_cohesion": st.cohesion, "seconds": st.seconds} for st in s.steps]
    return {
        "scene": an.scene.name,
        "status": s.status,
        "limit_load": {"lower": s.lower * total, "upper": None if s.upper is None else s.upper * total,
                       "unit": "N", "tolerance": s.tolerance, "width": an.scene.arch.width},
        "failure_reason": s.failure,
        "evidence": an.verdict.evidence if an.verdict else "",
        "mechanism": {"hinges": [j.id for j in hinges], "hinge_positions": {str(j.id): j.hinge for j in hinges},
                      "sliding": [j.id for j in an.joints if j.sliding]},
        "joints": [{"id": jt.id, "intrados": jt.intrados.tolist(), "extrados": jt.extrados.tolist(),
                    **({"normal_force": js.normal_force, "shear_force": js.shear_force,
                        "eccentricity": js.eccentricity, "open_fraction": js.open_fraction,
                        "opening": js.opening, "hinge": js.hinge, "sliding": js.sliding} if js else {})}
                   for jt, js in zip(an.ring.joints, an.joints or [None] * len(an.ring.joints))],
        "self_weight": an.model.dead_weight,
        "fill_weight": an.model.fill_weight,
        "springing_reactions": springing_reactions(an.joints, an.ring).tolist() if an.joints else [],
        "ring_under_transmitted_loads": ring_check_summary(an),
        "history": steps,
        "model": {"dofs": an.n_dofs, "displacement_dofs": int(an.model.K.getSize()[0]),
                  "joint_pairs": an.pairs.total, "cells": an.block_mesh.n_cells, "nodes": an.block_mesh.n_nodes,
                  "element_size": an.block_mesh.element_size, "degree": an.scene.mesh.degree,
                  "plane": an.scene.model.plane},
        "solver": {**an.solver.stats, "load_steps": len(s.steps),
                   "newton_iterations": sum(st.iterations for st in s.steps),
                   "petsc_options": an.solver.petsc_options},
        "timings": an.timings,
        "mpi_ranks": an.solver.comm.size,
        "versions": versions(),
        **(extra or {}),
    }


RING_CHECK_MODEL = ("the ring's rigid-block LP (associative friction) loaded by the forces the fill transmits across "
                    "the arch-fill interface: dead load = ring weight + interface forces after self-weight, live load = "
                    "their change up to the FE's last converged load, scaled with it; a lower-bound check: ratio >= 1, "
                    "close to 1 when the FE limit is a mechanism of the ring, above 1 when the fill restrains it")


def ring_check_summary(an: Analysis) -> dict | None:
    """The ``ring_under_transmitted_loads`` entry of results.json (None without a fill or a converged live load):
    ``fe_load`` the FE's last converged live load (N), ``load`` the live load at which the ring under the transmitted
    loads collapses (N; None if it does not), ``ratio`` = load / fe_load, the LP's status and mechanism. Collective."""
    check = transmitted_load_check(an)
    if check is None:
        return None
    lp, total = check.lp, an.load_total
    return {"model": RING_CHECK_MODEL, "fe_load": check.level * total,
            "load": None if check.load_factor is None else check.load_factor * total, "unit": "N",
            "ratio": check.ratio, "status": lp.status,
            "mechanism": {"hinges": sorted(lp.hinges),
                          "hinge_positions": {str(k): v for k, v in lp.hinge_positions.items()},
                          "sliding": sorted(lp.sliding)}}


LP_RATIO_RANGE = (0.98, 1.01)  # FE/LP outside this on a case without sliding is flagged
LP_FILL_LABEL = "fill as dead load only"


def lp_summary(lp) -> dict:
    """The JSON form of a rigid-block result: load (N), status, friction model, mechanism, seconds."""
    return {"load": lp.load, "unit": "N", "status": lp.status, "friction_model": lp.friction_model,
            "mechanism": {"hinges": sorted(lp.hinges),
                          "hinge_positions": {str(k): v for k, v in lp.hinge_positions.items()},
                          "sliding": sorted(lp.sliding)},
            "seconds": lp.time_s}


def lp_label(scene) -> str:
    """What the rigid-block LP models of a scene: the ring, the fill as dead load only, elastic abutments as rigid
    blocks; it ignores a support movement (small support movements do not change a rigid-block collapse load)."""
    label = LP_FILL_LABEL if scene.fill else "bare ring"
    if scene.abutments.elastic:
        label += ", abutments as rigid blocks"
    if scene.abutments.moves:
        label += ", support movement not modelled (no effect on the rigid-block collapse load)"
    return label


def lp_check(scene, data: dict) -> dict:
    """The rigid-block LP on the same joints (associative friction) and its ratio to the FE bracket midpoint.
    With a fill the LP carries it as dead load only, so the ratio measures the fill's strength and stiffness
    (the FE/LP range check applies to bare arches).

    Returns the ``lp``, ``fe_lp_ratio`` and ``warnings`` entries of results.json.
    """
    from .rigid_block import collapse_load

    lp = collapse_load(scene)
    out = {"lp": {**lp_summary(lp), "model": lp_label(scene)}, "fe_lp_ratio": None, "warnings": []}
    ring_joints = data["joints"][:scene.arch.voussoirs + 1]
    mid = np.array([0.5 * (np.array(j["intrados"]) + np.array(j["extrados"])) for j in ring_joints])
    shortest = float(np.linalg.norm(np.diff(mid, axis=0), axis=1).min())
    if shortest < data["model"]["element_size"]:
        out["warnings"].append(f"voussoirs as short as {shortest:.3g} m are shorter than one element "
                               f"({data['model']['element_size']:.3g} m): the FE can stop below the limit load; "
                               "raise [mesh] elements_through_thickness or use fewer voussoirs")
    lim = data["limit_load"]
    if lp.load and lim["upper"]:
        ratio = 0.5 * (lim["lower"] + lim["upper"]) / lp.load
        out["fe_lp_ratio"] = ratio
        if not data["mechanism"]["sliding"] and scene.fill is None and not LP_RATIO_RANGE[0] <= ratio <= LP_RATIO_RANGE[1]:
            out["warnings"].append(f"FE/LP limit-load ratio {ratio:.4f} is outside {list(LP_RATIO_RANGE)} on a "
                                   "case without FE sliding: check the mesh, the tolerance and the mechanism")
    return out


def write_results(an: Analysis, out: Path, extra: dict | None = None) -> dict:
    """Write results.json, fields.xdmf and the PNGs into ``out`` atomically (collective); returns the summary."""
    comm = an.solver.comm
    out = Path(out)
    tmp = Path(comm.bcast(tempfile.mkdtemp(prefix=f".{out.name}.", dir=_parent(out)) if comm.rank == 0 else None))
    try:
        data = summary(an, extra)
        data.update(lp_check(an.scene, data))
        data["warnings"] += list(an.verdict.warnings) if an.verdict else []
        if an.search.last is not None:
            _write_fields(an, tmp / "fields.xdmf")
        motion = _voussoir_motion(an) if an.search.last is not None else None
        if comm.rank == 0:
            (tmp / "results.json").write_text(json.dumps(data, indent=2))
            from .plots import plot_load_deflection, plot_mechanism

            plot_load_deflection(data, tmp / "load_deflection.png")
            plot_mechanism(an.ring, data, motion, tmp / "mechanism.png")
        comm.barrier()
    except BaseException:
        if comm.rank == 0:
            shutil.rmtree(tmp, ignore_errors=True)
        raise
    if comm.rank == 0:
        old = out.with_name(f".{out.name}.old")
        if out.exists():
            out.rename(old)
        tmp.rename(out)
        shutil.rmtree(old, ignore_errors=True)
    comm.barrier()
    return data


def _parent(out: Path) -> Path:
    out.parent.mkdir(parents=True, exist_ok=True)
    return out.parent


def _write_fields(an: Analysis, path: Path) -> None:
    """Displacement (m) and joint state (0 none, 1 stick, 2 slip, 3 open) at the last converged step, on P1."""
    V, it, solver, pairs = an.model.V, an.search.last, an.solver, an.pairs
    mesh = V.mesh
    u = fem.Function(V, name="displacement")
    n_u = solver.n_u
    u.x.array[:n_u] = it.x.array[:n_u]
    u.x.scatter_forward()
    Q, q_to_v = V.sub(0).collapse()
    state = fem.Function(Q, name="joint_state")
    code = np.where(it.active.state == OPEN, JOINT_STATE_CODES["open"],
                    np.where(it.active.state == SLIP, JOINT_STATE_CODES["slip"], JOINT_STATE_CODES["stick"]))
    table = np.vstack(mesh.comm.allgather(np.column_stack([np.concatenate([pairs.left, pairs.right]),
                                                           np.concatenate([code, code])])))
    table = table[table[:, 0] >= 0]
    order = np.argsort(table[:, 0])
    keys, vals = table[order, 0], table[order, 1]
    imap = V.dofmap.index_map
    nodes_global = imap.local_to_global(np.asarray(q_to_v, dtype=np.int32) // 2)
    pos = np.clip(np.searchsorted(keys, nodes_global), 0, max(len(keys) - 1, 0))
    hit = (keys[pos] == nodes_global) if len(keys) else np.zeros(len(nodes_global), bool)
    state.x.array[:] = np.where(hit, vals[pos] if len(keys) else 0, 0)
    if an.scene.mesh.degree != 1:
        V1 = fem.VectorFunctionSpace(mesh, ("Lagrange", 1))
        Q1 = fem.FunctionSpace(mesh, ("Lagrange", 1))
        u1, s1 = fem.Function(V1, name="displacement"), fem.Function(Q1, name="joint_state")
        u1.interpolate(u)
        s1.interpolate(state)
        u, state = u1, s1
    with io.XDMFFile(mesh.comm, str(path), "w") as xdmf:
        xdmf.write_mesh(mesh)
        xdmf.write_function(u)
        xdmf.write_function(state)


def _voussoir_motion(an: Analysis) -> np.ndarray:
    """Least-squares rigid motion (ux, uy, rotation) of each voussoir at the last converged step (collective)."""
    V, bm = an.model.V, an.block_mesh
    n_owned = V.dofmap.index_map.size_local
    n_blocks = an.ring.n_blocks + (an.block_mesh.fill_block is not None)  # the same on every rank
    blk = node_blocks(V, bm)[:n_owned]
    x = V.tabulate_dof_coordinates()[:n_owned, :2]
    u = an.search.last.x.array[:2 * n_owned].reshape(-1, 2)
    comm = V.mesh.comm

    def total(w):
        return comm.allreduce(np.bincount(blk, weights=w, minlength=n_blocks))

    count = total(np.ones(len(blk)))
    xc = np.column_stack([total(x[:, 0]), total(x[:, 1])]) / count[:, None]
    r = x - xc[blk]
    theta = total(r[:, 0] * u[:, 1] - r[:, 1] * u[:, 0]) / total((r ** 2).sum(axis=1))
    mean_u = np.column_stack([total(u[:, 0]), total(u[:, 1])]) / count[:, None]
    return np.column_stack([mean_u - np.column_stack([-theta * xc[:, 1], theta * xc[:, 0]]), theta])
