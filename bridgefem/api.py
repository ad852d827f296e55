"""bridgefem's public API: a scene in, its limit load out. ``import bridgefem`` gives every name here.

    import bridgefem

    scene = bridgefem.load_scene("demos/bare_arch.toml")
    result = bridgefem.analyse(scene)
    print(result.status, result.limit_load.lower, result.limit_load.upper)   # N, for the scene's width
    for friction in (0.4, 0.5, 0.6):                                          # a sweep is a loop
        print(bridgefem.analyse(bridgefem.edit(scene, joints={"friction": friction})).limit_load)

1. :func:`load_scene` reads and validates a scene file, :func:`scene_from_dict` a dictionary of the same sections;
   a bad value raises :class:`SceneError`, one line naming the key, the value and what is allowed.
2. :func:`edit` returns a changed scene, validated as the changed file would be (:mod:`bridgefem.scene.document`).
3. :func:`lp` solves the rigid-block limit analysis alone (a linear programme on the same joints; milliseconds).
5. :func:`assess_vehicle` rolls the scene's ``[vehicle]`` across the bridge: the adequacy factor, its critical position
   (m from the left springing), the LP screen and the FE confirmations (:mod:`bridgefem.assess.sweep`).
4. :func:`analyse` runs the FE limit analysis and its checks (:func:`bridgefem.analysis.runner.run_analysis`) and
   summarises it as results.json (:func:`bridgefem.io.results.summary`): :class:`Result`. It is collective over
   ``comm``: under ``mpirun`` every rank calls it and gets the same result.

Loads are in N for the scene's ``[arch] width``, lengths in m. Importing this module loads neither DOLFINx nor PETSc:
:func:`analyse` does, when it is called. It writes no file (``bridgefem run`` writes the results folder).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

from .io.lp_report import lp_entry, rigid_block_result
from .scene.document import edit
from .scene.keys import SceneError
from .scene.model import Scene
from .scene.reader import load_scene, scene_from_dict
from .status import Status

__all__ = ["LimitLoad", "Result", "RigidBlock", "Scene", "SceneError", "Status", "analyse", "assess_vehicle",
           "edit", "load_scene", "lp", "scene_from_dict"]


@dataclass(frozen=True)
class LimitLoad:
    """The limit load's bracket in ``unit`` (N) for ``width`` (m) of the ring: the structure carries ``lower`` (a
    converged equilibrium) and not ``upper``, with ``upper - lower <= tolerance x lower``. ``upper`` is None without
    a bracket (stable under self-weight, locked, unstable, or a solver failure: ``lower`` is then the last live load
    carried)."""

    lower: float
    upper: float | None
    tolerance: float
    width: float
    unit: str


@dataclass(frozen=True)
class RigidBlock:
    """The rigid-block limit analysis (a linear programme) on the scene's joints: the collapse ``load`` in ``unit``
    (N; None without one), its ``status``, the mechanism's ``hinges`` and ``sliding`` joints, the ``friction_model``
    and what it models of the scene (``model``: the bare ring, or the fill as dead load only)."""

    load: float | None
    status: str
    hinges: tuple[int, ...]
    sliding: tuple[int, ...]
    friction_model: str
    model: str
    unit: str

    @classmethod
    def of(cls, entry: dict) -> RigidBlock:
        """From the ``lp`` entry of results.json (:func:`bridgefem.io.lp_report.lp_entry`)."""
        return cls(entry["load"], entry["status"], tuple(entry["mechanism"]["hinges"]),
                   tuple(entry["mechanism"]["sliding"]), entry["friction_model"], entry["model"], entry["unit"])


@dataclass(frozen=True)
class Result:
    """What :func:`analyse` found for ``scene``: its ``status`` (a :class:`Status` text), the ``limit_load``, the
    collapse mechanism read off the last converged state (``hinges`` and ``sliding`` joints, numbered from the left
    springing), the rigid-block LP check ``lp`` and ``fe_lp_ratio`` (FE bracket midpoint over the LP's load), the
    ``evidence`` for the verdict and the ``warnings`` a user must read before trusting it. ``summary`` is the whole
    of results.json as a dictionary (units and sign conventions in its ``units`` and ``conventions`` entries)."""

    scene: Scene = field(repr=False)
    status: str
    limit_load: LimitLoad
    hinges: tuple[int, ...]
    sliding: tuple[int, ...]
    lp: RigidBlock
    fe_lp_ratio: float | None
    evidence: str
    warnings: tuple[str, ...]
    summary: dict = field(repr=False)

    @classmethod
    def of(cls, scene: Scene, summary: dict) -> Result:
        """From the summary of results.json (:func:`bridgefem.io.results.summary`)."""
        return cls(scene, str(summary["status"]), LimitLoad(**summary["limit_load"]),
                   tuple(summary["mechanism"]["hinges"]), tuple(summary["mechanism"]["sliding"]),
                   RigidBlock.of(summary["lp"]), summary["fe_lp_ratio"], summary["evidence"],
                   tuple(summary["warnings"]), summary)

    def to_json(self) -> str:
        """The text of results.json: every entry of :attr:`summary`, with its units."""
        return json.dumps(self.summary, indent=2)


def analyse(scene: Scene, comm=None, petsc: dict[str, str] | None = None) -> Result:
    """The limit load of ``scene`` by the FE, with its rigid-block LP check (collective over ``comm``, an mpi4py
    communicator; default: every rank). ``petsc``: PETSc options of the contact solver without their prefix (e.g.
    ``{"ksp_type": "preonly"}``), over the scene's ``[solver.petsc]``. A model larger than the machine or
    :data:`bridgefem.structure.sizing.MAX_DOFS` unknowns is refused with :class:`SceneError`, as ``bridgefem run``
    does."""
    from mpi4py import MPI

    from .analysis.runner import run_analysis
    from .io.results import summary
    from .solver.linear import check_petsc_options
    from .structure.sizing import check_size

    comm = MPI.COMM_WORLD if comm is None else comm
    petsc = dict(petsc or {})
    check_size(scene)
    check_petsc_options({**scene.solver.petsc, **petsc}, comm)
    return Result.of(scene, summary(run_analysis(scene, comm, petsc)))


def lp(scene: Scene, friction_model: str = "associative") -> RigidBlock:
    """The rigid-block LP of ``scene`` alone (``friction_model``: "associative", a bound, or "non-associative",
    one collapse state of several: docs/joints-and-lp.md). A failed LP is a result with the status "solver failure:
    <reason>" and no load."""
    return RigidBlock.of(lp_entry(rigid_block_result(scene, friction_model), scene))


def assess_vehicle(scene: Scene, comm=None, step: float | None = None, fe: bool = True):
    """The assessment of ``scene``'s ``[vehicle]`` (:class:`bridgefem.assess.sweep.Assessment`: ``adequacy``
    (lower, upper) by the FE, ``critical_x`` (m), ``lp_factor``, ``positions``, ``confirmations``; ``fe=False``: the
    rigid-block LP screen alone, milliseconds a position). ``step`` (m): the screening step (default span/40).
    Collective over ``comm`` (default: every rank). Raises :class:`SceneError` for a scene without a vehicle. (Not
    ``bridgefem.assess``: that name is the subpackage :mod:`bridgefem.assess`.)"""
    from .assess.sweep import assess as run

    if scene.vehicle is None:
        raise SceneError("[vehicle]: missing; assess rolls the scene's [vehicle] across the bridge")
    return run([scene], comm, step, fe=fe)[0]
