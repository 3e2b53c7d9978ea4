"""Binary recording formats: Parquet (pyarrow, extra ``parquet``) and MATLAB ``.mat`` v5 (scipy)
and v7.3 (HDF5, h5py; extra ``mat``). :func:`read_columns` gives ``(header, columns)`` — the
names in file order and float64 arrays (``None`` for a column that is not numeric) — which
:func:`jadhesion.data.recording.load_recording` maps, converts and validates like a CSV's.

* **Parquet**: one column a signal; integer, float and boolean columns are numeric (a null is
  NaN, reported as not finite by the validation; an integer beyond 2**53 rounded to float64),
  timestamp and duration columns are seconds (a timestamp's since the epoch, float64, as a CSV's
  ISO 8601 date-times; any unit, ns included, rounded once), others are ignored.
* **.mat**: one variable a signal, a numeric vector (``n×1`` or ``1×n``); the row count is the
  length most variables share; scalars, matrices and vectors of another length are ignored (listed
  in the notes, a vector with its length); a complex vector is a column that is not numeric (named
  as complex in the notes); ``__header__``-style entries and v7.3's ``#refs#`` are skipped. A
  struct (v7.3: a group) stands for its fields, at any depth: each is named by its field name, or
  ``struct.field`` where two share a name.

The optional packages are imported only here, only when such a file is read; a missing one is a
one-line error naming the extra to install.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from .validate import _fail

#: File suffixes read by this module (lower case).
PARQUET_SUFFIXES = (".parquet", ".pq")
MAT_SUFFIXES = (".mat",)
#: Suffixes of text recordings (comma, semicolon or tab separated: :mod:`.readers`).
TEXT_SUFFIXES = (".csv", ".tsv", ".txt")
#: Every recording's suffix: the files a directory stands for. A file named alone is read as text
#: whatever its suffix, unless it is one of this module's.
RECORDING_SUFFIXES = TEXT_SUFFIXES + PARQUET_SUFFIXES + MAT_SUFFIXES
_TICKS_PER_SECOND = {"s": 1, "ms": 10**3, "us": 10**6, "ns": 10**9}


def _missing(name: str, package: str, extra: str):
    return _fail(name, f"reading this format needs {package}: install jadhesion[{extra}]")


def _seconds(ticks, unit: str) -> np.ndarray:
    """Seconds [s], float64, of int64 ``ticks`` (a pyarrow array) in ``unit``; a null is NaN. Whole
    seconds and the remainder are converted apart, so a ns epoch (~1.8e18 ticks, beyond float64's
    2**53) is rounded once, to float64 seconds (steps of ~2.4e-7 s today), not first to 256 ns."""
    per = _TICKS_PER_SECOND[unit]
    whole, rest = np.divmod(np.asarray(ticks.fill_null(0).to_numpy(), dtype=np.int64), per)
    seconds = whole.astype(np.float64) + rest / per
    seconds[ticks.is_null().to_numpy(zero_copy_only=False)] = np.nan
    return seconds


def _parquet(path: Path, name: str):
    try:  # optional dependency (extra ``parquet``)
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise _missing(name, "pyarrow", "parquet") from None
    try:
        table = pq.read_table(path)
    except (pa.ArrowException, OSError) as exc:
        raise _fail(name, f"not a readable Parquet file ({str(exc).splitlines()[0]})") from None
    header, columns = [], []
    for field, column in zip(table.schema, table.columns, strict=True):
        header.append(field.name)
        t = field.type
        if pa.types.is_integer(t) or pa.types.is_floating(t) or pa.types.is_boolean(t):
            values = column.cast(pa.float64(), safe=False).to_numpy(zero_copy_only=False)
            columns.append(np.asarray(values, dtype=np.float64))
        elif pa.types.is_timestamp(t) or pa.types.is_duration(t):
            columns.append(_seconds(column.cast(pa.int64()), t.unit))
        else:
            columns.append(None)
    return header, columns, ()


def _unreadable_mat(name: str, exc: Exception):
    reason = (str(exc).splitlines() or [type(exc).__name__])[0]
    return _fail(name, f"not a readable MATLAB .mat file ({reason})")


def _complex(arr: np.ndarray) -> np.ndarray:
    """A v7.3 complex variable (HDF5 compound of ``real`` and ``imag``) as a complex array."""
    if arr.dtype.names is not None and set(arr.dtype.names) == {"real", "imag"}:
        return arr["real"] + 1j * arr["imag"]
    return arr


def _listed(keys) -> str:
    return f"variable{'s' if len(keys) > 1 else ''} {', '.join(map(repr, keys))}"


def _scipy_fields(key: str, value) -> list:
    """``[(path, array)]`` of a scipy.io variable: itself, or a 1×1 struct's fields at any depth
    (``path`` a tuple of names)."""
    value = np.asarray(value)
    if value.dtype.names is None or value.size != 1:
        return [((key,), value)]
    record = value.reshape(-1)[0]
    return [((key, *sub), v) for f in value.dtype.names for sub, v in _scipy_fields(f, record[f])]


def _short_names(variables: list) -> dict:
    """``{name: array}``: each field by its last name, or dotted in full where two share it."""
    last = Counter(path[-1] for path, _ in variables)
    return {(path[-1] if last[path[-1]] == 1 else ".".join(path)): v for path, v in variables}


def _mat_variables(path: Path, name: str) -> dict:
    try:  # optional dependency (extra ``mat``)
        import h5py
    except ImportError:
        h5py = None
    if h5py is not None and h5py.is_hdf5(path):  # MATLAB v7.3
        found = []

        def dataset(key, obj):
            if isinstance(obj, h5py.Dataset) and not key.startswith("#"):
                found.append((tuple(key.split("/")), _complex(np.asarray(obj))))

        try:
            with h5py.File(path, "r") as f:
                f.visititems(dataset)
            return _short_names(found)
        except OSError as exc:  # h5py's error for a truncated or corrupt HDF5 file
            raise _unreadable_mat(name, exc) from None
    try:
        import scipy.io
        from scipy.io.matlab import MatReadError
    except ImportError:
        raise _missing(name, "scipy", "mat") from None
    try:
        data = scipy.io.loadmat(path)
    except NotImplementedError:  # v7.3 without h5py
        raise _missing(name, "h5py (MATLAB v7.3 files)", "mat") from None
    except (MatReadError, ValueError, OSError, TypeError) as exc:  # MatReadError: empty or truncated
        raise _unreadable_mat(name, exc) from None
    return _short_names([f for k, v in data.items() if not k.startswith("__") for f in _scipy_fields(k, v)])


def _mat(path: Path, name: str):
    variables = _mat_variables(path, name)
    vectors = {}
    skipped = []
    for key, value in variables.items():
        arr = np.asarray(value)
        if arr.dtype.kind in "iufbc" and arr.ndim <= 2 and arr.size >= 2 and min(arr.shape) == 1:
            vectors[key] = arr.reshape(-1)
        else:
            skipped.append(key)
    if not vectors:
        raise _fail(name, "no numeric vector variables in the .mat file (one variable a signal, n×1 or 1×n)")
    n = Counter(v.size for v in vectors.values()).most_common(1)[0][0]
    header = [k for k in vectors if vectors[k].size == n]
    complex_ = [k for k in header if vectors[k].dtype.kind == "c"]
    notes = (f"{name}: {_listed(skipped)} ignored (not a numeric vector)",) if skipped else ()
    for size in sorted({v.size for v in vectors.values()} - {n}):
        keys = [k for k, v in vectors.items() if v.size == size]
        has = "has" if len(keys) == 1 else "have"
        notes += (f"{name}: {_listed(keys)} {has} {size} values, the others {n}: ignored",)
    if complex_:
        notes += (f"{name}: {_listed(complex_)} complex, not read (a signal must be real)",)
    columns = [None if k in complex_ else vectors[k].astype(np.float64) for k in header]
    return header, columns, notes


def is_binary(path: Path) -> bool:
    """Whether ``path``'s suffix names a format of this module."""
    return path.suffix.lower() in PARQUET_SUFFIXES + MAT_SUFFIXES


def read_columns(path: Path, name: str):
    """``(header, columns, notes)`` of a Parquet or .mat file (module docstring)."""
    if not path.exists():
        raise _fail(name, "file not found")
    if path.is_dir():
        raise _fail(name, "is a directory, not a file")
    if not path.is_file():  # the binary readers seek: a stream cannot be one of these formats
        raise _fail(name, "not a regular file (a device, pipe or socket); save it to a file")
    reader = _parquet if path.suffix.lower() in PARQUET_SUFFIXES else _mat
    header, columns, notes = reader(path, name)
    if not header:
        raise _fail(name, "no columns")
    if columns and all(c is not None and c.size == 0 for c in columns):
        raise _fail(name, "no data rows")
    return header, columns, notes
