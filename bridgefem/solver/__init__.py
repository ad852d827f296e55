"""One load step of the FE model with its joint laws: the semismooth Newton (active-set) method.

Importing it starts PETSc without the option files of the current folder
(:func:`bridgefem.petsc_start.start`).
"""
from ..petsc_start import start

start()
