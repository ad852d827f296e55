"""Arch geometry: intrados curves of every shape, joints and voussoir polygons (pure numpy)."""
