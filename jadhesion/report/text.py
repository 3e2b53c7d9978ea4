"""Plain-text tables for the reports of experiments and for the command line's output."""

from __future__ import annotations

import numbers


def _cell(value) -> str:
    if value is None:  # no value: said as a dash, not Python's "None"
        return "-"
    if isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral):
        return f"{float(value):.4g}"
    return str(value)


def table(rows, columns) -> str:
    """Format a list of dicts as a fixed-width text table: right-aligned columns, a header and a
    rule; real numbers (Python or NumPy floats) with 4 significant digits, ``None`` as ``-``,
    anything else by ``str``, a missing key as an empty cell."""
    cells = [[_cell(r.get(c, "")) for c in columns] for r in rows]
    widths = [
        max(len(c), *(len(row[i]) for row in cells)) if cells else len(c) for i, c in enumerate(columns)
    ]
    lines = [
        "  ".join(c.rjust(w) for c, w in zip(columns, widths, strict=True)),
        "  ".join("-" * w for w in widths),
    ]
    lines += ["  ".join(v.rjust(w) for v, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(lines)
