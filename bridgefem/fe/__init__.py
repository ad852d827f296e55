"""The finite-element model: Gmsh mesh of the blocks, elasticity, joint node pairs, the fill.

Importing it starts PETSc without the option files of the current folder (:func:`bridgefem.petsc_start.start`)
and keeps the just-in-time compilers from reading the current folder's parameter files
(:func:`bridgefem.petsc_start.ignore_folder_jit_parameters`).
"""
from ..petsc_start import ignore_folder_jit_parameters, start

start()
ignore_folder_jit_parameters()
