"""The recording's JSON sidecar ``<same stem>.json``: vehicle keys (:data:`SIDECAR_KEYS`) and the
column map ``"columns": {"CANONICAL": "SOURCE[UNIT]"}``.

Any other key is ignored with a note naming it (and the known key it most resembles, a likely
misspelling): the vehicle then keeps the 22E default the key may have meant to change. Every command
that loads a recording says so (:func:`sidecar_warning`: a line on stderr and, where its output
carries ``warnings``, a ``sidecar_unknown_key`` entry).
"""

from __future__ import annotations

import difflib
import json
import math
from pathlib import Path

from .readers import _read_text
from .validate import _fail
from .vehicle import LOCO_22E, SIDECAR_KEYS


def _brief(value) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:40] + "…"


def _finite(x) -> bool:
    """A JSON number (not a bool) representable as a finite float."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return False
    try:
        return math.isfinite(float(x))
    except OverflowError:  # an integer beyond float range
        return False


def _check_sidecar_value(key, value, name):
    where = f"key {key!r}"
    kind = SIDECAR_KEYS[key]
    if kind is str:
        if not isinstance(value, str):
            raise _fail(name, f"{where}: expected a string, got {type(value).__name__} {_brief(value)}")
        return value
    if kind is list:  # contact_semi_axes_m
        ok = isinstance(value, list) and len(value) == 2 and all(_finite(x) and x > 0 for x in value)
        if not ok:
            raise _fail(
                name, f"{where}: expected two positive numbers [a, b] in metres, got {json.dumps(value)}"
            )
        return (float(value[0]), float(value[1]))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(name, f"{where}: expected a number, got {type(value).__name__} {_brief(value)}")
    if not _finite(value):
        raise _fail(name, f"{where}: {_brief(value)} is not a finite number")
    if key == "poisson_ratio":
        if not 0.0 <= value < 0.5:
            raise _fail(name, f"{where}: {value} is outside [0, 0.5)")
    elif value <= 0:
        raise _fail(name, f"{where}: {value} must be positive")
    if key in PLAUSIBLE:
        lo, hi, low_unit, high_unit = PLAUSIBLE[key]
        if not lo <= value <= hi:
            unit = low_unit if value < lo else high_unit
            raise _fail(
                name,
                f"{where}: {value} is outside the plausible {lo:g}–{hi:g}"
                + (f"; in {unit}?" if unit else ""),
            )
    return float(value)


#: Plausible ranges of the vehicle keys a unit slip lands far outside, with the unit a value below
#: and above likely is in (a radius in mm, a load in tonnes or as a weight in N): rail vehicles'
#: wheels 0.3–0.65 m, axle loads 5–35 t.
PLAUSIBLE = {"wheel_radius_m": (0.1, 2.0, None, "mm"), "axle_load_kg": (500.0, 100_000.0, "t", "N")}


#: A known key at least this similar (:class:`difflib.SequenceMatcher` ratio) to an unknown one is
#: suggested as what it meant.
SIMILAR = 0.75


def _unknown(key: str) -> str:
    close = difflib.get_close_matches(key, [*SIDECAR_KEYS, "columns"], n=1, cutoff=SIMILAR)
    return f"unknown key {key!r} ignored" + (f" (did you mean {close[0]!r}?)" if close else "")


def unknown_key_note(name: str, key: str) -> str:
    """The note of an unknown sidecar ``key`` in sidecar ``name``, with the known key it most
    resembles when one is :data:`SIMILAR` enough."""
    return f"{name}: {_unknown(key)}"


def _unknown_keys(recording) -> list:
    return [k for k in recording.sidecar if k not in SIDECAR_KEYS and k != "columns"]


def unknown_key_notes(recording) -> set:
    """The notes (:func:`unknown_key_note`) ``recording``'s loading gave its sidecar's unknown
    keys."""
    name = str(recording.path.with_suffix(".json"))
    return {unknown_key_note(name, key) for key in _unknown_keys(recording)}


def sidecar_warning(recording) -> dict | None:
    """``{code: "sidecar_unknown_key", params: [keys], message}`` when ``recording``'s sidecar has
    keys that are neither vehicle keys nor ``columns`` (the message: their notes as
    :func:`unknown_key_note` words them), else ``None``."""
    unknown = _unknown_keys(recording)
    if not unknown:
        return None
    notes = "; ".join(map(_unknown, unknown))
    message = (
        f"{recording.path.with_suffix('.json')}: {notes}: a vehicle value meant there keeps its 22E default"
    )
    return {"code": "sidecar_unknown_key", "params": unknown, "message": message}


def _load_sidecar(csv_path: Path):
    path = csv_path.with_suffix(".json")
    if not path.exists():
        return path, {}, LOCO_22E, ()
    name = str(path)
    text = _read_text(path, name, kind="sidecar")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise _fail(
            name, f"sidecar is not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    except RecursionError:
        raise _fail(name, "sidecar is not valid JSON (nested too deeply)") from None
    if not isinstance(data, dict):
        raise _fail(
            name, f'sidecar must be a JSON object {{"key": value, ...}}, got a JSON {type(data).__name__}'
        )
    changes, notes = {}, []
    for key, value in data.items():
        if key == "columns" and value is not None:
            if not isinstance(value, dict) or not all(isinstance(v, str) for v in value.values()):
                raise _fail(
                    name,
                    f"key 'columns': expected an object {{\"CANONICAL\": "
                    f'"SOURCE[UNIT]"}}, got {_brief(value)}',
                )
            continue
        if key not in SIDECAR_KEYS:
            notes.append(unknown_key_note(name, key))
            continue
        if value is None:
            continue
        changes[key] = _check_sidecar_value(key, value, name)
    return path, data, LOCO_22E.replace(**changes), tuple(notes)
