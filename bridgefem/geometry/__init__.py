"""Arch geometry (pure numpy): :mod:`~bridgefem.geometry.shapes`, the intrados curves of every shape;
:mod:`~bridgefem.geometry.ring`, the joints, the voussoir and abutment polygons and where a load on the extrados
acts."""
