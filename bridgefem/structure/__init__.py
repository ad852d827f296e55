"""The structure a scene describes: :mod:`~bridgefem.structure.ring` (its blocks and joints),
:mod:`~bridgefem.structure.supports` (the joints on the ground and the support movements),
:mod:`~bridgefem.structure.grading` (a joint's element ends, graded for a compressed zone) and
:mod:`~bridgefem.structure.sizing` (the size of the FE model that meshes them, estimated from the scene alone, and the
element sizes the mesher and the estimate share)."""
