"""Shared pieces of the command line: user errors, JSON output, progress on stderr."""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np


from ..errors import InputError as UserError  # noqa: F401  (re-exported for command modules)


def require_at_least(command: str, least: int, **flags) -> None:
    """Raise :class:`UserError` for the first ``--flag`` (given, not None) whose value is below
    ``least``, e.g. ``require_at_least("sweep", 1, seeds=args.seeds)``."""
    for name, value in flags.items():
        if value is not None and value < least:
            raise UserError(f"{command}: --{name.replace('_', '-')} must be >= {least}, got {value}")


def _plain(obj):
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if hasattr(obj, "tolist"):
        return _plain(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def emit_json(document) -> None:
    """Write one JSON document on stdout (NumPy/JAX values converted; NaN/inf become null)."""
    json.dump(_plain(document), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")
    sys.stdout.flush()


class Progress:
    """A one-line progress counter on stderr with rate and ETA; silent when ``enabled`` is false."""

    def __init__(self, total: int, label: str, unit: str = "it", enabled: bool = True):
        self.total, self.label, self.unit, self.enabled = total, label, unit, enabled
        self.done = 0
        self.start = time.perf_counter()

    def update(self, n: int = 1) -> None:
        self.done += n
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        rate = self.done / elapsed if elapsed > 0 else float("nan")
        eta = (self.total - self.done) / rate if rate > 0 else float("nan")
        sys.stderr.write(f"\r{self.label}: {self.done}/{self.total} {self.unit} "
                         f"[{elapsed:6.1f} s, {rate:.3g} {self.unit}/s, ETA {eta:5.0f} s]")
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def table(rows, columns) -> str:
    """Format a list of dicts as a fixed-width text table."""
    def fmt(v):
        if isinstance(v, float):
            return f"{v:.4g}"
        if isinstance(v, (np.floating,)):
            return f"{float(v):.4g}"
        return str(v)

    cells = [[fmt(r.get(c, "")) for c in columns] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) if cells else len(c)
              for i, c in enumerate(columns)]
    lines = ["  ".join(c.rjust(w) for c, w in zip(columns, widths)),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(v.rjust(w) for v, w in zip(row, widths)) for row in cells]
    return "\n".join(lines)
