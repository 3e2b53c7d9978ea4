"""jadhesion: identify wheel–rail adhesion models (Polach, Kiencke) from traction recordings, in JAX.

The names below are loaded on first use (PEP 562), so that importing a JAX-free part of the package
— the command line's argument parsing, ``jadhesion --help`` — does not start JAX.
"""

import importlib

__version__ = "0.1.0"

#: Public name → the module that defines it.
_EXPORTS = {
    **dict.fromkeys(
        (
            "PARAM_NAMES",
            "adhesion_peak",
            "hertz_semi_axes",
            "kalker_c11",
            "kiencke_adhesion",
            "kiencke_optimum",
            "polach_adhesion",
        ),
        "jadhesion.models",
    ),
    **dict.fromkeys(("LOCO_22E", "Vehicle"), "jadhesion.data.vehicle"),
    "curve_fit": "jadhesion.identify.curve_fit",
}
__all__ = [*_EXPORTS, "__version__"]


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'jadhesion' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(__all__)
