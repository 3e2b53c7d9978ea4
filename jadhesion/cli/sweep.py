"""``jadhesion sweep``: simulate → observe → fit over a grid, one row per fit (see :mod:`..sweeps`).

Several machines: start one process per node with ``--distributed`` (SLURM/Open MPI/… detected by
``jax.distributed.initialize()``) or with ``--coordinator HOST:PORT --num-processes P --process-id
I``; every process takes its share of the chunks and process 0 merges the table. ``out`` must be on
a file system all processes share.

This module defines the arguments only; :mod:`.sweep_run` does the work.
"""

from __future__ import annotations

import argparse

from . import COMMANDS
from .common import MAX_ITER

#: The most ``--seeds``: a million data seeds per cell (the grid holds them all; 3e9 ran out of
#: memory before the first fit).
MAX_SEEDS = 1_000_000


def register(sub) -> None:
    """Add the ``sweep`` subcommand to ``sub`` (argparse subparsers)."""
    p = sub.add_parser("sweep", help=COMMANDS["sweep"], description=COMMANDS["sweep"])
    p.add_argument(
        "--scenarios", default="dry,wet,sand", help="comma-separated scenarios (default dry,wet,sand)"
    )
    p.add_argument(
        "--seeds", type=int, default=10, help=f"data seeds 0..N-1, N at most {MAX_SEEDS} (default 10)"
    )
    p.add_argument(
        "--methods", default="lm", help="comma-separated fitting methods: lm, itlbo, tlbo, pso (default lm)"
    )
    p.add_argument(
        "--noise",
        default="1",
        help="comma-separated noise scales around the true curve, each 0 to 10 (default 1 = as simulated)",
    )
    p.add_argument(
        "--creep-max",
        default="inf",
        help="comma-separated creep ranges covered by the test, 'inf' = all samples (default inf)",
    )
    p.add_argument(
        "--pop-size",
        type=int,
        default=None,
        help="population methods: class size (default 50; at most 1 GiB per evaluation: size × "
        "chunk size × samples × 8 B)",
    )
    p.add_argument(
        "--max-iter",
        type=int,
        default=None,
        help=f"population methods: iterations (default 300, at most {MAX_ITER:,})",
    )
    p.add_argument(
        "--samples", type=int, default=None, help="samples per simulated test (default 2000, 100 to 200,000)"
    )
    p.add_argument(
        "--chunk-size",
        type=int,
        default=None,
        help="fits per compiled batch (default 64, or fewer to keep 1 GiB per evaluation; at most "
        "1 GiB: chunk × samples × population × 8 B)",
    )
    p.add_argument(
        "--out",
        default="sweep.csv",
        help="table file, .csv or .parquet, in an existing directory (default sweep.csv)",
    )
    p.add_argument(
        "--resume",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="skip chunks whose part file exists (default on)",
    )
    p.add_argument(
        "--distributed",
        action="store_true",
        help="join a multi-process run (cluster auto-detected by jax.distributed)",
    )
    p.add_argument("--coordinator", metavar="HOST:PORT", help="multi-process run: coordinator address")
    p.add_argument("--num-processes", type=int, help="multi-process run: number of processes")
    p.add_argument("--process-id", type=int, help="multi-process run: this process's index")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(handler="jadhesion.cli.sweep_run:run")
