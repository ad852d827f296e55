"""The library of published assessment vehicles and load models (``[vehicle] standard``), and the ways an axle
may be carried through a fill (``[vehicle] dispersion``)."""
from __future__ import annotations

from typing import Any

MAX_AXLES = 20  # axles of one vehicle
TONNE = 9.80665e3  # N per tonne-force (standard gravity), for the standards that give axle loads in tonnes
VEHICLES: dict[str, dict[str, Any]] = {
    "EN1991-2-LM2": {"axles": (400e3,), "spacing": (), "contact_length": 0.0,
                     "source": "EN 1991-2:2003, 4.3.3(1): Load Model 2, a single axle of beta_Q x 400 kN (beta_Q = "
                               "alpha_Q1 = 1 unless the National Annex says otherwise), dynamic amplification "
                               "included"},
    "EN1991-2-LM1-single-axle": {"axles": (600e3,), "spacing": (), "contact_length": 0.0,
                                 "source": "EN 1991-2:2003, 4.3.2(6)b: for spans above 10 m, the tandem system of "
                                           "Lane 1 replaced by one axle of the two axles' weight, 600 alpha_Q1 kN "
                                           "(alpha_Q1 = 1 unless specified)"},
    "EN1991-2-LM1-TS1": {"axles": (300e3, 300e3), "spacing": (1.2,), "contact_length": 0.4,
                         "source": "EN 1991-2:2003, 4.3.2 and Figure 4.2a: Load Model 1's tandem system of Lane 1, "
                                   "two axles of alpha_Q1 Q_1k = 300 kN 1.2 m apart, wheels on 0.40 m square "
                                   "contact surfaces, dynamic amplification included; without the model's uniformly "
                                   "distributed load q_1k = 9 kN/m2"},
    "EN1991-2-LM71-axles": {"axles": (250e3,) * 4, "spacing": (1.6,) * 3, "contact_length": 0.0,
                            "source": "EN 1991-2:2003, 6.3.2 and Figure 6.2 (UIC 702's Load Model 71): the four "
                                      "point forces Q_vk = 250 kN 1.6 m apart, times the classification factor "
                                      "alpha (1 unless specified); without the model's distributed q_vk = 80 kN/m on "
                                      "either side of the axles and without the dynamic factor Phi"},
    "CS454-single-11.5t": {"axles": (11.5 * TONNE,), "spacing": (), "contact_length": 0.0,
                           "source": "DMRB CS 454 rev. 0, Table 7.3.1a (masonry arches): normal traffic, single axle "
                                     "of 11.5 tonnes"},
    "CS454-double-8t-1.00m": {"axles": (8 * TONNE,) * 2, "spacing": (1.0,), "contact_length": 0.0,
                              "source": "DMRB CS 454 rev. 0, Table 7.3.1a: normal traffic, double axle bogie of 8 "
                                        "tonnes per axle for spacings 1.00 <= s < 1.30 m, at s = 1.00 m"},
    "CS454-double-9.5t-1.30m": {"axles": (9.5 * TONNE,) * 2, "spacing": (1.3,), "contact_length": 0.0,
                                "source": "DMRB CS 454 rev. 0, Table 7.3.1a: normal traffic, double axle bogie of "
                                          "9.5 tonnes per axle for spacings 1.30 <= s < 1.80 m, at s = 1.30 m"},
    "CS454-double-10t-1.80m": {"axles": (10 * TONNE,) * 2, "spacing": (1.8,), "contact_length": 0.0,
                               "source": "DMRB CS 454 rev. 0, Table 7.3.1a: normal traffic, double axle bogie of 10 "
                                         "tonnes per axle for spacings s >= 1.80 m, at s = 1.80 m"},
    "AASHTO-LRFD-design-truck": {"axles": (35e3, 145e3, 145e3), "spacing": (4.3, 4.3), "contact_length": 0.25,
                                 "source": "AASHTO LRFD Bridge Design Specifications, 3.6.1.2.2 and Figure "
                                           "3.6.1.2.2-1: the design truck, 35, 145 and 145 kN axles, 4.3 m and "
                                           "4.3 m (the shortest of the 4.3 to 9.0 m the rear spacing may take) "
                                           "apart; 3.6.1.2.5: tyre contact 250 mm long; without the design lane "
                                           "load (9.3 N/mm) and the dynamic load allowance"},
    "AASHTO-LRFD-design-tandem": {"axles": (110e3, 110e3), "spacing": (1.2,), "contact_length": 0.25,
                                  "source": "AASHTO LRFD Bridge Design Specifications, 3.6.1.2.3: the design "
                                            "tandem, two 110 kN axles 1.2 m apart; 3.6.1.2.5: tyre contact 250 mm "
                                            "long; without the design lane load and the dynamic load allowance"},
}
"""Published assessment vehicles and load models (``[vehicle] standard``): axle loads (N, the whole vehicle's: the
scene's width is the ring width that carries it), spacings (m) and the tyre contact along the road (m; 0 where the
source read did not give it). Each has the source it was read from (docs/assessment.md); a vehicle whose source
could not be read is not here."""
DISPERSIONS = ("boussinesq", "spread-2:1", "spread-30", "none")
"""How the rigid-block LP carries an axle through a fill to the extrados (:mod:`bridgefem.assess.dispersion`)."""
