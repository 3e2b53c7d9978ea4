"""CSV reading: the file's text, its header and data rows with their line numbers; a vectorised
pass (pyarrow) for plain files and a precise pass that names the exact row and line of any error.

A units row directly under the header (``s,km/h,rpm,kN*m``: every cell a unit of
:data:`~.units.UNITS` or empty, one a unit other than ``-``) is read as if each header were
``name [unit]`` and skipped. Quoted numbers with a decimal comma in a comma-separated file
(``"0,489"``) are read with a decimal point once one cell shows the comma cannot group thousands."""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from .units import UNIT_KEYS, UNITS, same_unit, split_unit, unit_key
from .validate import EXCEL_ERRORS, RAW_COLUMNS, _fail, _is_number

_BLANK_LINE = re.compile(r"\n[ \t\r]*\n")
#: A point that groups thousands before a decimal comma (``25.472,08``, ``1.234.567,5``).
_THOUSANDS_POINT = re.compile(r"(?<=\d)\.(?=\d{3}(?:\.\d{3})*,\d)")
#: Any point between digits followed by groups of three (a thousands point, in such a file).
_GROUP_POINT = re.compile(r"(?<=\d)\.(?=\d{3}(?:\.\d{3})*(?![\d.]))")
#: A number with one decimal comma and no point (``0,489``, ``-1,5e-3``, ``,5``).
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?(\d*),(\d+)(?:[eE][+-]?\d+)?\s*$")


#: Most bytes read from a stream (``/dev/stdin``, a pipe, a device) [B].
STREAM_LIMIT = 1 << 30
_CHUNK = 1 << 20


def _read_stream(path: Path, name: str) -> bytes:
    """The bytes of a file that is not a regular one, read in chunks up to :data:`STREAM_LIMIT`;
    stops at the first chunk with a NUL byte (binary: reported by the caller), so ``/dev/zero``
    costs one chunk instead of the machine's memory."""
    parts, size = [], 0
    with path.open("rb") as stream:
        while chunk := stream.read(_CHUNK):
            parts.append(chunk)
            size += len(chunk)
            if b"\x00" in chunk:
                break
            if size > STREAM_LIMIT:
                raise _fail(name, f"more than {STREAM_LIMIT >> 30} GiB from a stream; save it to a file")
    return b"".join(parts)


def _read_text(path: Path, name: str, *, kind: str = "file") -> str:
    if not path.exists():
        raise _fail(name, f"{kind} not found")
    if path.is_dir():
        raise _fail(name, f"is a directory, not a {kind}")
    try:
        raw = path.read_bytes() if path.is_file() else _read_stream(path, name)
    except OSError as exc:
        raise _fail(name, f"cannot read {kind}: {exc.strerror or exc}") from None
    nul = raw.find(b"\x00")
    if nul >= 0:
        raise _fail(name, f"binary data (NUL byte at byte {nul}), not a text {kind}")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise _fail(
            name, f"not UTF-8 text (undecodable byte 0x{raw[exc.start]:02x} at byte {exc.start}, line {line})"
        ) from None
    if not text.strip():
        raise _fail(name, f"{kind} is empty")
    return text


def header_line(text: str) -> str:
    """The first line that is neither blank nor a ``#`` comment ('' when there is none)."""
    for line in text.splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            return line
    return ""


def normalise_delimiter(text: str) -> tuple[str, tuple]:
    """``(text, notes)``: a semicolon-separated file (European spreadsheets and loggers, with
    decimal commas) or a tab-separated one rewritten as comma-separated with decimal points, so
    every reader and every error's line number stay as they are. Sniffed from the header line:
    more ``;`` (or tabs) than commas; a tab-separated file's commas are decimal commas. Comma-
    separated text comes back unchanged."""
    header = header_line(text)
    commas = header.count(",")
    if header.count(";") > commas:
        note = "read as semicolon-separated, commas as decimal points"
        if _THOUSANDS_POINT.search(text):  # '25.472,08' as a German spreadsheet writes 25472.08
            text = _GROUP_POINT.sub("", text)  # and so '1.500' is 1500 there
            note += ", points between digit groups as thousands separators"
        return text.replace(",", ".").replace(";", ","), (note,)
    if header.count("\t") > commas:
        if "," in text:
            note = "read as tab-separated, commas as decimal points"
            return text.replace(",", ".").replace("\t", ","), (note,)
        return text.replace("\t", ","), ("read as tab-separated",)
    return text, ()


def _is_units_row(fields) -> bool:
    """Whether every cell is a unit of :data:`~.units.UNITS` or empty, and one is a unit other
    than ``-`` (a row of ``-`` is a row of missing values)."""
    units = [unit_key(f) for f in fields if f.strip()]
    return any(u != "-" for u in units) and all(u in UNIT_KEYS for u in units)


def _decimal_commas(rows, lines, name: str) -> tuple[list, tuple]:
    """``(rows, notes)`` with quoted decimal-comma numbers (:data:`_DECIMAL_COMMA`) written with a
    point, when one of them cannot be a thousands group (a leading 0 or none, more than three
    digits before the comma, or other than three after it); when every one could (``"1,500"``:
    1.5 or 1500?), the first raises."""
    found = [(i, j) for i, row in enumerate(rows) for j, cell in enumerate(row) if _DECIMAL_COMMA.match(cell)]
    if not found:
        return rows, ()
    parts = (_DECIMAL_COMMA.match(rows[i][j]).groups() for i, j in found)
    if not any(len(after) != 3 or len(before) > 3 or before.lstrip("0") != before for before, after in parts):
        i, j = found[0]
        raise _fail(
            name,
            f"row {i + 1} (line {lines[i]}), column {j + 1}: {rows[i][j].strip()!r} is a decimal comma or a "
            "thousands separator; write the numbers with a decimal point",
        )
    rows = [list(row) for row in rows]
    for i, j in found:
        rows[i][j] = rows[i][j].replace(",", ".")
    return rows, ("quoted numbers with decimal commas read with decimal points",)


def _with_unit(column: str, cell: str, name: str, line: int) -> str:
    """``column [unit]`` for a units-row ``cell`` (``column`` when empty, or when the header
    states that unit already); a header stating another unit raises."""
    unit = unit_key(cell)
    stated = split_unit(column)[1]
    if not unit or (stated is not None and any(same_unit(c, stated, unit) for c in UNITS)):
        return column
    if stated is not None:
        raise _fail(
            name,
            f"column {column!r}, units row (line {line}): {cell.strip()!r}, but the header says {stated!r}",
        )
    return f"{column} [{unit}]"


def _parse_rows(text: str, name: str):
    """Header, data rows, their 1-based line numbers and notes; skips blank and ``#`` lines (not a
    row whose first cell is a spreadsheet error such as ``#N/A``: a missing value), an
    unnamed last column without a value in any row (a delimiter ending every line) and a units row
    (:func:`_is_units_row`) after the header, its units joined to the header's names; reads quoted
    decimal commas (:func:`_decimal_commas`)."""
    header, rows, lines = None, [], []
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        for fields in reader:
            if not fields or (len(fields) == 1 and not fields[0].strip()):
                continue
            first = fields[0].strip()
            if first.startswith("#") and first.lower() not in EXCEL_ERRORS:  # '#N/A' is a value
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
        raise _fail(
            name,
            f"no header row: line {header_line} holds numbers; the first row must name "
            f"the columns, e.g. {','.join(RAW_COLUMNS)}",
        )
    while len(header) > 1 and not header[-1] and all(len(r) < len(header) or not r[-1].strip() for r in rows):
        header.pop()  # a delimiter ending every line (Excel, SAP): no column
        rows = [r[: len(header)] for r in rows]
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
        raise _fail(
            name, f"row {i + 1} (line {lines[i]}): {counts[i]} fields, but the header names {width} columns"
        )
    if _is_units_row(rows[0]):
        header = [_with_unit(h, f, name, lines[0]) for h, f in zip(header, rows[0], strict=True)]
        if len(rows) == 1:
            raise _fail(name, f"no data rows after the units row (line {lines[0]})")
        rows, lines = rows[1:], lines[1:]
    rows, notes = _decimal_commas(rows, lines, name)
    return header, rows, lines, notes


def _float_column(column) -> np.ndarray:
    """A pyarrow float64 column without nulls as a NumPy array, read from its chunks' data
    buffers: pyarrow's ``to_numpy`` imports pandas whenever it is installed, 0.2 s of CPU in every
    ``fit`` process (measured, benchmarks/bench_startup.py) for a reader that never uses it."""
    parts = [np.frombuffer(c.buffers()[1], np.float64, len(c), c.offset * 8) for c in column.chunks if len(c)]
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


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
    if (
        not all(header)
        or len(set(header)) != len(header)
        or all(_is_number(f) for f in header)
        or not body.strip()
    ):
        return None
    options = pacsv.ConvertOptions(
        column_types={h: pa.float64() for h in header},
        null_values=[],
        strings_can_be_null=False,
        quoted_strings_can_be_null=False,
    )
    try:
        table = pacsv.read_csv(
            io.BytesIO(body.encode()),
            convert_options=options,
            # One thread: pyarrow's CSV thread pool can abort the interpreter at exit when torn
            # down with a worker alive (apache/arrow#34314; measured: 2 of 88 `fit` processes
            # that stopped on an input error exited 134 under load).
            read_options=pacsv.ReadOptions(column_names=header, use_threads=False),
        )
    except (pa.ArrowInvalid, ValueError):
        return None
    if any(table.column(j).null_count for j in range(len(header))):
        return None
    columns = [_float_column(table.column(j)) for j in range(len(header))]
    if not all(np.isfinite(c).all() for c in columns):
        return None
    return header, columns, range(2, table.num_rows + 2)
