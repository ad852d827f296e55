"""Limit analysis on rigid blocks: the rigid-block LP and the conic lower/upper bounds with a fill.

Independent of the FE: nothing here imports :mod:`bridgefem.fe` or the solver."""
