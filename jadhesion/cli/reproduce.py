"""``jadhesion reproduce [table2|online]``: the papers' results on built-in defaults.

With no target it runs both: paper 001's Table 2 (Polach, offline) and paper 000's online
identification (Kiencke). Table 2 gains one ``mcmc`` row per scenario (the emcee posterior,
:func:`jadhesion.experiments.mcmc_row.mcmc_row`) unless ``--no-mcmc``. Table 2 runs on clean
sensors, the paper's conditions; ``--sensors realistic`` adds the same rows on realistic sensors
(scaled by ``--sensor-noise``) beside them.

This module defines the arguments only; :mod:`.reproduce_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS
from .simulate import MAX_SENSOR_NOISE

#: The most ``--seeds`` (Table 2 runs a cell's seeds as one batch: 1000 seeds' populations hold
#: about 0.8 GB), ``--runs`` (the online study's runs × 1200 steps per array: 10 000 runs about
#: 0.1 GB each) and ``--mcmc-steps`` (32 walkers' chain); beyond them a run ran out of memory
#: (--runs 10**8 asked XLA for 960 GB) or overflowed in a traceback.
MAX_SEEDS, MAX_RUNS, MAX_MCMC_STEPS = 1000, 10_000, 100_000
#: Defaults of ``--seeds`` and ``--runs``.
DEFAULT_SEEDS, DEFAULT_RUNS = 20, 1000


def register(sub) -> None:
    """Add the ``reproduce`` subcommand to ``sub`` (argparse subparsers)."""
    p = sub.add_parser("reproduce", help=COMMANDS["reproduce"])
    p.add_argument(
        "target", nargs="?", choices=("table2", "online"), default=None, help="one table (default: both)"
    )
    p.add_argument(
        "--seeds",
        type=int,
        default=DEFAULT_SEEDS,
        help=f"table2: data/optimiser seeds per cell (default {DEFAULT_SEEDS}, at most {MAX_SEEDS})",
    )
    p.add_argument(
        "--runs",
        type=int,
        default=DEFAULT_RUNS,
        help=f"online: Monte Carlo runs per algorithm (default {DEFAULT_RUNS:,}, at most {MAX_RUNS:,})",
    )
    p.add_argument(
        "--no-mcmc", action="store_true", help="table2: leave out the emcee posterior row of each scenario"
    )
    p.add_argument(
        "--mcmc-steps",
        type=int,
        default=None,
        metavar="S",
        help=f"table2: steps of each posterior chain (default 1500, at most {MAX_MCMC_STEPS:,}; "
        "burn-in a third)",
    )
    p.add_argument(
        "--sensors",
        choices=("clean", "realistic"),
        default="clean",
        help="table2: clean (the paper's conditions, default) or realistic: rows on realistic "
        "sensors beside the clean ones",
    )
    p.add_argument(
        "--sensor-noise",
        type=float,
        default=1.0,
        metavar="SCALE",
        help=f"table2: scale of the realistic sensor noise, 0 (none) to {MAX_SENSOR_NOISE:g} "
        "(jadhesion.data.sensors; default 1)",
    )
    p.add_argument("--plot", metavar="DIR", default=None, help="write figures into DIR")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(handler="jadhesion.cli.reproduce_run:run")
