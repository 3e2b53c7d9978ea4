"""Recordings: load, validate and save the recording CSV and its JSON sidecar (DESIGN §3).

A recording is a CSV file with a header row, SI units, one row a sample. Two layouts are accepted:

* **raw signals**: ``time`` [s], ``vehicle_speed`` [m/s], ``wheel_speed`` [m/s, circumferential at the
  nominal radius], ``traction_torque`` [N·m at the wheelset]; the adhesion observer turns them into
  ``mu_hat``;
* **fitting dataset**: ``vehicle_speed`` [m/s], ``adhesion`` [-] (observed mu) and ``creepage`` [-] or
  ``slip_velocity`` [m/s] (or, as an extension, ``wheel_speed``); no ``time`` column is needed.

Other columns are kept in :attr:`Recording.columns` when every cell is a number, and otherwise ignored;
they are never validated. Blank lines and lines starting with ``#`` are skipped. The optional sidecar
``<same stem>.json`` holds vehicle keys (:data:`~jadhesion.data.vehicle.SIDECAR_KEYS`); missing keys
take the 22E defaults, a JSON ``null`` means "default", unknown keys are ignored (listed in
:attr:`Recording.notes`), a wrong type or value is an error.

Validation raises :class:`~jadhesion.errors.RecordingError` with one line naming the file, the
column and the 1-based data row (and the file's line number), e.g.
``data.csv: column 'vehicle_speed', row 17 (line 18): 'abc' is not a number``. Checked: missing file,
directory, empty file, binary or non-UTF-8 content, missing header, duplicate/empty column names,
missing required columns, rows with the wrong number of fields, empty cells, text, NaN/inf, time not
strictly increasing, implausible magnitudes (speeds above :data:`MAX_SPEED` — km/h instead of m/s —,
wheel and vehicle speeds in different units, torque in kN·m, adhesion outside ±:data:`MAX_ADHESION`),
and a sidecar that is unreadable, not a JSON object, or has a key of the wrong type or value.

Sign conventions: negative vehicle and wheel speeds are **allowed** (running in reverse; creepage is
``w / max(|v|, floor)`` and both models are odd in creep), as are zero speeds (standstill) and
negative torque (braking). Only magnitudes are checked for plausibility.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import os
import re
from pathlib import Path
from typing import Optional

import numpy as np

from ..errors import RecordingError
from .units import ColumnSpec, parse_column_map, to_si
from .vehicle import LOCO_22E, SIDECAR_KEYS, Vehicle

#: Columns of a raw-signal recording.
RAW_COLUMNS = ("time", "vehicle_speed", "wheel_speed", "traction_torque")
#: Columns always needed by a fitting dataset, plus one of :data:`CREEP_COLUMNS`.
DATASET_COLUMNS = ("vehicle_speed", "adhesion")
CREEP_COLUMNS = ("creepage", "slip_velocity", "wheel_speed")
#: Columns that are always validated when present; any other column is carried along unchecked.
KNOWN_COLUMNS = frozenset(RAW_COLUMNS + DATASET_COLUMNS + CREEP_COLUMNS)
#: Largest plausible |speed| [m/s] (252 km/h, above any locomotive traction test). A larger value
#: almost always means the column is in km/h.
MAX_SPEED = 70.0
#: Largest plausible |adhesion coefficient| [-] (a larger value is a force or a percentage).
MAX_ADHESION = 1.5
#: Torque implying |mu| below this everywhere (but not all zero) is taken to be in kN·m.
MIN_TORQUE_MU = 1e-3
#: Torque implying |mu| above this somewhere is implausible (even with the wheelset's inertia).
MAX_TORQUE_MU = 3.0
#: Per-axle columns of a multi-axle file and their naming patterns (``--axle N``), first match wins.
AXLE_COLUMNS = ("wheel_speed", "traction_torque")
AXLE_PATTERNS = ("{name}_{n}", "{name}_axle{n}", "{name}{n}")
_BLANK_LINE = re.compile(r"\n[ \t\r]*\n")


@dataclasses.dataclass(frozen=True)
class Recording:
    """A validated recording.

    Attributes:
        path: the CSV file it was loaded from (or saved to).
        columns: every numeric column by header name, float64 arrays of equal length.
        vehicle: the locomotive, 22E defaults overridden by the sidecar.
        sidecar: the sidecar's JSON object as read (empty when there is none).
        notes: remarks that are not errors (ignored sidecar keys, ignored text columns).
        sources: the column map applied, ``{canonical: "SOURCE[UNIT]"}`` (empty when none).
    """

    path: Path
    columns: dict
    vehicle: Vehicle = LOCO_22E
    sidecar: dict = dataclasses.field(default_factory=dict)
    notes: tuple = ()
    sources: dict = dataclasses.field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def has_raw_signals(self) -> bool:
        return all(c in self.columns for c in RAW_COLUMNS)

    @property
    def has_adhesion(self) -> bool:
        return "adhesion" in self.columns


# ----------------------------------------------------------------------------------------- loading


def _fail(name: str, what: str) -> RecordingError:
    return RecordingError(f"{name}: {what}")


def _show(text: str, limit: int = 30) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "…")


def _read_text(path: Path, name: str, *, kind: str = "file") -> str:
    if not path.exists():
        raise _fail(name, f"{kind} not found")
    if path.is_dir():
        raise _fail(name, f"is a directory, not a {kind}")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise _fail(name, f"cannot read {kind}: {exc.strerror or exc}") from None
    nul = raw.find(b"\x00")
    if nul >= 0:
        raise _fail(name, f"binary data (NUL byte at byte {nul}), not a text {kind}")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise _fail(name, f"not UTF-8 text (undecodable byte 0x{raw[exc.start]:02x} at byte "
                          f"{exc.start}, line {line})") from None
    if not text.strip():
        raise _fail(name, f"{kind} is empty")
    return text


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_rows(text: str, name: str):
    """Header, data rows and their 1-based line numbers; skips blank and ``#`` lines."""
    header, rows, lines = None, [], []
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        for fields in reader:
            if not fields or (len(fields) == 1 and not fields[0].strip()):
                continue
            if fields[0].lstrip().startswith("#"):
                continue
            if header is None:
                header = [f.strip() for f in fields]
                header_line = reader.line_num
                continue
            rows.append(fields)
            lines.append(reader.line_num)
    except csv.Error as exc:
        raise _fail(name, f"line {reader.line_num}: malformed CSV ({exc})") from None
    if header is None:
        raise _fail(name, "no header row (only blank or comment lines)")
    if all(_is_number(f) for f in header):
        raise _fail(name, f"no header row: line {header_line} holds numbers; the first row must name "
                          f"the columns, e.g. {','.join(RAW_COLUMNS)}")
    for j, col in enumerate(header):
        if not col:
            raise _fail(name, f"header (line {header_line}): column {j + 1} has an empty name")
        if header.index(col) != j:
            raise _fail(name, f"header (line {header_line}): column {col!r} appears twice")
    if not rows:
        raise _fail(name, "no data rows after the header")
    width = len(header)
    counts = np.fromiter((len(r) for r in rows), dtype=np.int64, count=len(rows))
    bad = np.flatnonzero(counts != width)
    if bad.size:
        i = int(bad[0])
        raise _fail(name, f"row {i + 1} (line {lines[i]}): {counts[i]} fields, but the header names "
                          f"{width} columns")
    return header, rows, lines


def _fast_parse(text: str):
    """``(header, float64 columns, line numbers)`` by pyarrow's vectorised CSV reader, or ``None``
    when pyarrow is missing or the file is not plain (comments, quotes, blank lines, any cell that
    is not a finite number): the precise pass (:func:`_parse_rows`) then reads it and names the
    exact row and line of any error."""
    if "#" in text or '"' in text or _BLANK_LINE.search(text) or not text[:1].strip():
        return None
    try:  # optional dependency (extra ``parquet``): imported only when a CSV is read
        import pyarrow as pa
        from pyarrow import csv as pacsv
    except ImportError:
        return None
    first, _, body = text.partition("\n")
    header = [f.strip() for f in first.rstrip("\r").split(",")]
    if (not all(header) or len(set(header)) != len(header) or all(_is_number(f) for f in header)
            or not body.strip()):
        return None
    options = pacsv.ConvertOptions(column_types={h: pa.float64() for h in header}, null_values=[],
                                   strings_can_be_null=False, quoted_strings_can_be_null=False)
    try:
        table = pacsv.read_csv(io.BytesIO(body.encode()), convert_options=options,
                               read_options=pacsv.ReadOptions(column_names=header))
    except (pa.ArrowInvalid, ValueError):
        return None
    columns = [table.column(j).to_numpy() for j in range(len(header))]
    if not all(np.isfinite(c).all() for c in columns):
        return None
    return header, columns, range(2, table.num_rows + 2)


def _check_layout(header, name):
    """Raise unless the header holds the raw-signal or the fitting-dataset columns."""
    present = set(header)
    if all(c in present for c in RAW_COLUMNS):
        return
    if all(c in present for c in DATASET_COLUMNS) and any(c in present for c in CREEP_COLUMNS):
        return
    # Name what is missing from the layout the file is closest to.
    miss_raw = [c for c in RAW_COLUMNS if c not in present]
    miss_ds = [c for c in DATASET_COLUMNS if c not in present]
    if not any(c in present for c in CREEP_COLUMNS):
        miss_ds.append("creepage' or 'slip_velocity")
    missing = miss_ds if ("adhesion" in present or len(miss_ds) < len(miss_raw)) else miss_raw
    listed = ", ".join(f"'{c}'" for c in missing)
    raise _fail(name, f"missing column{'s' if len(missing) > 1 else ''} {listed}: a recording needs "
                      f"{', '.join(RAW_COLUMNS)} (raw signals) or vehicle_speed, adhesion and creepage "
                      f"or slip_velocity (fitting dataset); present: {', '.join(header)}")


def _convert_column(cells: np.ndarray, col: str, lines, name: str, strict: bool):
    """float64 values of one column; with ``strict``, the first bad cell raises a RecordingError."""
    try:
        values = cells.astype(np.float64)
    except ValueError:
        if not strict:
            return None
        for i, cell in enumerate(cells.tolist()):
            if not _is_number(cell):
                where = f"column {col!r}, row {i + 1} (line {lines[i]})"
                if not cell.strip():
                    raise _fail(name, f"{where}: empty cell (missing value)") from None
                raise _fail(name, f"{where}: {_show(cell)} is not a number") from None
        raise  # pragma: no cover  (numpy and float() disagree)
    if strict:
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            i = int(bad[0])
            raise _fail(name, f"column {col!r}, row {i + 1} (line {lines[i]}): {_show(cells[i].strip())}"
                              f" is not a finite number (NaN and inf are not allowed)")
    return values


def _check_values(cols, vehicle: Vehicle, lines, name: str, max_speed: float, shown: dict):
    def _where(col, i, lines):
        return f"column {shown.get(col, col)!r}, row {i + 1} (line {lines[i]})"

    if "time" in cols and len(cols["time"]) > 1:
        dt = np.diff(cols["time"])
        bad = np.flatnonzero(dt <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            t = cols["time"]
            raise _fail(name, f"{_where('time', i, lines)}: time {t[i]:.10g} s is not after the "
                              f"previous row's {t[i - 1]:.10g} s (time must strictly increase)")
    for col in ("vehicle_speed", "wheel_speed"):
        if col not in cols:
            continue
        bad = np.flatnonzero(np.abs(cols[col]) > max_speed)
        if bad.size:
            i = int(bad[0])
            raise _fail(name, f"{_where(col, i, lines)}: {cols[col][i]:.6g} m/s exceeds the plausible "
                              f"{max_speed:g} m/s; looks like km/h? map it with --column "
                              f"{col}={shown.get(col, col)}[km/h] (or the sidecar's \"columns\")")
    if "vehicle_speed" in cols and "wheel_speed" in cols:
        v, vw = cols["vehicle_speed"], cols["wheel_speed"]
        moving = np.abs(v) > 0.5
        if np.count_nonzero(moving) >= 10:
            ratio = float(np.median(vw[moving] / v[moving]))
            if 3.2 <= ratio <= 4.0 or 1 / 4.0 <= ratio <= 1 / 3.2:
                slow = "vehicle_speed" if ratio > 1 else "wheel_speed"
                fast = "wheel_speed" if ratio > 1 else "vehicle_speed"
                i = int(np.flatnonzero(moving)[0])
                raise _fail(name, f"{_where(fast, i, lines)}: median wheel/vehicle speed ratio is "
                                  f"{ratio:.3g} (creepage {ratio - 1:.3g}); {fast} looks like km/h "
                                  f"while {slow} is m/s? map it with --column "
                                  f"{fast}={shown.get(fast, fast)}[km/h]")
    if "traction_torque" in cols:
        torque = np.abs(cols["traction_torque"])
        scale = vehicle.axle_weight_n * vehicle.wheel_radius_m  # N·m for mu = 1
        peak = float(np.max(torque))
        if 0.0 < peak < MIN_TORQUE_MU * scale:
            i = int(np.argmax(torque))
            raise _fail(name, f"{_where('traction_torque', i, lines)}: the largest torque {peak:.4g} "
                              f"implies mu = {peak / scale:.2g}; expected N·m at the wheelset — looks "
                              f"like kN·m? map it with --column "
                              f"traction_torque={shown.get('traction_torque', 'traction_torque')}[kN*m]")
        bad = np.flatnonzero(torque > MAX_TORQUE_MU * scale)
        if bad.size:
            i = int(bad[0])
            raise _fail(name, f"{_where('traction_torque', i, lines)}: torque "
                              f"{cols['traction_torque'][i]:.4g} N·m implies mu = "
                              f"{torque[i] / scale:.3g}, implausible for this axle "
                              f"({vehicle.axle_load_kg:g} kg, r = {vehicle.wheel_radius_m:g} m)")
    if "adhesion" in cols:
        bad = np.flatnonzero(np.abs(cols["adhesion"]) > MAX_ADHESION)
        if bad.size:
            i = int(bad[0])
            raise _fail(name, f"{_where('adhesion', i, lines)}: adhesion coefficient "
                              f"{cols['adhesion'][i]:.4g} is implausible (|mu| <= {MAX_ADHESION:g}); "
                              f"a force or a percentage?")


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
            raise _fail(name, f"{where}: expected a string, got {type(value).__name__} "
                              f"{_brief(value)}")
        return value
    if kind is list:  # contact_semi_axes_m
        ok = (isinstance(value, list) and len(value) == 2
              and all(_finite(x) and x > 0 for x in value))
        if not ok:
            raise _fail(name, f"{where}: expected two positive numbers [a, b] in metres, got "
                              f"{json.dumps(value)}")
        return (float(value[0]), float(value[1]))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(name, f"{where}: expected a number, got {type(value).__name__} "
                          f"{_brief(value)}")
    if not _finite(value):
        raise _fail(name, f"{where}: {_brief(value)} is not a finite number")
    if key == "poisson_ratio":
        if not 0.0 <= value < 0.5:
            raise _fail(name, f"{where}: {value} is outside [0, 0.5)")
    elif value <= 0:
        raise _fail(name, f"{where}: {value} must be positive")
    return float(value)


def _load_sidecar(csv_path: Path):
    path = csv_path.with_suffix(".json")
    if not path.exists():
        return path, {}, LOCO_22E, ()
    name = str(path)
    text = _read_text(path, name, kind="sidecar")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise _fail(name, f"sidecar is not valid JSON (line {exc.lineno}, column {exc.colno}: "
                          f"{exc.msg})") from None
    except RecursionError:
        raise _fail(name, "sidecar is not valid JSON (nested too deeply)") from None
    if not isinstance(data, dict):
        raise _fail(name, f"sidecar must be a JSON object {{\"key\": value, ...}}, got a JSON "
                          f"{type(data).__name__}")
    changes, notes = {}, []
    for key, value in data.items():
        if key == "columns" and value is not None:
            if not isinstance(value, dict) or not all(isinstance(v, str) for v in value.values()):
                raise _fail(name, f"key 'columns': expected an object {{\"CANONICAL\": "
                                  f"\"SOURCE[UNIT]\"}}, got {_brief(value)}")
            continue
        if key not in SIDECAR_KEYS:
            notes.append(f"{name}: unknown key {key!r} ignored")
            continue
        if value is None:
            continue
        changes[key] = _check_sidecar_value(key, value, name)
    return path, data, LOCO_22E.replace(**changes), tuple(notes)


def _column_map(columns, sidecar: dict, sidecar_name: str, header, name: str, axle):
    """``{canonical: ColumnSpec}``: the sidecar's ``columns`` overridden by ``columns`` (--column);
    with ``axle`` N, unmapped ``wheel_speed``/``traction_torque`` come from the first present of
    ``{name}_{N}``, ``{name}_axle{N}``, ``{name}{N}``."""
    specs = parse_column_map([f"{k}={v}" for k, v in (sidecar.get("columns") or {}).items()],
                             f"{sidecar_name}: key 'columns':")
    specs.update(parse_column_map(columns or (), "--column"))
    if axle is not None:
        if isinstance(axle, bool) or not isinstance(axle, int) or axle < 1:
            raise _fail(name, f"--axle {axle}: expected an axle number >= 1")
        for canonical in AXLE_COLUMNS:
            if canonical in specs:
                continue
            names = [p.format(name=canonical, n=axle) for p in AXLE_PATTERNS]
            found = [c for c in names if c in header]
            if not found:
                raise _fail(name, f"--axle {axle}: no column {' or '.join(map(repr, names))} in the "
                                  f"file (columns: {', '.join(header)}); map it with --column")
            specs[canonical] = ColumnSpec(canonical, found[0])
    for spec in specs.values():
        if spec.source not in header:
            raise _fail(name, f"--column {spec.canonical}={spec.source}: no column {spec.source!r} "
                              f"in the file (columns: {', '.join(header)})")
    return specs


def load_recording(path, *, columns=(), axle=None, max_speed: float = MAX_SPEED) -> Recording:
    """Load and validate a recording CSV and its optional sidecar ``<same stem>.json``.

    Args:
        path: the CSV file.
        columns: ``CANONICAL=SOURCE[UNIT]`` strings (:mod:`jadhesion.data.units`), applied over the
            sidecar's ``columns`` map; values are converted to SI, errors name the source column.
        axle: pick this axle's wheel speed and torque from a multi-axle file
            (:data:`AXLE_PATTERNS`, overridable by the column map).
        max_speed: largest plausible |speed| [m/s]; larger values are reported as km/h.

    Raises:
        RecordingError: one line naming the file, column and row, and what is wrong.
    """
    path = Path(path)
    name = str(path)
    text = _read_text(path, name)
    fast = _fast_parse(text)
    if fast is None:
        header, rows, lines = _parse_rows(text, name)
        cells = np.array(rows, dtype=str)
    else:
        header, parsed, lines = fast
    sidecar_path, sidecar, vehicle, notes = _load_sidecar(path)
    specs = _column_map(columns, sidecar, str(sidecar_path), header, name, axle)
    by_source = {spec.source: spec for spec in specs.values()}
    shadowed = [c for c in header if c in specs and c not in by_source]
    if shadowed:
        notes += (f"{name}: column{'s' if len(shadowed) > 1 else ''} "
                  f"{', '.join(map(repr, shadowed))} replaced by the column map",)
    renamed = [by_source[c].canonical if c in by_source else (None if c in shadowed else c)
               for c in header]
    shown = {spec.canonical: spec.source for spec in specs.values()}
    _check_layout([c for c in renamed if c is not None], name)
    required = [c for c in renamed if c in KNOWN_COLUMNS]
    columns = {}
    ignored = []
    for j, col in enumerate(renamed):
        if col is None:
            continue
        values = parsed[j] if fast is not None else _convert_column(
            cells[:, j], shown.get(col, col), lines, name, strict=col in required)
        if values is None:
            ignored.append(col)
        else:
            spec = specs.get(col)
            columns[col] = values if spec is None else values * to_si(spec, vehicle.wheel_radius_m)
    if ignored:
        notes += (f"{name}: non-numeric column{'s' if len(ignored) > 1 else ''} "
                  f"{', '.join(map(repr, ignored))} ignored",)
    with np.errstate(all="ignore"):  # differences of huge finite values may overflow to inf
        _check_values({c: columns[c] for c in required}, vehicle, lines, name, max_speed, shown)
    return Recording(path=path, columns=columns, vehicle=vehicle, sidecar=sidecar, notes=notes,
                     sources={c: str(specs[c].source) + (f"[{specs[c].unit}]" if specs[c].unit else "")
                              for c in specs})


# ------------------------------------------------------------------------------------------ saving


def vehicle_sidecar(vehicle: Vehicle) -> dict:
    """The sidecar keys of ``vehicle`` as a JSON-ready dict (keys whose value is ``None`` left out)."""
    out = {}
    for key in SIDECAR_KEYS:
        value = getattr(vehicle, key)
        if value is None:
            continue
        out[key] = [float(x) for x in value] if key == "contact_semi_axes_m" else value
    return out


def atomic_write(path: Path, write) -> None:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it over ``path`` (the
    project's one atomic writer: a reader never sees a half-written file)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def save_recording(columns, vehicle: Vehicle = LOCO_22E, path="recording.csv",
                   extra_sidecar: Optional[dict] = None) -> Path:
    """Write ``columns`` as a recording CSV and the vehicle's sidecar ``<same stem>.json``.

    Values are written in Python's shortest round-trip notation, so :func:`load_recording` reads back
    exactly the same float64 values. Both files are written atomically (temporary file, then
    rename). ``extra_sidecar`` entries (JSON-serialisable) are added to the sidecar, e.g. the
    scenario and true parameters of a simulation; they override vehicle keys of the same name.

    Args:
        columns: mapping of column name to 1-D array-likes of equal length (float64 on disk).
        vehicle: written as its :data:`SIDECAR_KEYS`.
        path: the CSV file; the sidecar goes beside it.

    Returns:
        The CSV path.

    Raises:
        ValueError: empty, ragged or non-1-D columns, or a name that cannot be a CSV header.
    """
    path = Path(path)
    if not columns:
        raise ValueError("save_recording: no columns")
    names = list(columns)
    arrays = [np.asarray(columns[c], dtype=np.float64) for c in names]
    for c, a in zip(names, arrays):
        if not isinstance(c, str) or not c.strip() or c != c.strip() or any(ch in c for ch in ',"\r\n#'):
            raise ValueError(f"save_recording: column name {c!r} cannot be a CSV header")
        if a.ndim != 1:
            raise ValueError(f"save_recording: column {c!r} has shape {a.shape}, expected 1-D")
        if len(a) != len(arrays[0]):
            raise ValueError(f"save_recording: column {c!r} has {len(a)} rows, "
                             f"{names[0]!r} has {len(arrays[0])}")
    sidecar = vehicle_sidecar(vehicle)
    if extra_sidecar:
        sidecar.update(extra_sidecar)
    sidecar_text = json.dumps(sidecar, indent=2, allow_nan=False) + "\n"
    lists = [a.tolist() for a in arrays]
    buf = io.StringIO()
    buf.write(",".join(names) + "\n")
    buf.writelines(",".join(map(repr, row)) + "\n" for row in zip(*lists))
    atomic_write(path, lambda tmp: tmp.write_text(buf.getvalue(), encoding="utf-8", newline=""))
    atomic_write(path.with_suffix(".json"),
                 lambda tmp: tmp.write_text(sidecar_text, encoding="utf-8", newline=""))
    return path
