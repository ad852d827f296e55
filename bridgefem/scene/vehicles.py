"""The library of published assessment vehicles and load models (``[vehicle] standard``), and the ways an axle
may be carried through a fill (``[vehicle] dispersion``)."""
from __future__ import annotations

from typing import Any

MAX_AXLES = 20  # axles of one vehicle
VEHICLES: dict[str, dict[str, Any]] = {
    "EN1991-2-LM2": {"axles": (400e3,), "spacing": (), "contact_length": 0.0,
                     "source": "EN 1991-2:2003, 4.3.3(1): Load Model 2, a single axle of beta_Q x 400 kN (beta_Q = "
                               "alpha_Q1 = 1 unless the National Annex says otherwise), dynamic amplification "
                               "included"},
    "EN1991-2-LM1-single-axle": {"axles": (600e3,), "spacing": (), "contact_length": 0.0,
                                 "source": "EN 1991-2:2003, 4.3.2(6)b: for spans above 10 m, the tandem system of "
                                           "Lane 1 replaced by one axle of the two axles' weight, 600 alpha_Q1 kN "
                                           "(alpha_Q1 = 1 unless specified)"},
}
"""Published assessment vehicles and load models (``[vehicle] standard``): axle loads (N, the whole vehicle's: the
scene's width is the ring width that carries it), spacings (m) and the tyre contact along the road (m; 0 where the
source read did not give it). Each has the source it was read from (docs/assessment.md); a vehicle whose source
could not be read is not here."""
DISPERSIONS = ("boussinesq", "spread-2:1", "spread-30", "none")
"""How the rigid-block LP carries an axle through a fill to the extrados (:mod:`bridgefem.assess.dispersion`)."""
