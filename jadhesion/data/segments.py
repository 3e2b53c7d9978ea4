"""Segments of a recording: the time window ``--start/--end`` [s], applied before the observer
stage so that the observer runs on one contiguous stretch."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import RecordingError


def trim(recording, start=None, end=None):
    """The samples with ``start <= time <= end`` [s] (either bound optional), as a new Recording.

    Raises:
        RecordingError: a bound that is not finite, ``start >= end``, no ``time`` column, or no
            sample in the window; the line names the file and the flag.
    """
    if start is None and end is None:
        return recording
    name = str(recording.path)
    for flag, value in (("--start", start), ("--end", end)):
        if value is not None and not np.isfinite(value):
            raise RecordingError(f"{name}: {flag} {value}: expected a finite time in seconds")
    if start is not None and end is not None and start >= end:
        raise RecordingError(f"{name}: --start {start:g} s is not before --end {end:g} s")
    if "time" not in recording.columns:
        raise RecordingError(f"{name}: --start/--end need a time column (map one with --column "
                             f"time=SOURCE[s])")
    t = recording.columns["time"]
    keep = np.ones(t.shape, bool)
    if start is not None:
        keep &= t >= start
    if end is not None:
        keep &= t <= end
    if keep.sum() < 2:
        raise RecordingError(f"{name}: --start/--end select {int(keep.sum())} sample(s); the "
                             f"recording runs from {t[0]:g} s to {t[-1]:g} s")
    return dataclasses.replace(recording, columns={k: v[keep] for k, v in recording.columns.items()})
