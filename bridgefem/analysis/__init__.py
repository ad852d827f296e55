"""The FE limit analysis of a scene, its evidence (proofs, LP agreement) and mesh convergence.

Importing it starts PETSc without the option files of the current folder
(:func:`bridgefem.petsc_start.start`).
"""
from ..petsc_start import start

start()
