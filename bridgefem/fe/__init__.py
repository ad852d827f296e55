"""The finite-element model (DOLFINx): :mod:`~bridgefem.fe.mesh` (the Gmsh mesh of the blocks, split at the joints),
:mod:`~bridgefem.fe.model` (elasticity, self-weight and live load), :mod:`~bridgefem.fe.pairs` (the joints' node
pairs), :mod:`~bridgefem.fe.fill` (the Mohr-Coulomb fill's internal force and tangent), :mod:`~bridgefem.fe.sizing`
(the model's size estimated before it is built) and :mod:`~bridgefem.fe.footing` (the fill model's calibration
problems)."""
