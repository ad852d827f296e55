"""The structure a scene describes: :mod:`~bridgefem.structure.ring` (its blocks and joints) and
:mod:`~bridgefem.structure.supports` (the joints on the ground and the support movements)."""
