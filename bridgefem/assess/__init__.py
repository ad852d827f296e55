"""The assessment of a bridge for a vehicle: the vehicle rolled across the span, every position screened by the
rigid-block LP, the critical positions confirmed by the FE limit analysis (:mod:`bridgefem.assess.sweep`)."""
