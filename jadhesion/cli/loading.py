"""Load the recording a command names, with the shared options of :mod:`.recording_options`."""

from __future__ import annotations

from ..data.recording import Recording, load_recording
from ..data.segments import trim


def load_from_args(args, path) -> Recording:
    """The :class:`~jadhesion.data.recording.Recording` at ``path`` with ``--column``, ``--axle``,
    ``--start`` and ``--end`` from ``args`` applied."""
    return trim(load_recording(path, columns=args.column, axle=args.axle), args.start, args.end)
