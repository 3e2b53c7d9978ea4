"""Column names and units: the map from a logger's columns to the canonical SI columns (DESIGN §3).

A map entry is ``CANONICAL=SOURCE[UNIT]`` (``--column`` on the command line) or, in the sidecar,
``"columns": {"CANONICAL": "SOURCE[UNIT]"}``; ``[UNIT]`` may be left out (SI assumed). Units:

* ``time``: ``s``, ``ms``, ``us`` (``µs``, ``μs``), ``ns`` (an epoch in ns, ~1.8e18, rounded to
  float64 first: ~0.3 µs), ``min``, ``h``;
* ``vehicle_speed``, ``slip_velocity``: ``m/s``, ``km/h``, ``mph``;
* ``wheel_speed``: also ``rpm`` (German loggers' ``1/min``, ``U/min``, ``min^-1``) and ``rad/s``
  (times the vehicle's nominal wheel radius [m]);
* ``traction_torque``: ``N*m``, ``kN*m`` (``Nm``, ``kNm`` accepted);
* ``creepage``, ``adhesion``: ``-`` (dimensionless).

A unit is read without its whitespace, and a middle dot or a point as ``*`` (``kN·m``, ``kN.m``).

A header may state its column's unit, ``SOURCE[UNIT]``, ``SOURCE [UNIT]`` or, with a unit listed
here, ``SOURCE (UNIT)`` (:func:`split_unit`):
the map's ``SOURCE`` then names it (its unit the header's, or the one given when the header's is
not listed above), and a canonical column named so (``vehicle_speed [km/h]``) is read in that unit
without a map. Canonical names are matched ignoring case when no header is spelled exactly so.
"""

from __future__ import annotations

import math
import re
from typing import NamedTuple

from ..errors import RecordingError

_SPEED = {"m/s": 1.0, "km/h": 1.0 / 3.6, "mph": 0.44704}
_TORQUE = {"N*m": 1.0, "Nm": 1.0, "kN*m": 1e3, "kNm": 1e3}
_RPM = 2.0 * math.pi / 60.0
#: Wheel-speed units through the wheel radius, as rad/s per unit.
_ANGULAR = {"rpm": _RPM, "1/min": _RPM, "U/min": _RPM, "min^-1": _RPM, "rad/s": 1.0}
#: Units accepted per canonical column, as factors to SI; ``None`` marks units through the radius.
UNITS = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0},
    "vehicle_speed": _SPEED,
    "slip_velocity": _SPEED,
    "wheel_speed": {**_SPEED, **dict.fromkeys(_ANGULAR)},
    "traction_torque": _TORQUE,
    "creepage": {"-": 1.0},
    "adhesion": {"-": 1.0},
}
#: Every unit key of every column.
UNIT_KEYS = frozenset().union(*UNITS.values())
_DOTS = str.maketrans({"·": "*", "⋅": "*", ".": "*"})
_HEADER_UNIT = re.compile(r"^(.*?)\s*\[([^\[\]]*)\]$")
_HEADER_PAREN_UNIT = re.compile(r"^(.*?)\s*\(([^()]*)\)$")
_SPEC = re.compile(r"^\s*([^=\s]+)\s*=\s*([^\[\]]*?)\s*(?:\[([^\[\]]*)\])?\s*$")


def unit_key(unit: str) -> str:
    """``unit`` as :data:`UNITS` spells it: whitespace removed, ``·``, ``⋅`` and ``.`` as ``*``."""
    return "".join(unit.split()).translate(_DOTS)


def same_unit(canonical: str, a: str, b: str) -> bool:
    """Whether unit keys ``a`` and ``b`` are one unit of ``canonical`` (``kNm`` and ``kN*m``,
    ``rpm`` and ``1/min``)."""
    table = UNITS[canonical]
    if a == b:
        return True
    if a not in table or b not in table:
        return False
    return (table[a], _ANGULAR.get(a)) == (table[b], _ANGULAR.get(b))


def split_unit(column: str) -> tuple[str, str | None]:
    """``(name, unit key)`` of a header that states its unit, ``v_Lok[km/h]`` or ``v_Lok [km/h]``,
    or in parentheses a unit listed in :data:`UNITS`, ``Speed (km/h)`` (``Speed (front)`` is a
    name); ``(column, None)`` of one that does not."""
    match = _HEADER_UNIT.match(column.strip())
    if match and match.group(1):
        return match.group(1), unit_key(match.group(2))
    match = _HEADER_PAREN_UNIT.match(column.strip())
    if match and match.group(1) and unit_key(match.group(2)) in UNIT_KEYS:
        return match.group(1), unit_key(match.group(2))
    return column, None


class ColumnSpec(NamedTuple):
    """One map entry: canonical column, the file's column name, its unit (SI when ``None``)."""

    canonical: str
    source: str
    unit: str | None = None

    def text(self) -> str:
        """``SOURCE[UNIT]``, or ``SOURCE`` without a unit."""
        return f"{self.source}[{self.unit}]" if self.unit else self.source


def parse_column_spec(text: str, where: str) -> ColumnSpec:
    """Parse ``CANONICAL=SOURCE[UNIT]``; ``where`` (e.g. ``--column``) prefixes the error line."""
    match = _SPEC.match(text)
    if not match or not match.group(2):
        raise RecordingError(
            f"{where} {text!r}: expected CANONICAL=SOURCE[UNIT], e.g. vehicle_speed=v_Lok_kmh[km/h]"
        )
    canonical, source, unit = match.group(1), match.group(2), match.group(3)
    if canonical not in UNITS:
        raise RecordingError(
            f"{where} {text!r}: unknown canonical column {canonical!r}; expected one of {', '.join(UNITS)}"
        )
    if unit is not None and unit_key(unit) not in UNITS[canonical]:
        raise RecordingError(
            f"{where} {text!r}: unit {unit!r} is not a unit of {canonical}; "
            f"expected one of {', '.join(UNITS[canonical])}"
        )
    return ColumnSpec(canonical, source, None if unit is None else unit_key(unit))


def parse_column_map(specs, where: str) -> dict:
    """``{canonical: ColumnSpec}`` from ``CANONICAL=SOURCE[UNIT]`` strings; a canonical twice fails."""
    out = {}
    for text in specs:
        spec = parse_column_spec(text, where)
        if spec.canonical in out:
            raise RecordingError(f"{where} {text!r}: {spec.canonical} is mapped twice")
        out[spec.canonical] = spec
    return out


def to_si(spec: ColumnSpec, wheel_radius_m: float) -> float:
    """Factor taking the source column to SI (rpm and rad/s through ``wheel_radius_m`` [m])."""
    if spec.unit is None:
        return 1.0
    factor = UNITS[spec.canonical][spec.unit]
    if factor is not None:
        return factor
    return wheel_radius_m * _ANGULAR[spec.unit]
