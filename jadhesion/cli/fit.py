"""``jadhesion fit FILE.csv [FILE.csv | DIR ...]``: identify Polach's (or Kiencke's) parameters from
recordings or creepage files, with status, standard errors, 95 % intervals, correlations and
warnings.

This module defines the arguments only; :mod:`.fit_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS
from .common import MAX_ITER
from .recording_options import add_recording_options, add_single_law_option, add_slip_law_option

#: Fit methods offered (the registry's names; kept literal so ``--help`` imports no JAX — a test
#: keeps this equal to :data:`jadhesion.identify.methods.NAMES`).
METHODS = ("itlbo", "tlbo", "pso", "lm")
#: Models offered: Polach (paper 001) or Kiencke (paper 000, fitted offline).
MODELS = ("polach", "kiencke")
#: Creep estimates offered (:data:`jadhesion.data.dataset.CREEP_OPTIONS`).
CREEP = ("smoothed", "raw")


def register(sub) -> None:
    p = sub.add_parser("fit", help=COMMANDS["fit"])
    p.add_argument(
        "file",
        nargs="+",
        help="recordings or creepage files (CSV, Parquet, MATLAB .mat), or directories of them: "
        "several are fitted in one process, one compiled program per length "
        "bucket, each exactly as when fitted alone",
    )
    p.add_argument(
        "--method",
        choices=METHODS,
        default="itlbo",
        help="improved TLBO (default), TLBO, PSO or Levenberg–Marquardt",
    )
    p.add_argument(
        "--model",
        choices=MODELS,
        default="polach",
        help="Polach [kA, kS, mu0, A, B] (default) or Kiencke [p1, p2, a_s]",
    )
    p.add_argument(
        "--creep",
        choices=CREEP,
        default="smoothed",
        help="creep from the Kalman/RTS-smoothed speeds (default) or their raw difference",
    )
    add_slip_law_option(p)
    add_single_law_option(p, "95 %% intervals")
    p.add_argument("--seed", type=int, default=0, help="optimiser seed (default 0)")
    p.add_argument(
        "--pop-size",
        type=int,
        default=None,
        help="population size of a population method (default 50, >= 2, at most 1 GiB per evaluation: "
        "size × samples × 8 B; lm ignores it, with a warning)",
    )
    p.add_argument(
        "--max-iter",
        type=int,
        default=None,
        help=f"iteration cap of a population method (default 300, at most {MAX_ITER:,}); it stops earlier "
        "when its best MAE "
        "stalls (lm, which stops at its own convergence test, ignores it with a warning)",
    )
    p.add_argument(
        "--plot",
        metavar="DIR",
        default=None,
        help="write fit.png (data, fit and residuals) into DIR (several files: one STEM.fit.png each; "
        "Polach fits only)",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help='one JSON document on stdout (several files: {"fits": [one per file]})',
    )
    p.add_argument(
        "--out",
        metavar="FILE.csv",
        default=None,
        help="also write a CSV table, one row per file: file, method, params, mae, "
        "status, converged, stderr per parameter",
    )
    p.add_argument(
        "--keep-going",
        action="store_true",
        help="several files: fit those that can be used and list each one that cannot, with its "
        'reason (stderr, and "skipped" in --json), instead of stopping at the first; exit 2 only '
        "when none can",
    )
    add_recording_options(p)
    p.set_defaults(handler="jadhesion.cli.fit_run:run")
