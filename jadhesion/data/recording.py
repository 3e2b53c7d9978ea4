"""Recordings: load, validate and save the recording CSV and its JSON sidecar (DESIGN §3).

A recording is a CSV file with a header row, SI units, one row a sample. Two layouts are accepted
(canonical names match ignoring case when no header is spelled exactly so; a header may state its
unit, ``vehicle_speed [km/h]``: :mod:`.units`):

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

Validation (:mod:`.validate`) raises :class:`~jadhesion.errors.RecordingError` with one line
naming the file, the column and the 1-based data row (and the file's line number), e.g.
``data.csv: column 'vehicle_speed', row 17 (line 18): 'abc' is not a number``. Checked: missing file,
directory, empty file, binary or non-UTF-8 content, missing header, duplicate/empty column names,
missing required columns, rows with the wrong number of fields, empty cells, text, NaN/inf, time not
strictly increasing, implausible magnitudes (speeds above :data:`~.validate.MAX_SPEED` — km/h
instead of m/s —, wheel and vehicle speeds in different units, torque in kN·m, adhesion outside
±:data:`~.validate.MAX_ADHESION`), and a sidecar that is unreadable, not a JSON object, or has a
key of the wrong type or value.

Sign conventions: negative vehicle and wheel speeds are **allowed** (running in reverse; creepage is
``w / max(|v|, floor)`` and both models are odd in creep), as are zero speeds (standstill) and
negative torque (braking). Only magnitudes are checked for plausibility.
"""

import dataclasses
import io
import json
from pathlib import Path
from typing import Optional

import numpy as np

from ..atomic import atomic_write
from ..errors import RecordingError
from .formats import is_binary, read_columns
from .readers import _fast_parse, _parse_rows, _read_text, normalise_delimiter
from .sidecar import _load_sidecar
from .units import UNITS, ColumnSpec, parse_column_map, same_unit, split_unit, to_si
from .validate import (
    KNOWN_COLUMNS,
    MAX_SPEED,
    MISSING_CELLS,
    RAW_COLUMNS,
    Rows,
    _check_finite,
    _check_layout,
    _check_values,
    _convert_column,
    _fail,
    convert_time_column,
)
from .vehicle import LOCO_22E, SIDECAR_KEYS, Vehicle

#: Per-axle columns of a multi-axle file and their naming patterns (``--axle N``), first match wins.
AXLE_COLUMNS = ("wheel_speed", "traction_torque")
AXLE_PATTERNS = ("{name}_{n}", "{name}_axle{n}", "{name}{n}")


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


def _both(columns) -> str:
    """``columns 'a' and 'b' both match`` (``all`` for more)."""
    listed = ", ".join(map(repr, columns[:-1])) + f" and {columns[-1]!r}"
    return f"columns {listed} {'both' if len(columns) == 2 else 'all'} match"


def _find_column(spec: ColumnSpec, header, name: str) -> tuple[str, ColumnSpec]:
    """The file's column for ``spec`` and the spec with its unit: the header ``SOURCE``, else the
    one header ``SOURCE[UNIT]`` or ``SOURCE [UNIT]`` in the spec's unit (or the header's, when the
    spec gives none; the spec's, when the header's is not a unit of the column)."""
    table = UNITS[spec.canonical]
    if spec.source in header:
        stated = split_unit(spec.source)[1] if spec.unit is None else None
        if stated is None:
            return spec.source, spec
        if stated in table:  # 'Speed (km/h)' named in full: its header's unit, not SI
            return spec.source, spec._replace(unit=stated)
        raise _fail(
            name,
            f"--column {spec.canonical}={spec.text()}: the header states {stated!r}, not a unit of "
            f"{spec.canonical} ({', '.join(table)}); give its unit, --column "
            f"{spec.canonical}={spec.source}[UNIT]",
        )
    found, hints = [], []
    for column in header:
        source, unit = split_unit(column)
        if source != spec.source or unit is None:
            continue
        if unit in table and spec.unit is not None and not same_unit(spec.canonical, unit, spec.unit):
            hints.append(f"column {column!r} is in {unit}, not {spec.unit}")
        elif unit in table or spec.unit is not None:
            found.append((column, spec._replace(unit=spec.unit or unit)))
        else:
            hints.append(
                f"column {column!r}: {unit!r} is not a unit of {spec.canonical}; give its unit, "
                f"--column {spec.canonical}={source}[UNIT]"
            )
    where = f"--column {spec.canonical}={spec.text()}"
    if len(found) > 1:
        raise _fail(name, f"{where}: {_both([c for c, _ in found])}; rename one")
    if not found:
        raise _fail(
            name,
            f"{where}: no column {spec.source!r} in the file (columns: {', '.join(header)})"
            + "".join(f"; {h}" for h in hints),
        )
    return found[0]


def _column_map(columns, sidecar: dict, sidecar_name: str, header, name: str, axle):
    """``(specs, shown, hints)``. ``specs``, ``{canonical: ColumnSpec}``: the sidecar's ``columns``
    overridden by ``columns`` (--column); with ``axle`` N, unmapped ``wheel_speed``/``traction_torque``
    from the first present of ``{name}_{N}``, ``{name}_axle{N}``, ``{name}{N}``; then each other
    canonical column the file names in another case or with its unit (:mod:`.units`). ``shown``:
    the file's column of each (:func:`_find_column`); ``hints``: why a header like a canonical
    name was not taken (ambiguous, or a unit not of that column)."""
    specs = parse_column_map(
        [f"{k}={v}" for k, v in (sidecar.get("columns") or {}).items()], f"{sidecar_name}: key 'columns':"
    )
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
                raise _fail(
                    name,
                    f"--axle {axle}: no column {' or '.join(map(repr, names))} in the "
                    f"file (columns: {', '.join(header)}); map it with --column",
                )
            specs[canonical] = ColumnSpec(canonical, found[0])
    shown = {}
    for canonical, spec in specs.items():
        shown[canonical], specs[canonical] = _find_column(spec, header, name)
    hints = []
    for canonical in UNITS:
        if canonical in specs or canonical in header:
            continue
        near = [c for c in header if c not in shown.values() and split_unit(c)[0].lower() == canonical]
        if len(near) > 1:
            hints.append(
                f"{_both(near)} {canonical!r} ignoring case and unit: "
                f"map one with --column {canonical}=SOURCE"
            )
            continue
        source, unit = split_unit(near[0]) if near else (None, None)
        if near and unit is not None and unit not in UNITS[canonical]:
            hints.append(
                f"column {near[0]!r}: {unit!r} is not a unit of {canonical} "
                f"({', '.join(UNITS[canonical])}); map it with --column {canonical}={source}[UNIT]"
            )
        elif near:
            specs[canonical], shown[canonical] = ColumnSpec(canonical, source, unit), near[0]
    return specs, shown, hints


#: How :func:`load_recording` treats a row with a missing value in a column it uses.
MISSING_POLICIES = ("error", "skip")
#: How :func:`load_recording` treats a row whose time stamp repeats the previous row's.
REPEATED_TIME_POLICIES = ("error", "drop")


def _missing_cells(idx, cells=None, parsed=None) -> np.ndarray:
    """(rows, len(idx)) bool: the missing values (:data:`MISSING_CELLS` in a CSV's ``cells``, NaN
    in a binary format's ``parsed`` columns; a column that is not numeric has none: it is refused
    later) of the columns ``idx``."""
    if cells is not None:
        return np.isin(np.char.lower(np.char.strip(cells[:, idx])), list(MISSING_CELLS))
    n = len(next(a for a in parsed if a is not None))
    return np.stack([np.zeros(n, bool) if parsed[j] is None else np.isnan(parsed[j]) for j in idx], axis=1)


def _skip_missing(hole, shown_names, positions: Rows, name: str) -> tuple:
    """``(rows kept, notes)`` for ``missing="skip"``: every row without a missing value
    (:func:`_missing_cells`), and a note counting the others and naming the first (where it
    stands in the file: ``positions``)."""
    keep = ~hole.any(axis=1)
    rows = np.flatnonzero(~keep)
    if not rows.size:
        return keep, ()
    if not keep.any():
        raise _fail(name, f"every row has a missing value in {', '.join(map(repr, shown_names))}")
    first, col = int(rows[0]), int(np.flatnonzero(hole[rows[0]])[0])
    where = positions.at(first)
    return keep, (
        f"{name}: {rows.size} of {hole.shape[0]} rows skipped for a missing value (--missing skip; "
        f"the first at {where}, column {shown_names[col]!r}): each is a gap in time",
    )


def _drop_repeated_time(columns: dict, required, positions: Rows, name: str, shown: dict) -> tuple:
    """``(columns, positions, notes)`` for ``repeated_time="drop"``: the first row of every run of equal
    time stamps kept (a logger's duplicated row, or a stamp coarser than its rate), the others
    dropped, and a note counting them, naming the first and saying how many differ from the row
    kept in a column used. A time that goes back stays an error (:func:`._check_values`)."""
    t = columns["time"]
    repeat = np.r_[False, np.diff(t) == 0]
    if not repeat.any():
        return columns, positions, ()
    kept_row = np.maximum.accumulate(np.where(repeat, 0, np.arange(len(t))))  # each row's run head
    differ = np.zeros(len(t), bool)
    for c in required:
        differ |= columns[c] != columns[c][kept_row]
    rows = np.flatnonzero(repeat)
    first = int(rows[0])
    where = positions.at(first)
    n_differ = int(differ[rows].sum())
    copies = f"{n_differ} differ{'s' * (n_differ == 1)} from the row kept" if n_differ else "all exact copies"
    note = (
        f"{name}: {rows.size} of {len(t)} rows dropped for repeating the previous row's time stamp in "
        f"column {shown.get('time', 'time')!r} (--repeated-time drop; the first at {where}; {copies})"
    )
    keep = ~repeat
    return {c: v[keep] for c, v in columns.items()}, positions.kept(keep), (note,)


def load_recording(
    path,
    *,
    columns=(),
    axle=None,
    max_speed: float = MAX_SPEED,
    missing: str = "error",
    repeated_time: str = "error",
) -> Recording:
    """Load and validate a recording (CSV, or by suffix Parquet ``.parquet``/``.pq`` and MATLAB
    ``.mat`` v5/v7.3, :mod:`jadhesion.data.formats`) and its optional sidecar
    ``<same stem>.json``; every format gets the same column map, units and validation.

    Args:
        path: the recording file.
        columns: ``CANONICAL=SOURCE[UNIT]`` strings (:mod:`jadhesion.data.units`), applied over the
            sidecar's ``columns`` map; values are converted to SI, errors name the source column.
        axle: pick this axle's wheel speed and torque from a multi-axle file
            (:data:`AXLE_PATTERNS`, overridable by the column map).
        max_speed: largest plausible |speed| [m/s]; larger values are reported as km/h.
        missing: a row with a missing value (:data:`MISSING_CELLS`; NaN or null in Parquet and
            MATLAB) in a column the recording uses: ``"error"`` (the first one named) or
            ``"skip"`` (the row left out, a gap in time, with a note counting them).
        repeated_time: a row whose time stamp equals the previous row's: ``"error"`` (named) or
            ``"drop"`` (the first row of each stamp kept, with a note counting the others and how
            many of them differ from it).

    Raises:
        RecordingError: one line naming the file, column and row, and what is wrong.
    """
    if missing not in MISSING_POLICIES:
        raise ValueError(f"load_recording: missing must be one of {MISSING_POLICIES}, got {missing!r}")
    if repeated_time not in REPEATED_TIME_POLICIES:
        raise ValueError(
            f"load_recording: repeated_time must be one of {REPEATED_TIME_POLICIES}, got {repeated_time!r}"
        )
    path = Path(path)
    name = str(path)
    if is_binary(path):  # Parquet or .mat: numeric columns (None: not numeric), no line numbers
        header, parsed, read_notes = read_columns(path, name)
        fast, lines = True, None
        # why a variable was not read (another length, complex): said with the error it causes
        unread = [n.removeprefix(f"{name}: ") for n in read_notes]
    else:
        text, delimiter_notes = normalise_delimiter(_read_text(path, name))
        fast, read_notes = _fast_parse(text), tuple(f"{name}: {n}" for n in delimiter_notes)
        if fast is None:
            header, rows, lines, row_notes = _parse_rows(text, name)
            read_notes += tuple(f"{name}: {n}" for n in row_notes)
            cells = np.array(rows, dtype=str)
        else:
            header, parsed, lines = fast
        unread = []
    n_rows = len(rows) if fast is None else next((len(a) for a in parsed if a is not None), 0)
    positions = Rows.first(n_rows, lines)  # where each row kept stands in the file
    sidecar_path, sidecar, vehicle, notes = _load_sidecar(path)
    notes += read_notes
    specs, shown, hints = _column_map(columns, sidecar, str(sidecar_path), header, name, axle)
    by_column = {shown[c]: spec for c, spec in specs.items()}
    shadowed = [c for c in header if c in specs and c not in by_column]
    if shadowed:
        notes += (
            f"{name}: column{'s' if len(shadowed) > 1 else ''} "
            f"{', '.join(map(repr, shadowed))} replaced by the column map",
        )
    renamed = [by_column[c].canonical if c in by_column else (None if c in shadowed else c) for c in header]
    try:
        _check_layout([c for c in renamed if c is not None], name)
    except RecordingError as exc:
        raise RecordingError("; ".join([str(exc), *hints, *unread])) from None
    notes += tuple(f"{name}: {h}" for h in hints)
    required = [c for c in renamed if c in KNOWN_COLUMNS]
    if missing == "skip":
        idx = [j for j, c in enumerate(renamed) if c in required]
        names = [shown.get(renamed[j], renamed[j]) for j in idx]
        hole = _missing_cells(idx, cells if fast is None else None, None if fast is None else parsed)
        keep, skipped = _skip_missing(hole, names, positions, name)
        notes += skipped
        if skipped:
            positions = positions.kept(keep)
            if fast is None:
                cells = cells[keep]
            else:
                parsed = [None if a is None else np.asarray(a)[keep] for a in parsed]
    columns = {}
    ignored = []
    for j, col in enumerate(renamed):
        if col is None:
            continue
        if fast is not None:
            values = parsed[j]
        elif col == "time":
            values, time_notes = convert_time_column(cells[:, j], shown.get(col, col), positions, name)
            notes += time_notes
            if time_notes and specs.get(col) is not None and specs[col].unit not in (None, "s"):
                raise _fail(
                    name,
                    f"column {shown[col]!r} holds time stamps, read in seconds: map it without "
                    f"the unit [{specs[col].unit}]",
                )
        else:
            values = _convert_column(
                cells[:, j], shown.get(col, col), positions, name, strict=col in required
            )
        if values is None and positions.lines is None and col in required:
            source = shown.get(col, col)
            why = [n for n in unread if repr(source) in n]
            raise _fail(name, "; ".join([f"column {source!r}: not numeric", *why]))
        if values is None:
            ignored.append(col)
        else:
            spec = specs.get(col)
            columns[col] = values if spec is None else values * to_si(spec, vehicle.wheel_radius_m)
    if positions.lines is None:  # a CSV's cells were checked as they were converted
        for c in required:
            if c in columns:
                _check_finite(columns[c], shown.get(c, c), name)
    if ignored:
        notes += (
            f"{name}: non-numeric column{'s' if len(ignored) > 1 else ''} "
            f"{', '.join(map(repr, ignored))} ignored",
        )
    if repeated_time == "drop" and "time" in columns:
        columns, positions, dropped = _drop_repeated_time(columns, required, positions, name, shown)
        notes += dropped
    with np.errstate(all="ignore"):  # differences of huge finite values may overflow to inf
        notes += _check_values({c: columns[c] for c in required}, vehicle, positions, name, max_speed, shown)
    return Recording(
        path=path,
        columns=columns,
        vehicle=vehicle,
        sidecar=sidecar,
        notes=notes,
        sources={c: spec.text() for c, spec in specs.items()},
    )


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


def save_recording(
    columns, vehicle: Vehicle = LOCO_22E, path="recording.csv", extra_sidecar: Optional[dict] = None
) -> Path:
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
    for c, a in zip(names, arrays, strict=True):
        if not isinstance(c, str) or not c.strip() or c != c.strip() or any(ch in c for ch in ',"\r\n#'):
            raise ValueError(f"save_recording: column name {c!r} cannot be a CSV header")
        if a.ndim != 1:
            raise ValueError(f"save_recording: column {c!r} has shape {a.shape}, expected 1-D")
        if len(a) != len(arrays[0]):
            raise ValueError(
                f"save_recording: column {c!r} has {len(a)} rows, {names[0]!r} has {len(arrays[0])}"
            )
    sidecar = vehicle_sidecar(vehicle)
    if extra_sidecar:
        sidecar.update(extra_sidecar)
    sidecar_text = json.dumps(sidecar, indent=2, allow_nan=False) + "\n"
    lists = [a.tolist() for a in arrays]
    buf = io.StringIO()
    buf.write(",".join(names) + "\n")
    buf.writelines(",".join(map(repr, row)) + "\n" for row in zip(*lists, strict=True))
    atomic_write(path, lambda tmp: tmp.write_text(buf.getvalue(), encoding="utf-8", newline=""))
    atomic_write(
        path.with_suffix(".json"), lambda tmp: tmp.write_text(sidecar_text, encoding="utf-8", newline="")
    )
    return path
