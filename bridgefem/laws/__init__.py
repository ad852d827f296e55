"""Constitutive laws: the joint laws (contact, friction) and the fill's soil, as objects on numpy arrays."""
