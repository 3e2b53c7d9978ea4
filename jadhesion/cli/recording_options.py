"""Options shared by every command that reads a recording: the column map (``--column``)."""

from __future__ import annotations


def add_recording_options(parser) -> None:
    """Add ``--column CANONICAL=SOURCE[UNIT]`` (repeatable) to a command's parser."""
    parser.add_argument("--column", action="append", default=[], metavar="CANONICAL=SOURCE[UNIT]",
                        help="read a canonical column from the file's SOURCE column in UNIT, e.g. "
                             "vehicle_speed=v_Lok_kmh[km/h] (repeatable; overrides the sidecar's "
                             "\"columns\")")


def load_from_args(args, path):
    """The :class:`~jadhesion.data.recording.Recording` at ``path`` with the options in ``args``."""
    # The data layer imports JAX: kept out of the module top so that ``--help`` stays instant.
    from ..data.recording import load_recording

    return load_recording(path, columns=args.column)
