"""Arch geometry (pure numpy): :mod:`~bridgefem.geometry.ring`, the intrados curves of every shape, the joints, the
voussoir and abutment polygons and where a load on the extrados acts."""
