"""Options shared by every command that reads a recording: the column map (``--column``), the axle
of a multi-axle file (``--axle``), what a missing value (``--missing``) and a repeated time stamp
(``--repeated-time``) do, the time window
(``--start/--end``) and the phase of the samples used (``--phase``).

Arguments only (no JAX, so ``--help`` stays instant); :mod:`.loading` applies them."""

from __future__ import annotations

#: Phases offered (:data:`jadhesion.data.segments.PHASES`; literal so ``--help`` imports no data code).
PHASES = ("traction", "braking", "both")
#: Missing-value policies offered (:data:`jadhesion.data.recording.MISSING_POLICIES`; literal, as PHASES).
MISSING = ("error", "skip")
#: Repeated-time policies offered (:data:`jadhesion.data.recording.REPEATED_TIME_POLICIES`; literal).
REPEATED_TIME = ("error", "drop")
#: Laws of the true slip offered (:data:`jadhesion.identify.likelihood.SLIP_LAWS`; literal, as PHASES).
SLIP_LAWS = ("normal", "population")


def add_recording_options(parser) -> None:
    """Add ``--column CANONICAL=SOURCE[UNIT]`` (repeatable), ``--axle``, ``--missing``,
    ``--repeated-time``, ``--start``, ``--end`` and ``--phase`` to a command's parser."""
    parser.add_argument(
        "--column",
        action="append",
        default=[],
        metavar="CANONICAL=SOURCE[UNIT]",
        help="read a canonical column from the file's SOURCE column in UNIT, e.g. "
        "vehicle_speed=v_Lok_kmh[km/h]; a header 'SOURCE [UNIT]' is found by SOURCE "
        '(repeatable; overrides the sidecar\'s "columns")',
    )
    parser.add_argument(
        "--axle",
        type=int,
        default=None,
        metavar="N",
        help="take wheel_speed and traction_torque of axle N from a multi-axle file "
        "(columns wheel_speed_N, wheel_speed_axleN or wheel_speedN, likewise "
        "traction_torque)",
    )
    parser.add_argument(
        "--missing",
        choices=MISSING,
        default="error",
        help="a row with an empty, NaN, NA, null or '-' cell in a column used: error (default: one line "
        "naming it) or skip (the row is left out, a gap in time; a note counts them)",
    )
    parser.add_argument(
        "--repeated-time",
        choices=REPEATED_TIME,
        default="error",
        help="a row whose time stamp equals the previous row's (a duplicated row, or stamps coarser "
        "than the rate): error (default: one line naming it) or drop (the first row of each stamp "
        "kept; a note counts the others and how many differ from it)",
    )
    parser.add_argument(
        "--start",
        type=float,
        default=None,
        metavar="SECONDS",
        help="use the samples from this time on [s, as recorded]",
    )
    parser.add_argument(
        "--end",
        type=float,
        default=None,
        metavar="SECONDS",
        help="use the samples up to this time [s, as recorded]",
    )
    parser.add_argument(
        "--phase",
        choices=PHASES,
        default="traction",
        help="samples used: traction (default: moving, torque driving), braking "
        "(negative torque and creep) or both; standstill, coasting, direction "
        "changes and stretches between gaps too short are excluded and reported",
    )


def add_slip_law_option(parser) -> None:
    """Add ``--slip-law`` (:data:`SLIP_LAWS`) to a command that fits Polach's curve."""
    parser.add_argument(
        "--slip-law",
        choices=SLIP_LAWS,
        default="normal",
        help="law of the true slip given the smoothed one in the errors-in-variables curve: normal "
        "(default) about the smoothed slip, sign-truncated; population: the recording's own slips "
        "(deconvolved) as the prior, for steady runs whose slips crowd within a few of their sds "
        "(README: 'Which slip law'); no effect with --creep raw",
    )


def add_single_law_option(parser, intervals: str) -> None:
    """Add ``--single-law``: the command's ``intervals`` (help text, ``%`` doubled for argparse)
    under ``--slip-law`` alone, without the LM fit under the other law whose intervals they join."""
    parser.add_argument(
        "--single-law",
        action="store_true",
        help=f"{intervals} under --slip-law alone: skip the LM fit under the other slip law whose "
        "intervals they join by default (smoothed creep, Polach: the data cannot tell which law holds)",
    )
