"""A validated scene as frozen dataclasses, one a section, every value in SI units, every default taken from
:data:`~bridgefem.scene.schema.SCHEMA` (:mod:`bridgefem.scene.reader` builds them from a file)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .schema import SCHEMA


def _default(section: str, key: str) -> Any:
    """A key's default, from :data:`SCHEMA` (the dataclasses' field defaults)."""
    return SCHEMA[section][key].default


@dataclass(frozen=True)
class Arch:
    """The masonry ring: lengths in m measured on the intrados (span, rise); thickness normal to the centreline."""

    shape: str
    span: float
    rise: float
    thickness: float
    width: float
    voussoirs: int
    joint_at_loads: bool = _default("arch", "joint_at_loads")
    rings: int = _default("arch", "rings")
    ring_thicknesses: tuple[float, ...] | None = _default("arch", "ring_thicknesses")
    ring_bond: str = _default("arch", "ring_bond")

    @property
    def ring_layers(self) -> tuple[float, ...]:
        """The thickness (m) of each ring from the intrados out (one ring: empty)."""
        if self.ring_thicknesses:
            return self.ring_thicknesses
        return (self.thickness / self.rings,) * self.rings if self.rings > 1 else ()


@dataclass(frozen=True)
class Pier:
    """A masonry pier between two spans (``[[pier]]``): ``width`` (m) between the spans' intrados corners at
    springing level, ``height`` (m) from springing level down to its foundation, ``batter`` (m/m) each face's outward
    lean per metre down, ``blocks`` its courses (horizontal bed joints between them); ``young`` (Pa) and ``density``
    (kg/m^3) its own, None: the masonry's (its Poisson's ratio, joints and strength are the masonry's)."""

    width: float
    height: float
    batter: float = _default("pier", "batter")
    blocks: int = _default("pier", "blocks")
    young: float | None = _default("pier", "young")  # Pa; None: the masonry's
    density: float | None = _default("pier", "density")  # kg/m^3; None: the masonry's


@dataclass(frozen=True)
class Masonry:
    """Voussoir material: Young's modulus (Pa), Poisson's ratio, density (kg/m^3) and the joints' compressive
    strength (Pa; None: infinitely strong)."""

    young: float
    poisson: float
    density: float
    compressive_strength: float | None = _default("masonry", "compressive_strength")


@dataclass(frozen=True)
class JointProperties:
    """Coulomb friction coefficient of every joint, springings included; of the interfaces between rings
    ``ring_friction`` (None: ``friction``) and their cohesion ``ring_cohesion`` (Pa)."""

    friction: float
    ring_friction: float | None = _default("joints", "ring_friction")
    ring_cohesion: float = _default("joints", "ring_cohesion")

    @property
    def ring_interface_friction(self) -> float:
        return self.friction if self.ring_friction is None else self.ring_friction


@dataclass(frozen=True)
class Fill:
    """Backfill over the ring, in plane strain, between vertical ends and a base at the level of the springings'
    extrados corners (the rigid abutments below it are not meshed).

    unit_weight (N/m^3); young (Pa), poisson; depth (m): road level above the crown's extrados; extension (m):
    horizontal reach beyond each springing's extrados corner; material: "elastic" or "mohr-coulomb" (Drucker-Prager
    cone matched to Mohr-Coulomb in plane strain, see :mod:`bridgefem.laws.soil`) with friction_angle (degrees),
    cohesion (Pa), tension_cutoff (Pa, limit of the mean stress) and dilation_angle (degrees, 0 to friction_angle;
    None: equal to friction_angle, associated flow); interface_friction: Coulomb coefficient of
    the arch-fill interface (the extrados); element_size (m): mesh size away from the ring; loading_beam: patch
    loads reach the road through rigid loading beams (a test's spreader beam, a wheel's footprint) rather than as a
    flexible pressure, whose edge a frictional fill cannot carry (q <= c N_c at the edge of a uniform pressure).
    """

    unit_weight: float
    young: float
    depth: float
    extension: float
    poisson: float = _default("fill", "poisson")
    material: str = _default("fill", "material")
    friction_angle: float = _default("fill", "friction_angle")
    cohesion: float = _default("fill", "cohesion")
    tension_cutoff: float = _default("fill", "tension_cutoff")
    dilation_angle: float | None = _default("fill", "dilation_angle")
    interface_friction: float = _default("fill", "interface_friction")
    element_size: float = _default("fill", "element_size")
    loading_beam: bool = _default("fill", "loading_beam")


@dataclass(frozen=True)
class Abutments:
    """What carries the ring at its springings, and an optional imposed support movement.

    model: "rigid" (the springing joints bear on the rigid ground; no abutment mesh) or "elastic" (a block below
    each springing, from the springing line y = 0 down to y = -height (m), reaching ``length`` (m) outwards from
    the springing's intrados corner, with its own joints: the springing joint to the ring and its base to the
    rigid ground); young (Pa), poisson, unit_weight (N/m^3) of the blocks; friction: Coulomb coefficient of the
    base joints. Movement of the ground under ``movement_springing`` ("left", "right" or "both": under the
    springing joint, or under the abutment's base): movement_horizontal (m, positive = spreading, away from the
    span), movement_vertical (m, positive = up; a settlement is negative), imposed after the self-weight and
    before the live load in ``movement_steps`` equal increments.
    """

    model: str = _default("abutments", "model")
    height: float | None = None  # this key and the next five: elastic abutments only (None when rigid)
    length: float | None = None
    young: float | None = None
    poisson: float | None = None
    unit_weight: float | None = None
    friction: float | None = None
    movement_springing: str = _default("abutments", "movement_springing")
    movement_horizontal: float = _default("abutments", "movement_horizontal")
    movement_vertical: float = _default("abutments", "movement_vertical")
    movement_steps: int = _default("abutments", "movement_steps")

    @property
    def elastic(self) -> bool:
        return self.model == "elastic"

    @property
    def moves(self) -> bool:
        return bool(self.movement_horizontal or self.movement_vertical)


RIGID_ABUTMENTS = Abutments()


@dataclass(frozen=True)
class Load:
    """A vertical live load on the extrados, or on the road surface when the scene has a fill; ``position`` is the
    fraction of the span from the left springing (the centre of a patch), ``length`` the patch length along the
    span (m), ``factor`` its share of the load pattern (the live load is factor x load level, N)."""

    kind: str
    position: float  # of the first span: beyond 1 on a bridge of several spans
    length: float = _default("load", "length")
    factor: float = _default("load", "factor")
    x: float | None = _default("load", "x")

    def x_range(self, span: float) -> tuple[float, float]:
        """Horizontal extent on the extrados (m); a point load has zero length."""
        x = -span / 2 + self.position * span
        return x - self.length / 2, x + self.length / 2


@dataclass(frozen=True)
class Vehicle:
    """A vehicle rolled across the bridge (``bridgefem assess``): ``axles`` loads (N, for the scene's width), first
    (leftmost) axle first, ``spacing`` (m) between consecutive axles, ``contact_length`` (m) of each tyre patch
    along the road (0: point loads), ``dispersion``: how the rigid-block LP spreads an axle through a fill,
    ``standard``: the library vehicle (:data:`~bridgefem.scene.vehicles.VEHICLES`) it was taken from, or ""."""

    axles: tuple[float, ...]
    spacing: tuple[float, ...]
    contact_length: float
    dispersion: str = _default("vehicle", "dispersion")
    standard: str = _default("vehicle", "standard")

    @property
    def offsets(self) -> np.ndarray:
        """Each axle's distance (m) behind the first (leftmost) one."""
        return np.concatenate([[0.0], np.cumsum(self.spacing)])

    @property
    def length(self) -> float:
        """From the first axle to the last (m)."""
        return float(sum(self.spacing))


@dataclass(frozen=True)
class MeshOptions:
    """Elements through the ring thickness and Lagrange degree of the displacement field (1 or 2)."""

    elements_through_thickness: int = _default("mesh", "elements_through_thickness")
    degree: int = _default("mesh", "degree")


@dataclass(frozen=True)
class ModelOptions:
    """2D idealisation: plane strain (default) or plane stress."""

    plane: str = _default("model", "plane")


@dataclass(frozen=True)
class SolverOptions:
    """Path following and semismooth Newton settings.

    tolerance: relative width of the limit-load bracket; max_iterations: active-set iterations per step;
    max_load: live load (N) at which the search stops as "locked" (0: 100 x ring weight);
    initial_step: first live-load step (N; 0: ring weight / 4); max_steps: load steps in all;
    petsc: PETSc options for the linear solver (prefix ``bridgefem_``), e.g. {pc_factor_mat_solver_type = "mumps"};
    preset: the speed-accuracy preset (:data:`~bridgefem.scene.schema.PRESETS`,
    :data:`~bridgefem.scene.schema.FILL_PRESETS` with a Mohr-Coulomb fill) that supplied the mesh and tolerance
    defaults;
    stiffness_drop: with a fill, a load step whose secant stiffness (load over deflection increment), or tangent
    stiffness at its converged state, falls below this fraction of the tangent stiffness after self-weight, and
    whose curve's plateau, fitted to its last converged states, lies within ``tolerance`` above it, marks the
    limit (the load-deflection curve is flat: :mod:`bridgefem.search.step`, *Flat curve*; 0: only a lost
    equilibrium).
    """

    tolerance: float = _default("solver", "tolerance")
    max_iterations: int = _default("solver", "max_iterations")
    max_load: float = _default("solver", "max_load")
    initial_step: float = _default("solver", "initial_step")
    max_steps: int = _default("solver", "max_steps")
    petsc: dict = field(default_factory=dict)
    preset: str = _default("solver", "preset")
    stiffness_drop: float = _default("solver", "stiffness_drop")


@dataclass(frozen=True)
class Scene:
    """A validated scene; ``gravity`` in m/s^2. ``document``: the dictionary it was validated from (the TOML
    document as given, before defaults), which an edit re-validates with its changes
    (:mod:`bridgefem.scene.document`); not part of the scene's value."""

    name: str
    arch: Arch
    masonry: Masonry
    joints: JointProperties
    loads: tuple[Load, ...]
    gravity: float = _default("scene", "gravity")
    fill: Fill | None = None
    abutments: Abutments = RIGID_ABUTMENTS
    vehicle: Vehicle | None = None
    mesh: MeshOptions = MeshOptions()
    model: ModelOptions = ModelOptions()
    solver: SolverOptions = SolverOptions()
    document: dict | None = field(default=None, compare=False, repr=False)
    spans: tuple[Arch, ...] = ()
    piers: tuple[Pier, ...] = ()

    @property
    def arches(self) -> tuple[Arch, ...]:
        """Every span's arch, left to right: ``spans`` for a bridge of several spans (``[[span]]`` tables, the first
        of them ``arch``), else ``arch`` alone."""
        return self.spans or (self.arch,)

    @property
    def live_per_level(self) -> float:
        """Total live load (N) per unit load level: the loads' factors summed (1 without live loads, so that a
        level is then read as N)."""
        return sum(ld.factor for ld in self.loads) or 1.0

    def span_ranges(self) -> list[tuple[float, float]]:
        """Each span's horizontal extent between its springings' intrados corners (m, in the frame whose origin is
        the first span's midspan), left to right (:func:`span_ranges`)."""
        return span_ranges(self.arches, self.piers)

    def load_edges_x(self) -> list[float]:
        """Horizontal positions (m) of point loads and patch edges: where joints go by default."""
        xs: list[float] = []
        for ld in self.loads:
            a, b = ld.x_range(self.arch.span)
            xs.extend([a] if ld.kind == "point" else [a, b])
        return xs


def span_ranges(arches: tuple[Arch, ...], piers: tuple[Pier, ...]) -> list[tuple[float, float]]:
    """Each span's horizontal extent between its springings' intrados corners (m), left to right, in the frame whose
    origin is the first span's midspan: the spans side by side, each pier's ``width`` apart."""
    out, left = [], -arches[0].span / 2
    for k, a in enumerate(arches):
        out.append((left, left + a.span))
        left += a.span + (piers[k].width if k < len(piers) else 0.0)
    return out


def with_mesh(scene: Scene, elements_through_thickness: int) -> Scene:
    """The scene with its ring (and so its fill) meshed by this many elements through the thickness."""
    return dataclasses.replace(scene, mesh=dataclasses.replace(scene.mesh,
                                                               elements_through_thickness=elements_through_thickness))
