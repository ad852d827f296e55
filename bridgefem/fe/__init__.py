"""The finite-element model (DOLFINx): :mod:`~bridgefem.fe.mesh` (the Gmsh mesh of the blocks, split at the joints),
:mod:`~bridgefem.fe.model` (elasticity, self-weight and live load), :mod:`~bridgefem.fe.pairs` (the joints' node
pairs), :mod:`~bridgefem.fe.fill` (the Mohr-Coulomb fill's internal force and tangent) and
:mod:`~bridgefem.fe.footing` (the fill model's calibration problems). Its size is estimated before it is built, without
DOLFINx, by :mod:`bridgefem.structure.sizing`.

Importing it starts PETSc without the option files of the current folder (:func:`bridgefem.petsc_start.start`)
and keeps the just-in-time compilers from reading the current folder's parameter files
(:func:`bridgefem.petsc_start.ignore_folder_jit_parameters`).
"""
from ..petsc_start import ignore_folder_jit_parameters, start

start()
ignore_folder_jit_parameters()
