"""``jadhesion inspect FILE``: what a recording holds before any fit — duration, rate and jitter,
gaps, ranges of speed, creep and μ̂, the stretches selected and excluded, and what the data can
identify; ``--plot DIR`` writes the overview figure.

This module defines the arguments only; :mod:`.inspect_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS
from .recording_options import add_recording_options


def register(sub) -> None:
    p = sub.add_parser("inspect", help=COMMANDS["inspect"])
    p.add_argument("file", help="recording (CSV, Parquet or MATLAB .mat)")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.add_argument(
        "--plot",
        metavar="DIR",
        default=None,
        help="write inspect.png (signals with the excluded stretches shaded, μ̂ against creep) into DIR",
    )
    add_recording_options(p)
    p.set_defaults(handler="jadhesion.cli.inspect_run:run")
