"""``jadhesion posterior``'s work: LM start, emcee, diagnostics, figures (arguments: :mod:`.posterior`)."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

from ..identify.ensemble import ChainTooShortWarning
from ..identify.laplace import initial_spread, lm_optimum
from ..identify.likelihood import recording_observer_terms
from ..identify.mcmc import sample_posterior
from ..identify.polach_fit import require_samples
from ..models.polach import PARAM_NAMES
from ..plots.posterior import corner_plot, predictive_plot
from .common import Progress, UserError, emit_json, table
from .loading import load_dataset


def _choose_likelihood(recording, requested: str):
    """``(likelihood, ObserverTerms or None, note)`` for the loaded recording."""
    if requested not in ("auto", "observer"):
        return requested, None, "requested"
    if not recording.has_raw_signals:
        if requested == "observer":
            raise UserError(
                f"{recording.path}: --likelihood observer needs the columns time, "
                f"vehicle_speed, wheel_speed and traction_torque"
            )
        return "gauss", None, "auto: no raw signals (time, speeds, torque), i.i.d. Gaussian"
    # With the raw signals mu_hat is the observer's output (an adhesion column is ignored:
    # jadhesion.data.dataset.adhesion_source), so the observer likelihood applies.
    try:
        obs = recording_observer_terms(recording)
    except ValueError as err:
        raise UserError(f"{recording.path}: {err}") from None
    return (
        "observer",
        obs,
        "requested"
        if requested == "observer"
        else ("auto: raw signals present, the observer's lag modelled"),
    )


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
    if selection.complete:
        likelihood, obs, note = _choose_likelihood(recording, args.likelihood)
    elif args.likelihood == "observer":
        raise UserError(
            f"{recording.path}: --likelihood observer needs one contiguous series, but "
            f"{selection.summary()}; use --likelihood gauss or --start/--end"
        )
    elif args.likelihood == "auto":  # the observer likelihood needs one contiguous series
        likelihood, obs = "gauss", None
        note = f"auto: samples excluded ({selection.summary()}), i.i.d. Gaussian"
    else:
        likelihood, obs, note = args.likelihood, None, "requested"
    theta0 = lm_optimum(data, obs=obs)
    spread = np.asarray(initial_spread(theta0, data, obs=obs))
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
