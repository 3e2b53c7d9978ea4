"""``jadhesion posterior``'s work: LM start, emcee, diagnostics, figures (arguments: :mod:`.posterior`).

Unknown sidecar keys are said on stderr as soon as the recording is loaded and listed in the
document's ``warnings`` (``sidecar_unknown_key``, :func:`jadhesion.data.sidecar.sidecar_warning`),
followed by what ``fit`` warns of the data themselves, by fit's own rules (:func:`data_warnings`): a
posterior on such data is the prior's and the model's extrapolation however narrow its intervals;
last, a chain shorter than 50 autocorrelation times (``chain_too_short``, naming the slow
coordinates; its message stays in ``diagnostics.warnings`` too, and ``status`` says
``"chain_too_short"`` instead of ``"converged"``)."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

from ..data.dataset import sd_scale_summary, thinned, valid_mask
from ..data.selected import creep_sign_warning, stuck_speed_warning
from ..identify.batch_fit import bucketed
from ..identify.ensemble import ChainTooShortWarning
from ..identify.laplace import colour_check, initial_spread, thinning
from ..identify.likelihood import noise_names, other_slip_law, with_slip_law
from ..identify.mcmc import sample_posterior
from ..identify.observer_view import recording_observer_terms
from ..identify.peak import extrapolation_warning
from ..identify.polach_fit import require_samples
from ..identify.polach_residuals import eiv_scale, standardised_residual
from ..identify.trust import data_warnings as trust_data_warnings
from ..identify.trust import join_posterior_intervals, normal_intervals
from ..identify.uncertainty import Z90
from ..models.polach import PARAM_NAMES, adhesion_peak
from ..plots.posterior import corner_plot, predictive_plot
from ..status import status_of
from .common import Progress, UserError, emit_json, require_output_dir, require_seed, say_written, table
from .fit_program import fit_polach as kept_fit
from .fit_program import lm_start, seed_key
from .fit_program import to_dataset as kept_dataset
from .fit_run import other_law_fits
from .loading import load_dataset, load_from_args, say_notes_and_sidecar_warning, slip_law_used
from .posterior import MAX_CHAIN_BYTES, MAX_WALKERS, MIN_STEPS, MIN_WALKERS

#: Without ``--steps``: the chain's first length, and the most it is extended to while it holds
#: fewer than 50 autocorrelation times (:func:`jadhesion.identify.ensemble.run_ensemble`); the
#: latter's chain fits :data:`.posterior.MAX_CHAIN_BYTES` at any allowed ``--walkers``.
DEFAULT_STEPS, AUTO_MAX_STEPS = 5000, 20000


def tail_check(data, theta, kappa: float) -> dict:
    """The standardised residuals' tails at ``theta``: ``z = (E[mu_adh] − mu_hat) / √(σ² + Var[mu_adh])``
    (LM's and the likelihoods' errors-in-variables standardisation,
    :func:`~jadhesion.identify.polach_residuals.standardised_residual`, σ = 1.4826 MAD of the
    residuals), their excess kurtosis and ``"kurtosis_threshold"`` = three standard errors of a
    Gaussian sample's, ``3 √(24 κ / n)`` (n/κ effective samples). ``"heavy_tails"``: above it.
    A padded dataset (``weight``) gives its samples' numbers."""
    sigma = eiv_scale(theta, data)
    z = np.asarray(standardised_residual(theta, data._replace(residual_scale=sigma)))[valid_mask(data)]
    zc = z - z.mean()
    excess = float(np.mean(zc**4) / max(np.mean(zc**2) ** 2, 1e-300) - 3.0)
    threshold = 3.0 * float(np.sqrt(24.0 * kappa / z.shape[0]))
    return {"excess_kurtosis": excess, "kurtosis_threshold": threshold, "heavy_tails": excess > threshold}


def data_warnings(recording, selection, data, result) -> list:
    """``fit``'s warnings {code, params, message} about the data, by its own code: ``creep_sign``
    (:func:`jadhesion.data.selected.creep_sign_warning`), ``stuck_signal``
    (:func:`jadhesion.data.selected.stuck_speed_warning`), :func:`jadhesion.identify.trust.data_warnings`
    and ``peak_extrapolated`` for the posterior's median ``creep_opt`` outside the samples'
    ``|creep|`` (:func:`.peak.extrapolation_warning`)."""
    creep = np.abs(np.asarray(data.creep, float))[valid_mask(data)]
    peak = extrapolation_warning(
        result.derived["creep_opt"]["median"],
        float(creep.min()),
        float(creep.max()),
        f" at {result.vehicle_speed:.3g} m/s",
    )
    found = trust_data_warnings(data)
    recorded = (creep_sign_warning(recording, selection), stuck_speed_warning(recording))
    return [w for w in (*recorded, *found, peak) if w is not None]


def slip_law_check(data, law: str, seed: int, result) -> tuple:
    """``(check, warning)``: LM's fit of ``data`` under the other slip law (``law``, ``method``,
    ``params``, ``derived`` at the posterior's reference speed, ``status``, ``converged``, and
    ``interval90``: its 90 % intervals from ``fit``'s trust block,
    :func:`jadhesion.identify.trust.normal_intervals`) and the warning ``slip_law_sensitive``
    naming the quantities it puts outside this posterior's own 90 % interval (``None`` where there
    is none; LM's robust loss may differ from the likelihood too, so the warning says where, not
    why); ``(None, None)`` without a slip sd."""
    if data.slip_sd is None:
        return None, None
    other = other_slip_law(law)
    # as ``fit`` does it, through its kept programs (tracing them anew was 1.3 s of a warm
    # 2 000-sample posterior's 7.7 s of CPU; the same numbers bit for bit)
    ((fitted, report),) = other_law_fits([data], other, seed)
    fit = fitted.fit
    params = dict(zip(PARAM_NAMES, np.asarray(fit.params).tolist(), strict=True))
    peak = adhesion_peak(fit.params, data.k_eps, result.vehicle_speed)
    derived = dict(zip(("mu_max", "creep_opt"), map(float, peak), strict=True))
    check = {
        "law": other,
        "method": "lm",
        "params": params,
        "derived": derived,
        "status": status_of(fit.status).label,
        "converged": status_of(fit.status).converged,
        "interval90": normal_intervals(report, params, Z90),
    }
    ours = {**result.params, **result.derived}
    moved = [
        (n, ours[n]["median"], v)
        for n, v in {**params, **derived}.items()
        if not ours[n]["q05"] <= v <= ours[n]["q95"]
    ]
    if not moved:
        return check, None
    change = ", ".join(f"{n} {a:.4g} → {b:.4g}" for n, a, b in moved)
    message = (
        f"LM under the {other} slip law puts {change} (this posterior's median → LM's) outside this "
        "posterior's own 90 % interval: whether the smoother's error is Berkson or classical, one "
        "recording cannot tell; q05/q95 join both laws' 90 % intervals (q05_posterior/q95_posterior: "
        f"this posterior's own); compare --slip-law {other}"
    )
    return check, {"code": "slip_law_sensitive", "params": [n for n, _, _ in moved], "message": message}


def start_warning(start) -> list:
    """``[warning]`` when the LM fit the chain starts from (``lm_start``) did not converge (``[]``
    when it did)."""
    status = status_of(start.status)
    if status.converged:
        return []
    message = (
        f"the LM fit the chain starts from (lm_start) stopped with status {status.label}: it may not "
        "be a minimum, and the chain starts about it; read the chain's diagnostics before its intervals"
    )
    return [{"code": "lm_start_not_converged", "params": [], "message": message}]


def _auto_note(t: dict) -> str:
    tails = (
        "heavy: --likelihood student --temper is the heavy-tailed alternative"
        if t["heavy_tails"]
        else "near Gaussian"
    )
    return (
        f"auto: Gaussian tempered by 1/κ, κ = {t['kappa']:.1f} (residuals at the LM optimum: lag-1 "
        f"autocorrelation {t['residual_rho']:.2f}, {t['effective_samples']:.0f} effective of "
        f"{t['samples']} samples; standardised excess kurtosis {t['excess_kurtosis']:.1f} "
        f"{'>' if t['heavy_tails'] else '≤'} {t['kurtosis_threshold']:.1f} (3 Gaussian standard errors): "
        f"tails {tails})"
    )


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
            "moves": diag.moves,
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


def coordinates(likelihood: str) -> int:
    """Coordinates the ``likelihood``'s chain samples: the five Polach parameters and its noise
    ones (``auto`` samples the Gaussian's)."""
    return len(PARAM_NAMES) + len(noise_names("gauss" if likelihood == "auto" else likelihood))


def chain_bytes(walkers: int, steps: int, likelihood: str) -> int:
    """Memory [B] of a chain of ``steps`` × ``walkers`` of the ``likelihood``'s coordinates."""
    return walkers * steps * coordinates(likelihood) * 8


def _check_flags(args) -> None:
    """Refuse a bad flag before any work."""
    require_seed("posterior", args.seed)
    require_output_dir("posterior", "plot", args.plot)
    # emcee's stretch move needs at least two walkers per coordinate (ar1 and observer sample 7)
    least = max(MIN_WALKERS, 2 * coordinates(args.likelihood))
    if not (least <= args.walkers <= MAX_WALKERS and args.walkers % 2 == 0):
        why = "" if least == MIN_WALKERS else f" with --likelihood {args.likelihood} (2 per coordinate)"
        raise UserError(
            f"posterior: --walkers must be an even number in [{least}, {MAX_WALKERS}]{why}, "
            f"got {args.walkers}"
        )
    if args.steps is None:
        return
    if args.steps < MIN_STEPS:
        raise UserError(f"posterior: --steps must be at least {MIN_STEPS}, got {args.steps}")
    if (need := chain_bytes(args.walkers, args.steps, args.likelihood)) > MAX_CHAIN_BYTES:
        raise UserError(
            f"posterior: --steps {args.steps} with --walkers {args.walkers} needs a "
            f"{need / 2**30:.3g} GiB chain, more than {MAX_CHAIN_BYTES / 2**30:g} GiB: "
            "use fewer steps or walkers"
        )


def run(args) -> int:
    _check_flags(args)
    recording = load_from_args(args, args.file)
    sidecar = say_notes_and_sidecar_warning(recording)
    recording, data, selection = load_dataset(args, args.file, kept_dataset, recording=recording)
    data = with_slip_law(data, args.slip_law)  # --slip-law population: that law's nodes
    require_samples(data, args.file)
    if args.likelihood == "observer" and not selection.complete:
        raise UserError(
            f"{recording.path}: --likelihood observer needs one contiguous series, but "
            f"{selection.summary()} ({selection.where_broken()}); "
            "use --likelihood auto or --start/--end"
        )
    likelihood, obs, note = _choose_likelihood(recording, args.likelihood)
    # the start and the checks on the dataset padded to its length bucket: one program per bucket,
    # loaded, not compiled, for a recording of a new length (the sampler runs on the samples alone;
    # the observer's view needs them unpadded)
    padded = bucketed(data) if obs is None else data
    start = lm_start(padded, obs=obs)
    theta0 = start.params
    # the checks it prints, at the least-squares optimum: the residuals' colour and tails; auto
    # tempers the Gaussian by 1/κ (the Student-t in its place was not better on both generators:
    # benchmarks/results/coverage_posterior_student.json); a requested likelihood runs as asked,
    # untempered unless --temper (ar1/observer model the colour themselves)
    auto = args.likelihood == "auto"
    tempering = colour_check(padded, theta0, likelihood, obs)
    tempering.update(tail_check(padded, theta0, tempering["kappa"]))
    tempering["weight"] = 1.0 / tempering["kappa"] if auto or args.temper else 1.0
    if auto:
        note = _auto_note(tempering)
    elif args.temper:
        note = f"requested, tempered by 1/κ, κ = {tempering['kappa']:.1f}"
    if likelihood == "student":  # starts at LM's robust (pseudo-Huber) optimum, near its mode
        start = kept_fit(padded, "lm", seed_key(args.seed))
        theta0 = start.params
    sampled = data
    if auto and (every := thinning(tempering["samples"], tempering["kappa"])) > 1:
        # every d-th sample weighted d/κ: the same n/κ effective samples at 1/d of the cost (their
        # own κ, from fewer lags, read 3.5 where d/κ would be 4.9 on a 1 kHz recording)
        sampled = thinned(data, every)
        tempering["weight"] = every / tempering["kappa"]
        tempering["thinned"] = {"every": every, "samples": int(sampled.adhesion.shape[0])}
        note += f"; sampled one sample in {every}, each weighted {every}/κ"
    spread = initial_spread(theta0, padded if sampled is data else bucketed(sampled), obs=obs)
    spread = np.asarray(spread) * np.sqrt(1.0 / tempering["weight"])
    theta0 = np.asarray(theta0)
    steps, max_steps = (DEFAULT_STEPS, AUTO_MAX_STEPS) if args.steps is None else (args.steps, None)
    progress = Progress(steps, "posterior", "steps", enabled=not args.json or sys.stderr.isatty())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ChainTooShortWarning)  # reported in diagnostics instead
        result = sample_posterior(
            sampled,
            theta0,
            walkers=args.walkers,
            steps=steps,
            max_steps=max_steps,
            likelihood=likelihood,
            seed=args.seed,
            spread=spread,
            obs=obs,
            weight=tempering["weight"],
            callback=progress,
            moves=args.moves,
        )
    chain = result.chain_warning()
    if chain is not None and args.json:  # the text output lists it with the other warnings
        sys.stderr.write(f"jadhesion: warning: {chain['message']}\n")
    if args.plot:
        out = Path(args.plot)
        out.mkdir(parents=True, exist_ok=True)
        plots = [out / "posterior_corner.png", out / "posterior_predictive.png"]
        corner_plot(result).savefig(plots[0], dpi=90)
        predictive_plot(result, data).savefig(plots[1], dpi=110)
    creep = "given" if not recording.has_raw_signals else "smoothed" if data.slip_sd is not None else "raw"
    doc = {"file": str(args.file), **_document(result, theta0, note, creep)}
    doc["status"] = "converged" if chain is None else chain["code"]
    doc["converged"] = chain is None  # as fit's and online's: the status as a bool
    doc["lm_start_status"] = status_of(start.status).label
    doc["tempering"] = tempering
    doc["slip_law"] = slip_law_used(args, data)
    doc["slip_sd_scale"] = sd_scale_summary(data)
    doc["selection"] = selection.document()
    doc["notes"] = list(recording.notes)
    found = data_warnings(recording, selection, data, result)
    check, sensitive = (
        (None, None) if args.single_law else slip_law_check(data, args.slip_law, args.seed, result)
    )
    if check is not None:
        doc["slip_law_check"] = check
        doc["params"], doc["derived"] = (
            join_posterior_intervals(doc[k], check) for k in ("params", "derived")
        )
    found += [] if sensitive is None else [sensitive]
    found += start_warning(start)
    doc["warnings"] = ([] if sidecar is None else [sidecar]) + found + ([] if chain is None else [chain])
    if args.plot:
        doc["plots"] = [str(p) for p in plots]
    if args.json:
        emit_json(doc)
        return 0
    rows = [{"quantity": k, **v} for k, v in {**doc["params"], **doc["derived"]}.items()]
    print(f"likelihood: {likelihood} ({note}); creep: {doc['creep']}")
    print(table(rows, ["quantity", "median", "q05", "q95"]))
    d = doc["diagnostics"]
    unknown = [k for k, v in d["tau"].items() if not np.isfinite(v)]
    mixing = (
        f"tau max {max(d['tau'].values()):.0f} steps, ESS min {min(d['ess'].values()):.0f}"
        if not unknown
        else f"tau undefined for {', '.join(unknown)} (a walker never moved)"
    )
    print(
        f"{d['steps']} steps (burn-in {d['burn']}), acceptance {d['acceptance']:.2f}, {mixing}, "
        f"{d['n_samples']} samples, {d['seconds']:.1f} s"
    )
    for w in doc["warnings"]:
        print(f"warning [{w['code']}]: {w['message']}")
    say_written(doc.get("plots", []))
    return 0
