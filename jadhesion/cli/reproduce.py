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


def register(sub) -> None:
    """Add the ``reproduce`` subcommand to ``sub`` (argparse subparsers)."""
    p = sub.add_parser("reproduce", help=COMMANDS["reproduce"])
    p.add_argument("target", nargs="?", choices=("table2", "online"), default=None)
    p.add_argument("--seeds", type=int, default=20, help="table2: data/optimiser seeds per cell")
    p.add_argument("--runs", type=int, default=1000, help="online: Monte Carlo runs per algorithm")
    p.add_argument(
        "--no-mcmc", action="store_true", help="table2: leave out the emcee posterior row of each scenario"
    )
    p.add_argument(
        "--mcmc-steps",
        type=int,
        default=None,
        metavar="S",
        help="table2: steps of each posterior chain (default 1500; burn-in a third)",
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
