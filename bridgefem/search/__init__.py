"""The limit search: self-weight first, then the live load raised until no equilibrium exists.

Importing it starts PETSc without the option files of the current folder
(:func:`bridgefem.petsc_start.start`).
"""
from ..petsc_start import start

start()
