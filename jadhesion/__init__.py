"""jadhesion: identify wheel–rail adhesion models (Polach, Kiencke) from traction recordings, in JAX."""

from .models import (PARAM_NAMES, adhesion_peak, hertz_semi_axes, kalker_c11, kiencke_adhesion,
                     kiencke_optimum, polach_adhesion)
from .data.vehicle import LOCO_22E, Vehicle
from .identify.curve_fit import curve_fit

__version__ = "0.1.0"
