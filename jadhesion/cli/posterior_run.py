"""``jadhesion posterior``'s work: LM start, emcee, diagnostics, figures (arguments: :mod:`.posterior`)."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

from ..identify.ensemble import ChainTooShortWarning
from ..identify.laplace import colour_check, initial_spread, lm_optimum
from ..identify.mcmc import sample_posterior
from ..identify.observer_view import recording_observer_terms
from ..identify.polach_fit import require_samples
from ..models.polach import PARAM_NAMES
from ..plots.posterior import corner_plot, predictive_plot
from .common import Progress, UserError, emit_json, table
from .loading import load_dataset


def _choose_likelihood(recording, requested: str):
    """``(likelihood, ObserverTerms or None, note)`` for the loaded recording; ``auto`` is the
    Gaussian (tempered in :func:`run`)."""
    if requested == "auto":
        return "gauss", None, "auto"
    if requested != "observer":
        return requested, None, "requested"
    if not recording.has_raw_signals:
        raise UserError(
            f"{recording.path}: --likelihood observer needs the columns time, "
            f"vehicle_speed, wheel_speed and traction_torque"
        )
    try:
        return "observer", recording_observer_terms(recording), "requested"
    except ValueError as err:
        raise UserError(f"{recording.path}: {err}") from None


def _document(result, theta0, note="", creep="raw") -> dict:
    diag = result.diagnostics
    return {
        "likelihood": result.likelihood,
        "likelihood_note": note,
        "creep": creep,
        "lm_start": dict(zip(PARAM_NAMES, map(float, theta0), strict=True)),
        "params": result.params,
        "derived": result.derived,
        "vehicle_speed": result.vehicle_speed,
        "diagnostics": {
            "acceptance": diag.acceptance,
            "tau": dict(zip(result.names, diag.tau.tolist(), strict=True)),
            "ess": dict(zip(result.names, diag.ess.tolist(), strict=True)),
            "n_samples": diag.n_samples,
            "steps": diag.steps,
            "burn": diag.burn,
            "seconds": diag.seconds,
            "compile_seconds": diag.compile_seconds,
            "warnings": list(diag.warnings),
        },
    }


def run(args) -> int:

    if args.walkers < 12 or args.walkers % 2:
        raise UserError(f"--walkers must be an even number >= 12, got {args.walkers}")
    if args.steps < 50:
        raise UserError(f"--steps must be at least 50, got {args.steps}")
    recording, data, selection = load_dataset(args, args.file)
    require_samples(data, args.file)
    if args.likelihood == "observer" and not selection.complete:
        raise UserError(
            f"{recording.path}: --likelihood observer needs one contiguous series, but "
            f"{selection.summary()}; use --likelihood auto or --start/--end"
        )
    likelihood, obs, note = _choose_likelihood(recording, args.likelihood)
    theta0 = lm_optimum(data, obs=obs)
    # the check it prints: the residuals' colour; auto tempers the Gaussian by 1/κ, a requested
    # likelihood runs as asked (ar1/observer model the colour themselves)
    auto = args.likelihood == "auto"
    tempering = colour_check(data, theta0, likelihood, obs)
    tempering["weight"] = 1.0 / tempering["kappa"] if auto else 1.0
    if auto:
        note = (
            f"auto: Gaussian tempered by 1/κ, κ = {tempering['kappa']:.1f} (residuals at the LM "
            f"optimum: lag-1 autocorrelation {tempering['residual_rho']:.2f}, "
            f"{tempering['effective_samples']:.0f} effective of {tempering['samples']} samples)"
        )
    spread = np.asarray(initial_spread(theta0, data, obs=obs)) * np.sqrt(1.0 / tempering["weight"])
    theta0 = np.asarray(theta0)
    progress = Progress(args.steps, "posterior", "steps", enabled=not args.json or sys.stderr.isatty())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ChainTooShortWarning)  # reported in diagnostics instead
        result = sample_posterior(
            data,
            theta0,
            walkers=args.walkers,
            steps=args.steps,
            likelihood=likelihood,
            seed=args.seed,
            spread=spread,
            obs=obs,
            weight=tempering["weight"],
            callback=lambda i: progress.update(i - progress.done),
        )
    for message in result.diagnostics.warnings:
        sys.stderr.write(f"jadhesion: warning: {message}\n")
    if args.plot:
        out = Path(args.plot)
        out.mkdir(parents=True, exist_ok=True)
        corner_plot(result).savefig(out / "posterior_corner.png", dpi=90)
        predictive_plot(result, data).savefig(out / "posterior_predictive.png", dpi=110)
    doc = _document(result, theta0, note, "smoothed" if data.slip_sd is not None else "raw")
    doc["tempering"] = tempering
    doc["selection"] = selection.document()
    if args.json:
        emit_json(doc)
        return 0
    rows = [{"quantity": k, **v} for k, v in {**result.params, **result.derived}.items()]
    print(f"likelihood: {likelihood} ({note}); creep: {doc['creep']}")
    print(table(rows, ["quantity", "median", "q05", "q95"]))
    d = doc["diagnostics"]
    print(
        f"acceptance {d['acceptance']:.2f}, tau max {max(d['tau'].values()):.0f} steps, "
        f"ESS min {min(d['ess'].values()):.0f}, {d['n_samples']} samples, {d['seconds']:.1f} s"
    )
    return 0
