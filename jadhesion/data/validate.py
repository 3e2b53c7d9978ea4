"""Validation of a recording's canonical columns: layout, numbers, plausible magnitudes (SI units).
Messages name the user's column (``shown``: canonical → source name), the row and the line."""

from __future__ import annotations

from datetime import datetime, time, timezone
from typing import NamedTuple, Optional

import numpy as np

from ..errors import RecordingError
from ..models.kinematics import SPEED_FLOOR
from .units import UNITS, ColumnSpec, to_si
from .vehicle import Vehicle

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
#: Times [s] spanning more than this, in whole steps of 1 s or more, are likely ms (a note).
MS_DURATION = 10_000.0
#: A median time step [s] beyond this is no logger's rate (a time column in another unit).
MAX_TIME_STEP_S = 3600.0
#: Largest plausible vehicle acceleration [m/s²] (trains reach about 1.5; half of g is none's).
MAX_ACCELERATION = 5.0
#: The vehicle speed's change is judged on the medians of this many equal stretches of time, and
#: only over a change of at least MIN_SPEED_CHANGE [m/s] (beyond a sensor's noise and quantum).
ACCELERATION_BINS = 20
MIN_SPEED_CHANGE = 1.0
#: ... on recordings of at least this many samples (five per stretch).
MIN_ACCELERATION_SAMPLES = 5 * ACCELERATION_BINS


def largest_acceleration(t, v) -> tuple:
    """``(a, dv, dt)``: the largest |change| of the vehicle speed ``v`` [m/s] per time ``t`` [s]
    between the medians of :data:`ACCELERATION_BINS` equal stretches of the recording, over pairs
    whose speeds differ by at least :data:`MIN_SPEED_CHANGE` (robust to noise, quantisation and a
    spike); ``(0, 0, 0)`` when none do."""
    edges = np.linspace(t[0], t[-1], ACCELERATION_BINS + 1)
    which = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, ACCELERATION_BINS - 1)
    full = [k for k in range(ACCELERATION_BINS) if np.any(which == k)]
    mid = np.array([np.median(t[which == k]) for k in full])
    speed = np.array([np.median(v[which == k]) for k in full])
    dv = np.abs(speed[:, None] - speed[None, :])
    dt = np.abs(mid[:, None] - mid[None, :])
    rate = np.where((dv >= MIN_SPEED_CHANGE) & (dt > 0), dv / np.where(dt > 0, dt, 1.0), 0.0)
    i, j = np.unravel_index(np.argmax(rate), rate.shape)
    return float(rate[i, j]), float(dv[i, j]), float(dt[i, j])


#: Largest median wheel/vehicle speed ratio over the moving samples (and smallest, its inverse) of
#: a recording with both speeds in one unit: a median creepage of 50 %. Our simulator's, the
#: independent and the kinematic generators' recordings: medians 1.00–1.05 (99th percentiles up to
#: 1.67); a speed in another unit gives 1/r (rad/s), 60/(2πr) (rpm), 2.24 (mph) or 3.6 (km/h).
MAX_SPEED_RATIO = 1.5
#: Relative tolerance of :func:`speed_units`' match (km/h: ratios 3.2–4.0).
UNIT_RATIO_TOLERANCE = 0.11
#: Torque implying |mu| below this everywhere (but not all zero) is taken to be in kN·m.
MIN_TORQUE_MU = 1e-3
#: Torque implying |mu| above this somewhere is implausible (even with the wheelset's inertia).
MAX_TORQUE_MU = 3.0


def _fail(name: str, what: str) -> RecordingError:
    return RecordingError(f"{name}: {what}")


def _show(text: str, limit: int = 30) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "…")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


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
    # a file that names no column of a fitting dataset is taken for a recording of raw signals
    dataset_like = any(c in present for c in ("adhesion", "creepage", "slip_velocity"))
    missing = miss_ds if dataset_like else miss_raw
    listed = ", ".join(f"'{c}'" for c in missing)
    raise _fail(
        name,
        f"missing column{'s' if len(missing) > 1 else ''} {listed}: a recording needs "
        f"{', '.join(RAW_COLUMNS)} (raw signals) or vehicle_speed, adhesion and creepage "
        f"or slip_velocity (fitting dataset); present: {', '.join(header)}; map the file's "
        'columns with --column CANONICAL=SOURCE[UNIT] (or the sidecar\'s "columns")',
    )


#: What reads as a missing value in a CSV cell (case and spaces ignored; ``-`` as a row of ``-``
#: under the header is read, :func:`.readers._parse_rows`); in Parquet and MATLAB, NaN or null.
#: Spreadsheet error values (``#N/A``, ``#DIV/0!``…: a cell a formula could not fill) count too.
EXCEL_ERRORS = frozenset({"#n/a", "#value!", "#div/0!", "#ref!", "#name?", "#num!", "#null!"})
MISSING_CELLS = frozenset({"", "nan", "na", "n/a", "null", "-"}) | EXCEL_ERRORS
#: The end of an error about a missing value: the way to read past it.
_SKIP_HINT = "; --missing skip leaves such rows out (gaps in time)"
_REPEAT_HINT = "; --repeated-time drop keeps the first row of each repeated stamp"


class Rows(NamedTuple):
    """Where the rows read stand in the file: ``numbers``, 1-based among its data rows (the rows a
    ``--missing skip`` or ``--repeated-time drop`` keeps keep theirs), and ``lines``, a CSV's line
    numbers, or ``None`` (Parquet, .mat: no lines)."""

    numbers: np.ndarray
    lines: Optional[list]

    @classmethod
    def first(cls, n: int, lines=None) -> "Rows":
        """The ``n`` rows of a file as read (``lines``: theirs, or ``None``)."""
        return cls(np.arange(1, n + 1), lines)

    def at(self, i: int) -> str:
        """``"row N (line L)"`` of the ``i``-th row kept (``"row N"`` without lines)."""
        return f"row {int(self.numbers[i])}" + ("" if self.lines is None else f" (line {self.lines[i]})")

    def kept(self, keep) -> "Rows":
        """The rows ``keep`` (bool per row) leaves."""
        keep = np.asarray(keep, bool)
        lines = None if self.lines is None else [line for line, k in zip(self.lines, keep, strict=True) if k]
        return Rows(self.numbers[keep], lines)


def _convert_column(cells: np.ndarray, col: str, rows: Rows, name: str, strict: bool):
    """float64 values of one column; with ``strict``, the first bad cell raises a RecordingError."""
    try:
        values = cells.astype(np.float64)
    except ValueError:
        if not strict:
            return None
        for i, cell in enumerate(cells.tolist()):
            if not _is_number(cell):
                where = f"column {col!r}, {rows.at(i)}"
                if not cell.strip():
                    raise _fail(name, f"{where}: empty cell (missing value{_SKIP_HINT})") from None
                hint = f" (a missing value{_SKIP_HINT})" if cell.strip().lower() in MISSING_CELLS else ""
                raise _fail(name, f"{where}: {_show(cell)} is not a number{hint}") from None
        raise  # pragma: no cover  (numpy and float() disagree)
    if strict:
        _check_finite(values, col, name, rows, cells)
    return values


def _date_seconds(cell: str) -> float | None:
    """Seconds since the Unix epoch of an ISO 8601 date-time cell (``2026-05-01T08:00:00.010``,
    ``… 08:00:00Z``, ``…+01:00``; without an offset read as UTC), or ``None`` when it is not one."""
    try:
        stamp = datetime.fromisoformat(cell.strip())
    except ValueError:
        return None
    return (stamp if stamp.tzinfo else stamp.replace(tzinfo=timezone.utc)).timestamp()


def _clock_seconds(cell: str) -> float | None:
    """Seconds since midnight of an ISO 8601 time of day (``08:00:00.010``; an offset is ignored),
    or ``None`` when it is not one."""
    try:
        clock = time.fromisoformat(cell.strip())
    except ValueError:
        return None
    return clock.hour * 3600.0 + clock.minute * 60.0 + clock.second + clock.microsecond * 1e-6


#: Time stamps a CSV's time column may hold instead of numbers: (parser, one, several, seconds since).
_STAMPS = (
    (_date_seconds, "date-time", "date-times", "1970-01-01 UTC"),
    (_clock_seconds, "time of day", "times of day", "midnight"),
)


def convert_time_column(cells: np.ndarray, col: str, rows: Rows, name: str) -> tuple:
    """``(values [s], notes)`` of a CSV's time column: numbers as they are; ISO 8601 date-times as
    seconds since the Unix epoch (as Parquet timestamps are read) or times of day as seconds since
    midnight, the kind row 1 holds, with a note. The first bad cell raises a RecordingError naming
    its row and line (a day change in times of day: time not increasing)."""
    values = _convert_column(cells, col, rows, name, strict=False)
    if values is not None:
        _check_finite(values, col, name, rows, cells)
        return values, ()
    kind = next((k for k in _STAMPS if k[0](cells[0]) is not None), None)
    if kind is None:
        return _convert_column(cells, col, rows, name, strict=True), ()  # raises at the first bad cell
    parse, one, several, since = kind
    seconds = np.empty(len(cells))
    for i, cell in enumerate(cells.tolist()):
        value = parse(cell)
        if value is None:
            raise _fail(
                name,
                f"column {col!r}, {rows.at(i)}: {_show(cell)} is not an ISO 8601 "
                f"{one} like row 1's {_show(str(cells[0]))}",
            )
        seconds[i] = value
    return seconds, (f"{name}: column {col!r} read as ISO 8601 {several} (seconds since {since})",)


def _check_finite(values, col: str, name: str, rows: Optional[Rows] = None, cells=None):
    """Raise at the first NaN or inf of column ``col`` (the user's name for it). A CSV's error shows
    the cell's text and its line (``rows``, ``cells``); a binary format's (no lines; a Parquet null
    is NaN) shows the value."""
    bad = np.flatnonzero(~np.isfinite(values))
    if not bad.size:
        return
    i = int(bad[0])
    rows = Rows.first(len(values)) if rows is None else rows
    if rows.lines is None:
        raise _fail(
            name,
            f"column {col!r}, {rows.at(i)}: {values[i]} is not a "
            f"finite number (NaN, a missing value, and inf are not allowed"
            f"{_SKIP_HINT if np.isnan(values[i]) else ''})",
        )
    hint = _SKIP_HINT if np.isnan(values[i]) else ""
    raise _fail(
        name,
        f"column {col!r}, {rows.at(i)}: {_show(cells[i].strip())}"
        f" is not a finite number (NaN and inf are not allowed{hint})",
    )


def _ms_note(t, name: str, source: str) -> tuple:
    """A note when times ``t`` [s] look like ms: median step >= 1 s, every step a whole number
    (to 1e-3) and more than :data:`MS_DURATION` in all. Not an error: a 1 Hz logger looks so."""
    dt = np.diff(t)
    step, duration = float(np.median(dt)), float(t[-1] - t[0])
    if step < 1.0 or duration <= MS_DURATION or not np.allclose(dt, np.round(dt), rtol=0.0, atol=1e-3):
        return ()
    return (
        f"{name}: column {source!r}: median time step {step:.6g} s over {duration:.4g} s, every "
        f"step a whole number of seconds; looks like ms? map it with --column time={source}[ms] "
        f'(or the sidecar\'s "columns")',
    )


def speed_units(ratio: float, column: str, wheel_radius_m: float) -> list:
    """The units of ``column`` (:data:`.units.UNITS`: km/h and mph, and for ``wheel_speed`` rpm and
    rad/s through the wheel radius [m]; one spelling each) that would make it ``ratio`` (> 1) times
    the other speed in m/s, to within :data:`UNIT_RATIO_TOLERANCE`; closest first."""
    by_factor = {}  # values per m/s -> (first spelling, relative mismatch)
    for unit in UNITS[column]:
        factor = 1.0 / to_si(ColumnSpec(column, column, unit), wheel_radius_m)
        if factor != 1.0:
            by_factor.setdefault(factor, (unit, abs(ratio / factor - 1)))
    return [u for e, u in sorted((e, u) for u, e in by_factor.values()) if e <= UNIT_RATIO_TOLERANCE]


def _check_values(
    cols, vehicle: Vehicle, rows: Optional[Rows], name: str, max_speed: float, shown: dict
) -> tuple:
    """Raise at the first implausible value of ``cols`` (SI; ``shown``: the user's column names);
    return notes of likely unit slips that may be right (:func:`_ms_note`)."""
    notes = ()

    rows = Rows.first(len(next(iter(cols.values())))) if rows is None else rows

    def _where(col, i):
        return f"column {shown.get(col, col)!r}, {rows.at(i)}"

    if "time" in cols and len(cols["time"]) > 1:
        dt = np.diff(cols["time"])
        bad = np.flatnonzero(dt <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            t = cols["time"]
            raise _fail(
                name,
                f"{_where('time', i)}: time {t[i]:.10g} s is not after the "
                f"previous row's {t[i - 1]:.10g} s (time must strictly increase"
                f"{_REPEAT_HINT if t[i] == t[i - 1] else ''})",
            )
        source = shown.get("time", "time")
        step = float(np.median(dt))
        if step > MAX_TIME_STEP_S:
            raise _fail(
                name,
                f"column {source!r}: median time step {step:.4g} s, more than an hour: no logger's "
                f"rate; is it in another unit? map it with --column time={source}[ms] (or us, ns)",
            )
        notes = _ms_note(cols["time"], name, source)
    # first the pair's ratio: it tells which unit (rpm, rad/s) a speed beyond max_speed is in
    if "vehicle_speed" in cols and "wheel_speed" in cols:
        v, vw = cols["vehicle_speed"], cols["wheel_speed"]
        moving = np.abs(v) > 0.5
        if np.count_nonzero(moving) >= 10:
            ratio = float(np.median(vw[moving] / v[moving]))
            if ratio > MAX_SPEED_RATIO or 0 < ratio < 1 / MAX_SPEED_RATIO:
                fast = "wheel_speed" if ratio > 1 else "vehicle_speed"
                i = int(np.flatnonzero(moving)[0])
                where = (
                    f"{_where(fast, i)}: median wheel/vehicle speed ratio is {ratio:.4g} "
                    f"(creepage {ratio - 1:.3g})"
                )
                units = speed_units(max(ratio, 1 / ratio), fast, vehicle.wheel_radius_m)
                if units:
                    source = shown.get(fast, fast)
                    raise _fail(
                        name,
                        f"{where}; {fast} looks like {' or '.join(units)} while the other speed is "
                        f"m/s? map it with --column {fast}={source}[{units[0]}]",
                    )
                # a speed beyond max_speed: the check below names that column instead
                if max(np.max(np.abs(v)), np.max(np.abs(vw))) <= max_speed:
                    raise _fail(
                        name,
                        f"{where} over the moving samples: implausible for an adhesion recording (at "
                        f"most {MAX_SPEED_RATIO:g}, at least 1/{MAX_SPEED_RATIO:g}); are both speeds in "
                        "m/s? map them with --column CANONICAL=SOURCE[UNIT]",
                    )
    for col in ("vehicle_speed", "wheel_speed"):
        if col not in cols:
            continue
        bad = np.flatnonzero(np.abs(cols[col]) > max_speed)
        if bad.size:
            i = int(bad[0])
            raise _fail(
                name,
                f"{_where(col, i)}: {cols[col][i]:.6g} m/s exceeds the plausible "
                f"{max_speed:g} m/s; looks like km/h? map it with --column "
                f'{col}={shown.get(col, col)}[km/h] (or the sidecar\'s "columns")',
            )
    if "traction_torque" in cols:
        torque = np.abs(cols["traction_torque"])
        scale = vehicle.axle_weight_n * vehicle.wheel_radius_m  # N·m for mu = 1
        peak = float(np.max(torque))
        if 0.0 < peak < MIN_TORQUE_MU * scale:
            i = int(np.argmax(torque))
            raise _fail(
                name,
                f"{_where('traction_torque', i)}: the largest torque {peak:.4g} "
                f"implies mu = {peak / scale:.2g}; expected N·m at the wheelset — looks "
                f"like kN·m? map it with --column "
                f"traction_torque={shown.get('traction_torque', 'traction_torque')}[kN*m]",
            )
        bad = np.flatnonzero(torque > MAX_TORQUE_MU * scale)
        if bad.size:
            i = int(bad[0])
            raise _fail(
                name,
                f"{_where('traction_torque', i)}: torque "
                f"{cols['traction_torque'][i]:.4g} N·m implies mu = "
                f"{torque[i] / scale:.3g}, implausible for this axle "
                f"({vehicle.axle_load_kg:g} kg, r = {vehicle.wheel_radius_m:g} m)",
            )
    if "adhesion" in cols:
        bad = np.flatnonzero(np.abs(cols["adhesion"]) > MAX_ADHESION)
        if bad.size:
            i = int(bad[0])
            raise _fail(
                name,
                f"{_where('adhesion', i)}: adhesion coefficient "
                f"{cols['adhesion'][i]:.4g} is implausible (|mu| <= {MAX_ADHESION:g}); "
                f"a force or a percentage?",
            )
    # a given slip or creep no pair of plausible speeds makes (creep: slip over |v| floored at
    # SPEED_FLOOR, as the fit computes it); creepage 1e300 ran, online ended 'nonfinite'
    limits = {"slip_velocity": (2 * max_speed, " m/s"), "creepage": (2 * max_speed / SPEED_FLOOR, "")}
    for col, (limit, unit) in limits.items():
        bad = np.flatnonzero(np.abs(cols[col]) > limit) if col in cols else ()
        if len(bad):
            i = int(bad[0])
            raise _fail(
                name,
                f"{_where(col, i)}: {cols[col][i]:.4g}{unit} is implausible (|{col}| <= "
                f"{limit:g}{unit} with both speeds within {max_speed:g} m/s)",
            )
    # last: a value beyond its range says more than the acceleration it makes
    if "time" in cols and "vehicle_speed" in cols and len(cols["time"]) >= MIN_ACCELERATION_SAMPLES:
        acc, dv, span = largest_acceleration(cols["time"], cols["vehicle_speed"])
        if acc > MAX_ACCELERATION:
            source = shown.get("time", "time")
            raise _fail(
                name,
                f"column {source!r}: the vehicle speed changes by {dv:.3g} m/s in {span:.3g} s "
                f"({acc:.3g} m/s², beyond any train's {MAX_ACCELERATION:g}): is the time in "
                f"another unit? map it with --column time={source}[min] (or h), or check the "
                "speed's unit",
            )
    return notes
