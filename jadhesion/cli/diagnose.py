"""``jadhesion diagnose FILE [--json] [--report DIR]``: the missing physics behind a misfit.

JSON keys (DESIGN §3): ``verdict`` — the primary effect (a catalogue name) or ``"none"``, always a
string; ``effects`` — the accepted effects in order (0, 1 or 2; with two, ``verdict`` is the first);
``candidates`` (name, params, mae, heldout_mae, delta_bic, gain, sse_reduction, status, p_value,
evidence), ``indistinguishable``, ``base`` and ``extended`` (params, mae, heldout_mae, status),
``generic``, ``null`` (replicas, level, the recording's torque noise model and error share γ, critical
statistic), ``verdict_set``, ``warnings`` (code, message: unconverged fits — their candidates'
``p_value`` is null — and a null at its widest),
``selection`` (the samples used: ``--phase``, ``--start``/``--end``), ``explanation``, ``seconds``.

This module defines the arguments only; :mod:`.diagnose_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS
from .recording_options import add_recording_options

#: The most ``--replicas``: enough to reject at 0.1 % (p ≥ 1/(R + 1)); each replica is a fit and
#: a torque series held in memory, and --replicas 10**20 never ended.
MAX_REPLICAS = 999


def register(sub) -> None:
    p = sub.add_parser("diagnose", help=COMMANDS["diagnose"])
    p.add_argument("file", help="recording (CSV, Parquet or .mat with the raw signals)")
    p.add_argument(
        "--report", metavar="DIR", default=None, help="write a Markdown report with figures into DIR"
    )
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.add_argument(
        "--replicas",
        type=int,
        default=19,
        metavar="R",
        help="clean re-synthesised replicas of the recording's null (default 19, the fewest that "
        f"can reject at 5 %%; at most {MAX_REPLICAS}; 0 skips the null and decides on the held-out "
        "gain alone)",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="seed of the null's replicas, 0 to 2**63 - 1 (default 0)"
    )
    add_recording_options(p)
    p.set_defaults(handler="jadhesion.cli.diagnose_run:run")
