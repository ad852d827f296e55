"""What each block of a scene's structure is made of: one source for the FE model (stiffness, self-weight), the
rigid-block LP's weights and the joints' stiffness.

:func:`block_materials` gives every block of :func:`bridgefem.structure.ring.scene_ring` (by id: voussoirs, pier
courses, abutments) its Young's modulus (Pa), Poisson's ratio and unit weight (N/m^3): the voussoirs the masonry's
(``[masonry]`` young, poisson, density x gravity); a pier's courses its ``[[pier]]`` young and density where given,
else the masonry's; the elastic abutments ``[abutments]`` young, poisson and unit_weight. The fill and the loading
beams are not blocks of the structure (:mod:`bridgefem.fe.model` gives them their own).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.ring import Abutment, ArchRing, PierBlock
from ..scene.model import Scene


@dataclass(frozen=True)
class BlockMaterials:
    """Per block id (0 .. n_blocks - 1): ``young`` (Pa), ``poisson`` and ``unit_weight`` (N/m^3) arrays."""

    young: np.ndarray
    poisson: np.ndarray
    unit_weight: np.ndarray

    def own(self, scene: Scene) -> list[int]:
        """The blocks whose material is not the masonry's (an abutment, a pier of its own material)."""
        m = scene.masonry
        return [int(b) for b in np.flatnonzero((self.young != m.young) | (self.poisson != m.poisson)
                                               | (self.unit_weight != m.density * scene.gravity))]


def block_materials(scene: Scene, ring: ArchRing) -> BlockMaterials:
    """Each block's material (module docstring)."""
    m, ab = scene.masonry, scene.abutments
    rows = []
    for b in ring.blocks:
        if isinstance(b, Abutment):
            rows.append((ab.young, ab.poisson, ab.unit_weight))
        elif isinstance(b, PierBlock):
            pier = scene.piers[b.pier]
            rows.append((pier.young or m.young, m.poisson, (pier.density or m.density) * scene.gravity))
        else:
            rows.append((m.young, m.poisson, m.density * scene.gravity))
    young, poisson, unit_weight = (np.array(col, float) for col in zip(*rows)) if rows else (np.zeros(0),) * 3
    return BlockMaterials(young, poisson, unit_weight)
