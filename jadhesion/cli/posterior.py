"""``jadhesion posterior FILE``: Bayesian posterior of the Polach parameters (emcee).

Walkers start around the LM optimum; the output gives per-parameter medians and 90 % intervals,
the derived peak adhesion and optimal creepage, and sampler diagnostics (acceptance, τ, ESS, and a
warning when the chain is shorter than 50 τ). Its ``warnings`` are ``fit``'s about the recording and
the data, by fit's code: ``creep_sign``, ``few_samples``, ``narrow_creep_range``,
``single_speed``, ``crowded_slips``, ``implausible_adhesion``, and ``peak_extrapolated`` when the
median ``creep_opt`` lies outside the samples' creep: the intervals are then the model's
extrapolation, however narrow.

``--likelihood auto`` (the default) is the Gaussian likelihood (errors in variables included)
tempered by 1/κ, κ the residuals' colour factor at the LM optimum
(:func:`jadhesion.identify.laplace.colour_check`: long-run over plain variance; the observer and
coloured sensor noise correlate neighbouring residuals, so n samples carry about n/κ samples'
information). It prints that check (κ, lag-1 autocorrelation, effective samples) and the tails'
(:func:`.posterior_run.tail_check`: the standardised residuals' excess kurtosis against three
standard errors of a Gaussian sample's at n/κ samples) in ``likelihood_note`` and the JSON's
``tempering``. ``student`` (Student-t, ν = 4, the same errors-in-variables standardisation,
started at LM's robust optimum) is the heavy-tailed alternative: with ``--temper``, on the
independent generator it cut the median μ0 error from 0.0017 to 0.0007 and narrowed the intervals
by 27–46 %, but held one truth fewer of kA (7 of 12) and kS (11 of 15); on ours it held more kS,
μ0 and creep_opt but one μ_max fewer (8 of 18) and missed sand's μ0 by up to 0.18 (Gaussian
0.08), so it is not the default (``benchmarks/results/coverage_posterior_student.json``).
Untempered, an i.i.d. likelihood on such residuals gives intervals √κ too narrow (``--temper``
tempers a requested likelihood as auto does); the ``observer`` likelihood (the observer's lag
modelled, AR(1) noise), the former default, held on our simulator's clean sensors but missed μ0
on most recordings of the independent generator (issue 18); it stays available with
``--likelihood observer``, as do ``gauss`` and ``student`` (untempered), ``ar1`` and ``laplace``.
Measured coverage: ``benchmarks/results/coverage_posterior.json`` and
``coverage_posterior_student.json``.

``--creep smoothed`` (the default) estimates creep as a smoothed state when the file has the raw
signals (:mod:`jadhesion.data.creep_state`) and the likelihood integrates its uncertainty (errors in
variables, :mod:`jadhesion.identify.likelihood`); ``--creep raw`` uses the speed difference. The
JSON's ``creep`` says which one ran; ``--slip-law`` (``slip_law``) the law of the true slip
given the smoothed one (:mod:`jadhesion.identify.slip_law`). One recording cannot tell which law
holds, so with smoothed creep LM also fits the other law (``slip_law_check``) and each reported
90 % interval (``q05``, ``q95``) is the join of this posterior's (``q05_posterior``,
``q95_posterior``) and LM's 90 % interval under the other law, as ``fit`` joins its 95 % ones;
``--single-law`` skips that fit and reports the posterior's own.

This module defines the arguments only; :mod:`.posterior_run` does the work.
"""

from __future__ import annotations

from . import COMMANDS
from .recording_options import add_recording_options, add_single_law_option, add_slip_law_option

#: ``--walkers``: an even ensemble of 12 to 512 (16× the default; every step evaluates the
#: likelihood on walkers × samples values: 52 s for 200 steps of 512 walkers on a 4000-sample
#: recording).
MIN_WALKERS, MAX_WALKERS = 12, 512
#: The largest chain ``--walkers`` × ``--steps`` may make, walkers × steps × coordinates × 8 bytes
#: (1 GiB; the process's peak grew by about 1.5× the chain, measured).
MAX_CHAIN_BYTES = 2**30
#: emcee's move sets offered (:data:`jadhesion.identify.ensemble.MOVES`; literal so ``--help``
#: imports no sampler code).
MOVES = ("de", "stretch")


#: Fewest steps per walker a chain may have.
MIN_STEPS = 50


def register(sub) -> None:
    p = sub.add_parser("posterior", help=COMMANDS["posterior"])
    p.add_argument("file", help="recording or creepage CSV")
    p.add_argument(
        "--walkers",
        type=int,
        default=32,
        help=f"ensemble size, even, {MIN_WALKERS} (14 for ar1 and observer: 2 per coordinate) to "
        f"{MAX_WALKERS} (default 32)",
    )
    p.add_argument(
        "--steps",
        type=int,
        default=None,
        help=f"steps per walker, burn-in included, at least {MIN_STEPS}, at most "
        f"{MAX_CHAIN_BYTES / 2**30:g} GiB of chain (walkers × steps × coordinates × 8 B; default: "
        "5000, extended up to 20000 until the chain holds 50 autocorrelation times)",
    )
    p.add_argument(
        "--likelihood",
        choices=("auto", "gauss", "student", "laplace", "ar1", "observer"),
        default="auto",
        help="auto (default): gauss tempered by the residuals' colour (n/κ effective samples); "
        "gauss: i.i.d. untempered; student: Student-t (ν = 4, heavy tails) i.i.d. untempered; "
        "ar1: AR(1) residuals in time order; "
        "observer: the adhesion observer's lag modelled, AR(1) noise (needs time and "
        "traction_torque, one stretch)",
    )
    p.add_argument(
        "--temper",
        action="store_true",
        help="temper a requested likelihood by 1/κ as auto does (auto always tempers)",
    )
    p.add_argument(
        "--creep",
        choices=("smoothed", "raw"),
        default="smoothed",
        help="smoothed (default): creep as a smoothed state with its uncertainty in the "
        "likelihood (errors in variables); raw: the difference of the speeds",
    )
    add_slip_law_option(p)
    add_single_law_option(p, "90 %% intervals (q05, q95)")
    p.add_argument(
        "--moves",
        choices=MOVES,
        default="de",
        help="emcee's moves: de (default: differential evolution, emcee's DEMove) or stretch "
        "(the affine-invariant stretch move, the default before 2026-12-02)",
    )
    p.add_argument("--seed", type=int, default=0, help="0 to 2**63 - 1 (default 0)")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    add_recording_options(p)
    p.add_argument("--plot", metavar="DIR", default=None, help="write corner and predictive figures")
    p.set_defaults(handler="jadhesion.cli.posterior_run:run")
