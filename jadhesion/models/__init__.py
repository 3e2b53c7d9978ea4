"""Pure model functions: Polach and Kiencke adhesion, Hertz/Kalker contact, kinematics."""

from .contact import Contact, contact_stiffness, elliptic_ke, hertz_semi_axes, kalker_c11
from .kiencke import RAIL_SETS, KienckeParams, kiencke_adhesion, kiencke_optimum, kiencke_regressors
from .kinematics import SPEED_FLOOR, creepage, slip_velocity
from .polach import (
    BOUNDS,
    PARAM_NAMES,
    adhesion_peak,
    friction,
    gradient_constant,
    initial_slope,
    polach_adhesion,
)

__all__ = [
    "BOUNDS",
    "Contact",
    "KienckeParams",
    "PARAM_NAMES",
    "RAIL_SETS",
    "SPEED_FLOOR",
    "adhesion_peak",
    "contact_stiffness",
    "creepage",
    "elliptic_ke",
    "friction",
    "gradient_constant",
    "hertz_semi_axes",
    "initial_slope",
    "kalker_c11",
    "kiencke_adhesion",
    "kiencke_optimum",
    "kiencke_regressors",
    "polach_adhesion",
    "slip_velocity",
]
