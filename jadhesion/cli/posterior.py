"""``jadhesion posterior FILE``: Bayesian posterior of the Polach parameters (emcee).

Walkers start around the LM optimum; the output gives per-parameter medians and 90 % intervals,
the derived peak adhesion and optimal creepage, and sampler diagnostics (acceptance, τ, ESS, and a
warning when the chain is shorter than 50 τ).

``--likelihood auto`` (the default) picks ``observer`` — the observer's lag and torque leak
modelled, AR(1) noise (:mod:`jadhesion.identify.likelihood`), the best-calibrated choice on
simulated recordings (``benchmarks/results/mcmc_coverage_recordings.json``) — when the file has the
raw signals (``time``, speeds, ``traction_torque``) and its ``adhesion`` column, if any, is the
paper observer's output of them; otherwise ``gauss`` (i.i.d. Gaussian). The JSON's ``likelihood``
says which one ran and ``likelihood_note`` why.

``--creep smoothed`` (the default) estimates creep as a smoothed state when the file has the raw
signals (:mod:`jadhesion.data.creep_state`) and the likelihood integrates its uncertainty (errors in
variables, :mod:`jadhesion.identify.likelihood`); ``--creep raw`` uses the speed difference. The
JSON's ``creep`` says which one ran.

This module defines the arguments only; :mod:`.posterior_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS
from .recording_options import add_recording_options


def register(sub) -> None:
    p = sub.add_parser("posterior", help=COMMANDS["posterior"])
    p.add_argument("file", help="recording or creepage CSV")
    p.add_argument("--walkers", type=int, default=32, help="ensemble size (default 32)")
    p.add_argument("--steps", type=int, default=5000, help="steps per walker, burn-in included")
    p.add_argument(
        "--likelihood",
        choices=("auto", "gauss", "laplace", "ar1", "observer"),
        default="auto",
        help="auto (default): observer when the file has raw signals, else gauss; ar1: "
        "AR(1) residuals in time order; observer: the adhesion observer's lag "
        "modelled, AR(1) noise (needs time and traction_torque)",
    )
    p.add_argument(
        "--creep",
        choices=("smoothed", "raw"),
        default="smoothed",
        help="smoothed (default): creep as a smoothed state with its uncertainty in the "
        "likelihood (errors in variables); raw: the difference of the speeds",
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    add_recording_options(p)
    p.add_argument("--plot", metavar="DIR", default=None, help="write corner and predictive figures")
    p.set_defaults(handler="jadhesion.cli.posterior_run:run")
