"""Results of a run written to files: results.json, XDMF fields for ParaView and PNG plots, written atomically.
Everything here formats what :mod:`bridgefem.analysis.runner` computed.

Everything goes to a temporary folder beside the target, which replaces the target only when complete
(:func:`bridgefem.io.output.results_folder`), so an interrupted run never leaves a half-written folder.
Loads are in N (for the scene's width), lengths in m.
"""
from __future__ import annotations

import json
import platform
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..analysis.mechanism import springing_reactions
from ..analysis.result import Analysis
from ..analysis.runner import quiet_compiler
from ..analysis.thrust import line_of_thrust, thrust_summary
from ..geometry.ring import PierBlock, Voussoir, fill_outline
from ..laws.base import JointLaw
from ..limit.ring_blocks import block_weights, load_forces
from ..structure.ring import snapped_loads
from .lp_report import lp_entry, mechanism_summary
from .output import results_folder
from .targets import version

NO_JOINT = 0  # the joint_state of a node on no joint pair (fields.xdmf); a pair's is its law's output code
FILES = ("results.json", "fields.xdmf", "fields.h5", "load_deflection.png", "mechanism.png", "report.html")
"""The files :func:`write_results` writes: the command line has their paths' lengths checked before the analysis
(:func:`bridgefem.io.output.check_names`)."""


def versions() -> dict:
    """Versions of the software that produced a result."""
    import dolfinx
    import gmsh
    import scipy
    from petsc4py import PETSc

    out = {"python": platform.python_version(), "dolfinx": dolfinx.__version__,
           "petsc": ".".join(map(str, PETSc.Sys.getVersion())), "gmsh": gmsh.__version__,
           "numpy": np.__version__, "scipy": scipy.__version__, "bridgefem": version()}
    return out


UNITS = {
    "force": "N (forces, loads, weights, reactions: for the scene's width)",
    "length": "m (coordinates, deflections, openings, eccentricities, element size, width, joints' "
              "compressed_depth and stress_block_depth)",
    "stress": "Pa (fill cohesion)",
    "time": "s (timings, seconds)",
    "dimensionless": "tolerance, ratios, open_fraction, crushed_fraction, friction, support_movement (fraction of the movement), "
                     "residual (out-of-balance force over the largest applied nodal force, inf-norms)",
}
CONVENTIONS = {
    "coordinates": "x to the right, y up; origin at the midpoint of the springing line on the intrados",
    "joints": "one ring of N voussoirs: numbered from the left springing (0) to the right springing (joint N); "
              "voussoir i lies between joints i and i+1; several rings: each ring's joints and voussoirs in turn from "
              "the intrados out, then the ring interfaces, then the abutments' bases; every joint names its kind, its "
              "blocks (left, right; null: the ground) and its points (blocks and joints: the structure)",
    "blocks": "voussoirs then elastic abutments, each a counter-clockwise polygon with its weight (N, unit weight x "
              "area x width) acting at its centroid",
    "ring_interface": "a curved joint between an inner-ring voussoir (left) and an outer-ring one (right), from its "
                      "end nearer the right springing to the other; its curve the polyline of its chords; it never "
                      "hinges: it separates (opens) or slides",
    "normal_force": "compression positive",
    "shear_force": "along the joint's tangent (intrados -> extrados end turned -90 degrees)",
    "eccentricity": "of the thrust from the joint's centre, positive towards the extrados (the base's outer edge)",
    "deflection": "downward displacement under the live load (mean over the loaded nodes), positive down",
    "mesh_refinements": "the other runs of an automatic mesh refinement, coarsest first: their elements through "
                        "the thickness, status, seconds and linear solves (the runs a finer mesh replaced; a finer run that failed "
                        "after a confirmed one, which the results then are; otherwise the results are the last "
                        "run's, model)",
    "springing_reactions": "force of the ground on the structure at each joint on the ground: horizontal positive "
                           "to the right, vertical positive up",
    "load": "live load: the sum of the [[load]] tables' forces, each factor x load level",
}


def state_vocabulary(law: JointLaw) -> tuple[dict, dict]:
    """The entries of results.json's ``units`` and ``conventions`` that name the joint law's states: the pair counts
    of each step and the codes of the field ``joint_state``."""
    codes = sorted((code, name) for name, code in law.OUTPUT_CODES.items())
    return ({"counts": f"pairs: joint node pairs {' / '.join(law.STATES)} at the end of the step; "
                       "elements_through_thickness (model, mesh_refinements)"},
            {"joint_state (fields.xdmf)": f"{NO_JOINT} no joint, {', '.join(f'{c} {n}' for c, n in codes)}; time "
                                          "value = live load (N)"})


def summary(an: Analysis) -> dict:
    """The JSON-ready summary of an analysis, with its LP check and warnings (identical on every rank; local: the
    analysis holds its checks as plain data)."""
    s, total = an.search, an.load_total
    hinges = [j for j in an.joints if j.hinge]
    units, conventions = state_vocabulary(an.solver.law)
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
        "units": {**UNITS, **units},
        "conventions": {**CONVENTIONS, **conventions},
        "mechanism": {"hinges": [j.id for j in hinges], "hinge_positions": {str(j.id): j.hinge for j in hinges},
                      "sliding": [j.id for j in an.joints if j.sliding],
                      "separated": [j.id for j in an.joints if j.separated],
                      "crushed": [j.id for j in an.joints if j.crushed_fraction > 0]},
        "blocks": block_entries(an.scene, an.ring),
        "joints": joint_entries(an.scene, an.ring, an.joints),
        "line_of_thrust": thrust_summary(line_of_thrust(an.joints, an.ring)),
        "self_weight": an.model.dead_weight,
        "fill_weight": an.model.fill_weight,
        "springing_reactions": _reactions(an),
        "ring_under_transmitted_loads": ring_check_summary(an),
        **lp_entries(an),
        "history": steps,
        "model": {"dofs": an.n_dofs, "displacement_dofs": int(an.model.K.getSize()[0]),
                  "joint_pairs": an.pairs.total, "cells": an.block_mesh.n_cells, "nodes": an.block_mesh.n_nodes,
                  "element_size": an.block_mesh.element_size, "degree": an.scene.mesh.degree,
                  "elements_through_thickness": an.scene.mesh.elements_through_thickness,
                  "joint_nodes": (list(an.block_mesh.joint_nodes) if an.block_mesh.joint_nodes is not None
                                  else None),
                  "plane": an.scene.model.plane},
        "mesh_refinements": [asdict(r) for r in an.refinements],
        "solver": {**an.solver.stats, "load_steps": len(s.steps),
                   "newton_iterations": sum(st.iterations for st in s.steps),
                   "petsc_options": an.solver.system.petsc_options},
        "timings": an.timings,
        "mpi_ranks": an.solver.comm.size,
        "versions": versions(),
        "loads": load_entries(an.scene, an.ring, an.lp.load_sides),
    }


def block_entries(scene, ring) -> list[dict]:
    """The ``blocks`` entry of results.json: per block its ``id``, ``kind`` ("voussoir" | "pier" | "abutment"),
    ``ring`` (0: the innermost; None off the rings), ``span`` (from 0, left to right; None off the spans), ``pier``
    and ``course`` (a pier's course: the pier from 0, left to right, and the course from 0 at its top; else None),
    ``polygon`` (counter-clockwise, m) and ``weight`` (N: :func:`bridgefem.limit.ring_blocks.block_weights`, the
    rigid-block LP's)."""
    weights = block_weights(scene, ring)

    def kind(b) -> str:
        return "voussoir" if isinstance(b, Voussoir) else "pier" if isinstance(b, PierBlock) else "abutment"

    return [{"id": b.id, "kind": kind(b), "ring": b.ring if isinstance(b, Voussoir) else None,
             "span": b.span if isinstance(b, Voussoir) else None,
             "pier": b.pier if isinstance(b, PierBlock) else None,
             "course": b.course if isinstance(b, PierBlock) else None,
             "polygon": b.polygon.tolist(), "weight": float(w)} for b, w in zip(ring.blocks, weights)]


def joint_entries(scene, ring, states) -> list[dict]:
    """The ``joints`` entry of results.json: per joint of ``ring`` its ``id``, ``kind``, ``span`` (the span whose barrel
    it belongs to; None: a pier's bed joint or an abutment's base), ``blocks`` (left, right;
    None: the ground), ``points`` (its intrados and extrados ends, m; a ring interface also its ``curve``), its law's
    ``friction``, ``cohesion`` (Pa) and ``compressive_strength`` (Pa; None where it does not crush: no strength, a
    ring interface), and the resultants and state of ``states`` (JointState rows of the last converged step, when
    there is one: :func:`bridgefem.analysis.mechanism.joint_states`)."""
    by_id = {js.id: js for js in states or []}
    j = scene.joints
    friction = {"base": scene.abutments.friction, "ring": j.ring_interface_friction}
    out = []
    for jt in ring.joints:
        js = by_id.get(jt.id)
        out.append({"id": jt.id, "kind": jt.kind, "span": jt.span, "blocks": [jt.left, jt.right],
                    "points": [jt.intrados.tolist(), jt.extrados.tolist()],
                    **({"curve": jt.curve.tolist()} if jt.curve is not None else {}),
                    "intrados": jt.intrados.tolist(), "extrados": jt.extrados.tolist(),
                    "friction": friction.get(jt.kind, j.friction),
                    "cohesion": j.ring_cohesion if jt.kind == "ring" else 0.0,
                    "compressive_strength": None if jt.kind == "ring" else scene.masonry.compressive_strength,
                    **({"normal_force": js.normal_force, "shear_force": js.shear_force,
                        "eccentricity": js.eccentricity, "open_fraction": js.open_fraction,
                        "opening": js.opening, "hinge": js.hinge, "sliding": js.sliding, "separated": js.separated,
                        "crushed_fraction": js.crushed_fraction, "compressed_depth": js.compressed_depth,
                        "stress_block_depth": js.stress_block_depth} if js else {})})
    return out


def load_entries(scene, ring, sides: list[str | None]) -> list[dict]:
    """The ``loads`` entry of results.json: each [[load]] table with its centre ``x`` (m); ``side``: the voussoir
    that carries a point load on a joint ("left" | "right" of the joint, "split": both; ``sides``, the rigid-block
    LP's least favourable choice; None off the joints, and over a fill, where the loads act on the road); ``point``
    [x, y] (m): where it acts, on the extrados (a point load; a patch: its centre, on the road over a fill);
    ``forces``: how the rigid-block LP applies it on a bare ring, per carrying voussoir its ``block``, ``point``
    [x, y] and vertical ``force`` (N per unit load level; :func:`bridgefem.limit.ring_blocks.load_forces`);
    ``snapped_to_joint`` and ``moved_by`` (m): the joint a point load was moved onto and how far
    (:func:`bridgefem.structure.ring.snapped_loads`; None and 0 for a load that acts where it was given)."""
    snapped = {s.index: s for s in snapped_loads(scene, ring)}
    chosen = tuple((sides[i] if i < len(sides) else None) or "split" for i in range(len(scene.loads)))
    parts = load_forces(scene, ring, chosen)
    road = None if scene.fill is None else ring.crown_extrados + scene.fill.depth
    out = []
    for i, (ld, (blocks, points, forces)) in enumerate(zip(scene.loads, parts)):
        s = snapped.get(i)
        side = sides[i] if scene.fill is None and i < len(sides) else None
        x = sum(ld.x_range(scene.arch.span)) / 2
        where = [x, road] if road is not None else ([float(points[:, 0].mean()), float(points[:, 1].mean())]
                                                    if ld.kind == "point" else ring.extrados_point(x).tolist())
        out.append({"kind": ld.kind, "position": ld.position, "x": x, "point": where,
                    "length": ld.length, "factor": ld.factor, "side": side,
                    "snapped_to_joint": s.joint if s else None, "moved_by": s.moved_by if s else 0.0,
                    "forces": [{"block": int(b), "point": p.tolist(), "force": float(f[1])}
                               for b, p, f in zip(blocks, points, forces)]})
    return out


def _reactions(an: Analysis) -> list[dict]:
    """``springing_reactions``: one labelled entry per joint on the ground (N, ground on the structure)."""
    if not an.joints:
        return []
    ring = an.ring
    on_ground = [js.id for js in an.joints if ring.joints[js.id].left is None or ring.joints[js.id].right is None]
    names = {j.id: f"{side} springing" + (f" of ring {k}" if ring.n_rings > 1 else "")
             for side in ("left", "right") for k, j in enumerate(ring.springings(side))}
    if an.scene.abutments.elastic:
        names = {j.id: f"{side} abutment base" for j, side in zip(ring.bases, ("left", "right"))}
    pier_of = {b.id: b.pier for b in ring.piers}
    names.update({j.id: f"foundation of pier {pier_of[j.left] + 1}" for j in ring.joints
                  if j.kind == "pier" and j.right is None})
    return [{"joint": jid, "at": names.get(jid, "ground"), "horizontal": float(h), "vertical": float(v)}
            for jid, (h, v) in zip(on_ground, springing_reactions(an.joints, ring))]


RING_CHECK_MODEL = ("the ring's rigid-block LP (associative friction) loaded by the forces the fill transmits across "
                    "the arch-fill interface: dead load = ring weight + interface forces after self-weight, live load = "
                    "their change up to the FE's last converged load, scaled with it; a lower-bound check: ratio >= 1, "
                    "close to 1 when the FE limit is a mechanism of the ring, above 1 when the fill restrains it")


def ring_check_summary(an: Analysis) -> dict | None:
    """The ``ring_under_transmitted_loads`` entry of results.json (None without a fill or a converged live load):
    ``fe_load`` the FE's last converged live load (N), ``load`` the live load at which the ring under the transmitted
    loads collapses (N; None if it does not), ``ratio`` = load / fe_load, the LP's status and mechanism."""
    check = an.ring_check
    if check is None:
        return None
    lp, total = check.lp, an.load_total
    return {"model": RING_CHECK_MODEL, "fe_load": check.fe_level * total,
            "load": None if check.lp_level is None else check.lp_level * total, "unit": "N",
            "ratio": check.ratio, "status": lp.status, "mechanism": mechanism_summary(lp)}


def lp_entries(an: Analysis) -> dict:
    """The ``lp``, ``fe_lp_ratio``, ``static_bound``, ``warnings`` and ``fill_bounds`` entries of results.json
    (:attr:`Analysis.lp`, :attr:`Analysis.fe_lp_ratio`, :func:`static_summary`, :attr:`Analysis.warnings`,
    :attr:`Analysis.fill_bounds`)."""
    return {"lp": lp_entry(an.lp, an.scene), "fe_lp_ratio": an.fe_lp_ratio,
            "static_bound": static_summary(an), "warnings": an.warnings, "fill_bounds": an.fill_bounds}


def static_summary(an: Analysis) -> dict | None:
    """The ``static_bound`` entry of results.json (None without one: a fill, or an LP that failed): the rigid-block
    LP on the same joints under the FE's own loads (:class:`bridgefem.analysis.evidence.StaticBound`), its collapse ``load``
    (N; None without one) and ``status``, the ``deficit`` (N) of joint tension and cohesion its blocks need under the
    FE's self-weight, the ``margin`` (N) a converged FE state's tolerances can hide, and ``closed``: the search ended
    on the bound."""
    b = an.static
    if b is None:
        return None
    return {"load": None if b.level is None else b.level * an.load_total, "status": b.status, "deficit": b.deficit,
            "margin": b.margin, "closed": an.search.static}


def write_results(an: Analysis, out: Path) -> dict:
    """Write results.json, fields.xdmf and the PNGs into ``out`` atomically, under the output policy of
    :mod:`bridgefem.io.output` (collective); returns the summary."""
    comm = an.solver.comm
    with results_folder(Path(out), comm) as tmp:
        data = summary(an)
        if an.converged:
            with quiet_compiler():
                _write_fields(an, tmp / "fields.xdmf")
        motion = an.collapse_mode
        if comm.rank == 0:
            (tmp / "results.json").write_text(json.dumps(data, indent=2))
            from .plots import plot_load_deflection, plot_mechanism

            plot_load_deflection(data, tmp / "load_deflection.png")
            plot_mechanism(an.ring, data, motion, tmp / "mechanism.png", _fill_polygon(an))
            from .report import run_report

            (tmp / "report.html").write_text(run_report(data, {"mechanism": tmp / "mechanism.png",
                                                               "load_deflection": tmp / "load_deflection.png"}))
    return data


XDMF_CELL = {3: ("Triangle", [0, 1, 2]), 6: ("Triangle_6", [0, 1, 2, 5, 3, 4])}  # DOLFINx's triangle dofs (P1,
# P2) in XDMF's node order


class _XdmfSeries:
    """An XDMF 3 temporal collection on one mesh (rank 0): the points and cells once, then per time value the point
    fields, each in the HDF5 file beside the XDMF file."""

    def __init__(self, path: Path, points: np.ndarray, cells: np.ndarray):
        import h5py

        self.path, self.h5 = path, h5py.File(path.with_suffix(".h5"), "w")
        self.h5["mesh/geometry"], self.h5["mesh/topology"] = points, cells
        kind, _ = XDMF_CELL[cells.shape[1]]
        self.mesh = (f'<Geometry GeometryType="XYZ">{self._item("mesh/geometry")}</Geometry>'
                     f'<Topology TopologyType="{kind}" NumberOfElements="{len(cells)}">'
                     f'{self._item("mesh/topology")}</Topology>')
        self.grids: list[str] = []

    def _item(self, name: str) -> str:
        data = self.h5[name]
        kind = "Int" if data.dtype.kind == "i" else "Float"
        dims = " ".join(map(str, data.shape))
        return (f'<DataItem DataType="{kind}" Precision="{data.dtype.itemsize}" Dimensions="{dims}" Format="HDF">'
                f'{self.path.with_suffix(".h5").name}:/{name}</DataItem>')

    def write(self, time: float, fields: dict[str, np.ndarray]) -> None:
        k = len(self.grids)
        attributes = ""
        for name, values in fields.items():
            self.h5[f"{name}/{k}"] = values
            kind = "Vector" if values.ndim == 2 else "Scalar"
            attributes += (f'<Attribute Name="{name}" AttributeType="{kind}" Center="Node">'
                           f'{self._item(f"{name}/{k}")}</Attribute>')
        self.grids.append(f'<Grid Name="step {k}" GridType="Uniform">{self.mesh}<Time Value="{time!r}"/>'
                          f'{attributes}</Grid>')

    def close(self) -> None:
        self.h5.close()
        self.path.write_text('<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain>'
                             '<Grid Name="load steps" GridType="Collection" CollectionType="Temporal">\n'
                             + "\n".join(self.grids) + "\n</Grid></Domain></Xdmf>\n")


def _write_fields(an: Analysis, path: Path) -> None:
    """Displacement (m, x y 0) and joint state (the joint law's output codes, :data:`NO_JOINT` off the joints; exact
    integers) at every converged load step, at the displacement's nodes (P1: triangles, P2: six-node triangles), as
    one XDMF time series whose time value is the live load (N), for ParaView and meshio's ``TimeSeriesReader``.
    Gathered to and written by rank 0. Collective."""
    V, pairs = an.model.V, an.pairs
    comm = V.mesh.comm
    imap = V.dofmap.index_map
    n_owned = imap.size_local
    dofs = V.dofmap.list.array.reshape(-1, V.dofmap.dof_layout.num_dofs)
    dofs = dofs[:V.mesh.topology.index_map(2).size_local]
    owned = imap.local_to_global(np.arange(n_owned, dtype=np.int32))
    points = comm.gather((owned, V.tabulate_dof_coordinates()[:n_owned]), root=0)
    cells = comm.gather(imap.local_to_global(dofs.ravel()).reshape(dofs.shape), root=0)
    codes = an.solver.law.output_codes()
    ends = np.concatenate([pairs.left, pairs.right])
    series = None
    if comm.rank == 0:
        xyz = np.zeros((sum(len(g) for g, _ in points), 3))
        for g, x in points:
            xyz[g] = x
        cells = np.vstack(cells)
        series = _XdmfSeries(path, xyz, cells[:, XDMF_CELL[cells.shape[1]][1]])
    for cs in an.converged:
        u = comm.gather((owned, cs.u.reshape(-1, 2)), root=0)
        state = comm.gather((ends, np.concatenate([codes[cs.pair_state]] * 2)), root=0)
        if series is not None:
            disp, joint_state = np.zeros_like(xyz), np.full(len(xyz), NO_JOINT, dtype=np.int32)
            for g, v in u:
                disp[g, :2] = v
            for g, c in state:
                joint_state[g[g >= 0]] = c[g >= 0]
            series.write(cs.load, {"displacement": disp, "joint_state": joint_state})
    if series is not None:
        series.close()


def pictures(an: Analysis, data: dict, level: float | None = None) -> dict[str, bytes]:
    """The mechanism (with the line of thrust), the load-deflection and the elevation (the bridge and its loads at
    ``level``, N per unit factor; default: the last converged one) PNGs of an analysis, as bytes (collective: the
    collapse mode; drawn on rank 0, empty elsewhere)."""
    import io

    motion = an.collapse_mode
    if an.solver.comm.rank != 0:
        return {}
    from .plots import plot_elevation, plot_load_deflection, plot_mechanism

    out = {}
    level = data["limit_load"]["lower"] / an.load_total if level is None else level
    loads = [{"x": ld["x"], "load": ld["factor"] * level} for ld in data["loads"]]
    for name, draw in (("mechanism", lambda f: plot_mechanism(an.ring, data, motion, f, _fill_polygon(an))),
                       ("load_deflection", lambda f: plot_load_deflection(data, f)),
                       ("elevation", lambda f: plot_elevation(an.ring, {**data, "loads": loads}, f,
                                                              _fill_polygon(an)))):
        buf = io.BytesIO()
        draw(buf)
        out[name] = buf.getvalue()
    return out


def _fill_polygon(an: Analysis) -> np.ndarray | None:
    """The fill's region (m): its ends, road and base, then the ring's extrados from right to left; None without
    a fill."""
    fill = an.scene.fill
    if fill is None:
        return None
    box = fill_outline(an.ring, fill.depth, fill.extension)
    extrados = np.vstack([v.extrados for v in an.ring.outer_voussoirs])
    extrados = extrados[np.argsort(-extrados[:, 0])]
    corners = [[box.x_left, box.y_base], [box.x_left, box.y_road], [box.x_right, box.y_road],
               [box.x_right, box.y_base]]
    return np.vstack([corners, extrados])
