"""One load step of the FE model with its joint laws: the semismooth Newton (active-set) method."""
