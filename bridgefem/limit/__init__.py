"""Limit analysis on rigid blocks: the rigid-block LP and the conic lower/upper bounds with a fill.

The rigid-block LP: :mod:`~bridgefem.limit.rigid_block` (blocks, joints, the programme and its solution),
:mod:`~bridgefem.limit.ring_blocks` (a scene's ring as blocks), :mod:`~bridgefem.limit.collapse` (the collapse load
with point loads on joints where least favourable), :mod:`~bridgefem.limit.thickness` (the least thickness). The
conic bounds: :mod:`~bridgefem.limit.bounds` (both bounds of a scene), :mod:`~bridgefem.limit.bounds_model` (the
rigid-plastic model), :mod:`~bridgefem.limit.bounds_mesh` (the fill's triangles), :mod:`~bridgefem.limit.bounds_lower`
and :mod:`~bridgefem.limit.bounds_upper` (the two programmes), :mod:`~bridgefem.limit.conic` (Clarabel).

Independent of the FE: nothing here imports :mod:`bridgefem.fe` or the solver, so that the LP stays an independent
check of the FE."""
