"""The sweep's tidy table: one row per fit, as a dict of equal-length NumPy columns.

CSV always (floats written with ``repr``, so a round trip is exact); Parquet when ``pyarrow`` is
installed and the file name ends in ``.parquet``. Every write is atomic (temporary file, then
rename), so a reader never sees half a file and an interrupted sweep leaves no corrupt part.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..atomic import atomic_write
from ..errors import InputError
from ..models.polach import PARAM_NAMES

COORDINATES = ("scenario", "method", "seed", "noise_scale", "creep_max")
#: Column order of the table; ``status`` is the fit's :class:`jadhesion.status.Status` label
#: (``converged``, ``max_steps``, …).
COLUMNS = (
    COORDINATES
    + ("samples",)
    + tuple(f"true_{p}" for p in PARAM_NAMES)
    + PARAM_NAMES
    + (
        "mae",
        "status",
        "iterations",
        "evaluations",
        "seconds",
        "true_mu_max",
        "mu_max",
        "true_creep_opt",
        "creep_opt",
    )
)
_STR = {"scenario", "method", "status"}
_INT = {"seed", "samples", "iterations", "evaluations"}


def _dtype(column):
    return str if column in _STR else np.int64 if column in _INT else np.float64


def concat(tables) -> dict:
    """Rows of several tables, in order."""
    tables = list(tables)
    return {c: np.concatenate([np.asarray(t[c], dtype=_dtype(c)) for t in tables]) for c in COLUMNS}


def _cell(value):
    return repr(float(value)) if isinstance(value, (float, np.floating)) else str(value)


def _write_csv(table, path):
    with open(path, "w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(COLUMNS)
        columns = [table[c] for c in COLUMNS]
        out.writerows([_cell(col[i]) for col in columns] for i in range(len(columns[0])))


def _pyarrow():
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        raise InputError(
            "sweep: writing .parquet needs pyarrow (pip install pyarrow); use a .csv output instead"
        ) from None
    return pyarrow


def check_format(path) -> None:
    """Raise :class:`InputError` now if ``path`` could not be written later (Parquet sans pyarrow)."""
    if Path(path).suffix == ".parquet":
        _pyarrow()


def write_table(table: dict, path) -> Path:
    """Write ``table`` to ``path`` (Parquet if it ends in ``.parquet``, else CSV), atomically."""
    path = Path(path)
    if path.suffix == ".parquet":
        pa = _pyarrow()
        arrow = pa.table({c: np.asarray(table[c], dtype=_dtype(c)) for c in COLUMNS})
        atomic_write(path, lambda p: pa.parquet.write_table(arrow, p))
    else:
        atomic_write(path, lambda p: _write_csv(table, p))
    return path


def read_table(path) -> dict:
    """Read a table written by :func:`write_table` (CSV or Parquet)."""
    path = Path(path)
    if path.suffix == ".parquet":
        arrow = _pyarrow().parquet.read_table(path)
        return {c: arrow.column(c).to_numpy(zero_copy_only=False).astype(_dtype(c)) for c in COLUMNS}
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or tuple(rows[0]) != COLUMNS:
        raise InputError(f"{path}: not a sweep table (header differs from the expected columns)")
    body = rows[1:]
    return {c: np.array([r[j] for r in body], dtype=_dtype(c)) for j, c in enumerate(COLUMNS)}
