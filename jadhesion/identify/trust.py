"""How far to trust a Polach fit: standard errors, 95 % intervals, correlations and warnings.

:func:`fit_report` takes a dataset (rows in time order) and a :class:`.polach_fit.PolachFit` and
returns the JSON-ready block of ``jadhesion fit``: ``uncertainty`` {param: {``stderr``, ``ci95``,
``stderr_hac``, ``stderr_jackknife``}}, ``correlation`` (5 × 5, order kA, kS, mu0, A, B; the
sandwich's), ``warnings`` [{``code``, ``params``, ``message``}], ``hac_lags``, ``jackknife_blocks``,
and the curve's peak with its intervals, ``derived`` {``mu_max``, ``creep_opt``: {``value``,
``stderr``, ``ci95``, ``stderr_hac``, ``stderr_jackknife``}} at ``vehicle_speed`` [m/s]
(:mod:`.peak`).
Each standard error is the larger of two, both reported (``stderr_hac``, ``stderr_jackknife``):
the HAC sandwich of :mod:`.uncertainty` (the observer colours the noise) of LM's residual
:data:`.polach_fit.LM_RESIDUAL` on the dataset with the fit's noise scale
(:func:`.polach_fit.scaled`: for an LM fit the standardised robust residual it minimised, an
M-estimator's sandwich; for a population method's fit the errors-in-variables residual), with the
delta method for the peak; and the **block jackknife** over :data:`JACKKNIFE_BLOCKS` contiguous
blocks of the samples (each left out once, LM refitted from the fit). The sandwich sees the
residuals' variance and colour; the jackknife also sees the errors that come and go with stretches
of the recording — the smoother's transients on clean sensors, the slow errors in variables of
noisy ones — which bias a fit of this recording and which no variance of its residuals shows:
90 % coverage on 12 starts of the independent generator, HAC → larger of the two (one slip law,
``benchmarks/coverage_fit.py``; a one-off probe first) kS 0.75 → 0.92 clean and 0.42 → 0.83
realistic, μ_max 0.58 → 0.92 and 0.67 → 1.00. ``ci95 = θ ± 1.96·stderr`` clipped to the box [0, 1].

Warning codes:

* ``at_bound`` — a parameter within :data:`BOUND_TOL` of 0 or 1: its ``stderr``/``ci95`` are
  ``null`` (a local interval means nothing on a face of the box). It stays *free* in the
  covariance, so the others' errors include the trade-off with it: conditioning on it (the former
  rule) made them far too narrow whenever A or B sat on a bound. HAC 90 % coverage of kS/μ0,
  12 recordings per set, conditional → free (``benchmarks/results/coverage_fit_conditional.json``
  → ``coverage_fit.json``): dry clean 0.75/0.50 → 0.83/0.92, wet clean 0.33/0.25 → 0.83/0.83,
  foreign generator realistic 0.50/0.50 → 0.67/0.67, dry realistic μ0 0.00 → 0.50.
* ``weakly_identified`` — a parameter whose 95 % interval (the reported one: joined over both
  slip laws where both were fitted) is wider than :data:`WEAK_WIDTH` of its box, or whose variance is
  infinite (a singular direction), named with the combination the data
  do determine where one is known: with A and B both weak, at small slip ``w``
  ``μ ≈ μ0 (1 − (1 − A)·B·|w|)``, so only ``(1 − A)·B`` is determined.
* ``undetermined`` — a parameter or peak quantity whose standard error the data do not determine
  (:func:`.uncertainty.determined`: infinite, or wider than the whole box): its ``stderr`` and
  ``ci95`` are ``null``. Together with ``at_bound`` (and ``peak_extrapolated`` for a curve without
  a peak) every ``null`` standard error is named by a warning.
* ``not_converged`` — the solver's status is not ``converged``.
* ``worse_than_zero`` — the fit's mean |residual| is no smaller than the mean |μ̂|: a curve at zero
  would fit better, so the parameters describe no curve of these data (23 samples of a start's
  first seconds ended on every bound with MAE 0.985 against 0.19, status ``converged``).
* ``few_samples`` — fewer than :data:`.polach_fit.RECOMMENDED_SAMPLES` samples.
* ``peak_extrapolated`` — the fitted peak lies outside the creep the recording covers (below its
  smallest or above its largest ``|creep|``), or the curve has none below creep 1 (:mod:`.peak`).
* ``narrow_creep_range`` — the samples' ``|creep|`` spans less than a factor :data:`CREEP_SPAN`
  (1st to 99th percentile, as ``inspect``'s rules, so a few transition samples do not make a held
  creep look covered): the curve is seen at (nearly) one creep value, where its initial slope, its
  bend and its peak cannot be told apart; the parameters and the peak are the model's
  extrapolation.
* ``single_speed`` — the samples' vehicle speed spans less than a factor
  :data:`jadhesion.data.inspection.SPEED_SPAN` (:func:`jadhesion.data.inspection.single_speed`):
  slip velocity and creep proportional, A and B traded against kA, kS and μ0 beyond the linear
  errors.
* ``slip_law_sensitive`` — (:func:`join_slip_laws`) the fit under the other slip law puts a
  parameter or peak quantity outside this fit's own 95 % interval; the reported ``ci95`` join
  both laws' (a posterior's 90 % intervals likewise: :func:`join_posterior_intervals`).
* ``implausible_adhesion`` — μ̂ beyond any wheel–rail adhesion
  (:func:`jadhesion.data.inspection.implausible_adhesion`): the fit is of a mis-scaled recording.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import valid_mask
from ..data.inspection import implausible_adhesion, single_speed
from ..models.polach import PARAM_NAMES, adhesion_peak
from ..status import status_of
from .batch_fit import bucketed, valid_samples
from .peak import DERIVED, MU_BOX_MAX, S_MAX, S_MIN, peak_numbers, peak_report, reference_speed
from .polach_fit import LM_RESIDUAL, RECOMMENDED_SAMPLES, refit_lm, scaled
from .uncertainty import (
    UNDETERMINED,
    Z95,
    block_jackknife_sd,
    correlation,
    covariance,
    determined,
    normal_interval,
    undetermined_warning,
)

#: Distance from a face of the unit box at which a parameter counts as on its bound.
BOUND_TOL = 1e-6
#: A 95 % interval wider than this share of the unit box marks a parameter weakly identified.
WEAK_WIDTH = 0.5
#: Contiguous blocks of the valid samples, each left out once by the block jackknife
#: (:func:`trust_numbers`).
JACKKNIFE_BLOCKS = 8
#: A 99th-to-1st percentile ratio of the samples' |creep| below this (less than a third of a
#: decade) is too narrow a creep range to determine the curve's shape.
CREEP_SPAN = 2.0


def _warning(code, params, message):
    return {"code": code, "params": list(params), "message": message}


def held_fixed(params):
    """Parameters within :data:`BOUND_TOL` of a face of the unit box (reported without a local
    interval; free in the covariance)."""
    return (params <= BOUND_TOL) | (params >= 1 - BOUND_TOL)


class TrustNumbers(NamedTuple):
    """The array work of a trust block (one compiled program)."""

    cov: jax.Array  # (5, 5) covariance of the parameters
    lags: jax.Array  # HAC bandwidth [samples]
    speed: jax.Array  # reference speed of the peak [m/s] (:func:`.peak.reference_speed`)
    peak: jax.Array  # (mu_max, creep_opt) at ``speed``
    peak_jacobian: jax.Array  # (2, 5)
    max_creep: jax.Array  # largest |creep| of the samples [-]
    jackknife: jax.Array  # (JACKKNIFE_BLOCKS, 7) refits' parameters, mu_max and creep_opt


def _jackknife(params, data, speed):
    """(:data:`JACKKNIFE_BLOCKS`, 7): LM refitted from ``params`` (:func:`.polach_fit.refit_lm`)
    without each contiguous block of the valid samples in turn, its parameters and its peak
    ``(mu_max, creep_opt)`` at ``speed``; one block at a time (``lax.map``: memory of one fit)."""
    n = data.adhesion.shape[-1]
    weight = jnp.ones(n, data.adhesion.dtype) if data.weight is None else data.weight
    valid = weight > 0
    block = ((jnp.cumsum(valid) - 1) * JACKKNIFE_BLOCKS) // jnp.maximum(jnp.sum(valid), 1)

    def refit(b):
        p = refit_lm(params, data._replace(weight=jnp.where(valid & (block == b), 0.0, weight))).params
        return jnp.concatenate([p, jnp.stack(adhesion_peak(p, data.k_eps, speed))])

    return jax.lax.map(refit, jnp.arange(JACKKNIFE_BLOCKS))


def jackknife_sd(replicates) -> np.ndarray:
    """(7,) block-jackknife standard errors of the parameters, ``mu_max`` and ``log creep_opt``
    from :class:`TrustNumbers`' ``jackknife`` (B, 7): ``√((B − 1)/B · Σ (x_b − x̄)²)``; 0 where a
    replicate is not finite (the delta method's then stands alone)."""
    x = np.array(replicates, float)
    x[:, -1] = np.log(np.where(x[:, -1] > 0, x[:, -1], np.nan))
    sd = block_jackknife_sd(x)
    return np.where(np.isfinite(sd), sd, 0.0)


@jax.jit
def trust_numbers(params, data) -> TrustNumbers:
    """:class:`TrustNumbers` of a fit at ``params``: the covariance and bandwidth of
    :func:`.uncertainty.covariance` for LM's residual (its Jacobian over every row), the peak
    of the curve with its gradient (:func:`.peak.peak_numbers`) and the block jackknife's refits
    (:func:`_jackknife`)."""
    r = LM_RESIDUAL(params, data)
    jac = jax.jacfwd(LM_RESIDUAL)(params, data)
    cov, lags = covariance(jac, r, weight=data.weight)  # bound parameters stay free (module docstring)
    speed = reference_speed(data.vehicle_speed, data.weight)
    peak, peak_jacobian = peak_numbers(params, data.k_eps, speed)
    creep = (
        jnp.abs(data.creep) if data.weight is None else jnp.where(data.weight > 0, jnp.abs(data.creep), 0.0)
    )
    replicates = _jackknife(params, data, speed)
    return TrustNumbers(cov, lags, speed, peak, peak_jacobian, jnp.max(creep), replicates)


def data_warnings(data) -> list:
    """The warnings about the data themselves, whatever was fitted to them (``fit`` and
    ``posterior`` both report them): ``few_samples``, ``implausible_adhesion``,
    ``narrow_creep_range``, ``single_speed`` and ``crowded_slips`` (module docstring)."""
    out = []
    n = valid_samples(data)
    if n < RECOMMENDED_SAMPLES:
        out.append(
            _warning(
                "few_samples",
                [],
                (f"{n} samples (< {RECOMMENDED_SAMPLES} recommended): errors and intervals are rough"),
            )
        )
    if (note := implausible_adhesion(np.asarray(data.adhesion)[valid_mask(data)])) is not None:
        out.append(_warning(note["code"], [], note["message"]))
    creep = np.abs(np.asarray(data.creep, float))[valid_mask(data)]
    lo, hi = np.percentile(creep, [1, 99]) if creep.size else (0.0, 0.0)
    if not hi >= CREEP_SPAN * lo:
        out.append(
            _warning(
                "narrow_creep_range",
                PARAM_NAMES + DERIVED,
                (
                    f"the samples' creep spans only {lo:.3g}–{hi:.3g} (1st–99th percentile, less than "
                    f"a factor {CREEP_SPAN:g}): too narrow to determine the curve's shape; its "
                    "parameters and peak are the model's extrapolation"
                ),
            )
        )
    if (note := single_speed(np.asarray(data.vehicle_speed)[valid_mask(data)])) is not None:
        out.append(_warning(note["code"], PARAM_NAMES, note["message"]))
    if (note := crowded_slips(data)) is not None:
        out.append(note)
    return out


#: Crowding of the micro-slip samples' smoothed slips (their median sd over their robust spread,
#: :func:`crowded_slips`) above which the errors-in-variables curve depends on the slip law: our
#: simulator's steady starts 0.37–0.85, the independent generator's 30 s starts 0–0.24 (12
#: recordings per set, 1×/2× noise and clean/mild/realistic sensors); its default 60 s recordings
#: 0.34–0.74 on 6 of 24 (steady runs and starts), below 0.3 on the rest.
CROWDED_SLIPS = 0.3


def crowded_slips(data):
    """The ``crowded_slips`` warning, or ``None``: among the samples whose |smoothed slip| is at
    most its 75th percentile (the micro-slip ones), the median ``slip_sd`` over the smoothed slips'
    robust spread (1.4826 MAD) is above :data:`CROWDED_SLIPS`. The true slip given the smoothed
    one then depends on whether the smoother's error is Berkson or classical (not measurable from
    one recording), and with it the curve's initial slope and μ0: ``--slip-law normal`` and
    ``population`` take the two views (README, "Which slip law")."""
    if data.slip_sd is None:
        return None
    keep = valid_mask(data)
    slip, sd = np.asarray(data.slip, float)[keep], np.asarray(data.slip_sd, float)[keep]
    micro = np.abs(slip) <= np.quantile(np.abs(slip), 0.75)
    spread = 1.4826 * np.median(np.abs(slip[micro] - np.median(slip[micro])))
    ratio = np.median(sd[micro]) / spread if spread > 0 else np.inf
    if not ratio > CROWDED_SLIPS:
        return None
    return _warning(
        "crowded_slips",
        ("kA", "kS", "mu0", *DERIVED),
        (
            f"the micro-slip samples' smoothed slips spread over only {1 / ratio:.2g} of their sds "
            f"(sd/spread {ratio:.2f} > {CROWDED_SLIPS:g}): the initial slope and mu0 depend on whether "
            "the smoother's error is Berkson (--slip-law normal) or classical (--slip-law population), "
            "which one recording cannot tell (fit's 95 % and posterior's 90 % intervals join both laws')"
        ),
    )


def fit_report(data, fit, numbers=None) -> dict:
    """The trust block of a fit of ``data`` (see the module docstring); ``numbers``:
    :func:`trust_numbers` of it when already computed (the command line's kept program), else
    computed on ``data`` padded to its length bucket (:func:`.batch_fit.bucketed`, as
    :func:`.polach_fit.fit_polach` pads: one compiled program per bucket, the same numbers to
    round-off)."""
    theta = np.asarray(fit.params, float)
    fixed = held_fixed(theta)
    numbers = trust_numbers(fit.params, scaled(bucketed(data), fit)) if numbers is None else numbers
    cov = np.asarray(numbers.cov)
    hac = np.sqrt(np.diag(cov))
    jackknife = jackknife_sd(numbers.jackknife)
    sd = np.maximum(hac, jackknife[:5])  # nan or inf (a singular direction) stays undetermined
    uncertainty, warnings, undetermined = {}, [], []
    for i, name in enumerate(PARAM_NAMES):
        if fixed[i] or not determined(sd[i]):
            uncertainty[name] = dict(UNDETERMINED)
            undetermined += [] if fixed[i] else [name]
            continue
        uncertainty[name] = {
            "stderr": float(sd[i]),
            "ci95": normal_interval(theta[i], sd[i], Z95, 0.0, 1.0),
            "stderr_hac": float(hac[i]),
            "stderr_jackknife": float(jackknife[i]),
        }
    on_bound = [n for n, f in zip(PARAM_NAMES, fixed, strict=True) if f]
    if on_bound:
        where = ", ".join(f"{n} = {theta[PARAM_NAMES.index(n)]:.3g}" for n in on_bound)
        warnings.append(
            _warning(
                "at_bound",
                on_bound,
                (
                    f"{where} on the bound of [0, 1]: no local standard error (null); the other "
                    "parameters' errors include their trade-off with it to first order only (along a "
                    "curved trade-off, as A's with B, their intervals can fall short; posterior "
                    "samples it)"
                ),
            )
        )
    weak = [n for i, n in enumerate(PARAM_NAMES) if not fixed[i] and not (2 * Z95 * sd[i] <= WEAK_WIDTH)]
    if weak:
        w_max = float(np.max(np.abs(np.asarray(data.slip))))
        ab = {"A", "B"} <= set(weak)
        rest = [n for n in weak if not ab or n not in ("A", "B")]
        parts = []
        if rest:
            parts.append(
                f"{', '.join(rest)}: 95 % interval wider than {WEAK_WIDTH} of the box or "
                "undetermined (singular direction); the data do not pin "
                f"{'it' if len(rest) == 1 else 'them'} down"
            )
        if ab:
            parts.append(
                f"only (1 − A)·B is determined at these slip velocities (|w| ≤ {w_max:.3g}"
                " m/s, where μ ≈ μ0·(1 − (1 − A)·B·|w|)): A and B separately are not"
            )
        warnings.append(_warning("weakly_identified", weak, "; ".join(parts)))
    status = status_of(fit.status)
    if not status.converged:
        warnings.append(
            _warning(
                "not_converged",
                [],
                (f"the solver stopped with status {status.label}: the parameters may not be a minimum"),
            )
        )
    level = float(np.mean(np.abs(np.asarray(data.adhesion, float))[valid_mask(data)]))
    if not float(fit.mae) < level:
        warnings.append(
            _warning(
                "worse_than_zero",
                PARAM_NAMES + DERIVED,
                (
                    f"the fitted curve is further from mu_hat (mean |residual| {float(fit.mae):.3g}) than "
                    f"a curve at zero is (mean |mu_hat| {level:.3g}): not a fit of these data, whatever "
                    "the solver's status"
                ),
            )
        )
    warnings += data_warnings(data)
    creep = np.abs(np.asarray(data.creep, float))[valid_mask(data)]
    speed = float(numbers.speed)
    derived, peak_warnings = peak_report(
        numbers.peak,
        numbers.peak_jacobian,
        cov,
        speed,
        float(numbers.max_creep),
        float(np.min(creep)) if creep.size else 0.0,
        jackknife[5:],
    )
    undetermined += [n for w in peak_warnings if w["code"] == "undetermined" for n in w["params"]]
    if undetermined:  # one warning for the parameters and the peak
        warnings.append(undetermined_warning(undetermined))
    corr = correlation(cov)
    return {
        "uncertainty": uncertainty,
        "correlation": [[float(c) if np.isfinite(c) else None for c in row] for row in corr],
        "warnings": warnings + [w for w in peak_warnings if w["code"] != "undetermined"],
        "hac_lags": int(numbers.lags),
        "jackknife_blocks": JACKKNIFE_BLOCKS,
        "derived": derived,
        "vehicle_speed": speed,
    }


def normal_intervals(report: dict, params: dict, z: float) -> dict:
    """``{name: [lo, hi] or None}`` for the five parameters (values ``params``) and the peak
    quantities of a :func:`fit_report`, at the normal quantile ``z`` (e.g. :data:`.uncertainty.Z90`)
    from its standard errors, clipped as its ``ci95`` are (parameters to [0, 1], ``mu_max`` to
    [0, MU_BOX_MAX], ``creep_opt`` on the log scale to [S_MIN, S_MAX]); ``None`` where it has no
    standard error."""

    def interval(value, sd, lo, hi, log=False):
        return None if sd is None else normal_interval(value, sd / value if log else sd, z, lo, hi, log)

    out = {n: interval(params[n], report["uncertainty"][n]["stderr"], 0.0, 1.0) for n in PARAM_NAMES}
    mu, creep = report["derived"]["mu_max"], report["derived"]["creep_opt"]
    out["mu_max"] = interval(mu["value"], mu["stderr"], 0.0, MU_BOX_MAX)
    out["creep_opt"] = interval(creep["value"], creep["stderr"], S_MIN, S_MAX, log=True)
    return out


def joined_interval(own, other, other_value):
    """``[min, max]`` of the interval ``own`` and the other slip law's interval ``other`` (its
    estimate ``other_value`` alone where that law gives none: on a bound, or not determined);
    ``None`` where ``own`` is (this fit's ``at_bound``/``undetermined`` warnings stand)."""
    if own is None:
        return None
    lo, hi = (other_value, other_value) if other is None else other
    return [float(min(own[0], lo)), float(max(own[1], hi))]


def join_slip_laws(report: dict, params: dict, other: dict) -> dict:
    """``report`` (:func:`fit_report` of a fit with ``params`` {name: value} under one slip law)
    with every ``ci95`` of ``uncertainty`` and ``derived`` joined to the other law's
    (:func:`joined_interval`; this fit's own interval kept as ``ci95_hac``), plus the warning
    ``slip_law_sensitive`` naming the parameters and peak quantities whose estimate under the other
    law lies outside this fit's own 95 % interval. ``other``: that law's ``params`` and its
    :func:`fit_report` (``uncertainty``, ``derived``).

    Why: with crowded slips the curve's initial slope and μ0 depend on whether the smoother's error
    is Berkson (``normal``) or classical (``population``), which one recording cannot tell (README,
    "Which slip law"); an interval that holds under either must hold both laws' intervals. 90 %
    intervals joined so held the truth on 72 recordings of our simulator at 1× and 2× realistic
    sensor noise: kS 68, μ0 65, μ_max 63, creep_opt 69 (the normal law's alone: 56, 39, 41, 66;
    ``benchmarks/results/coverage_fit_slip_law_both.json``)."""
    out = {**report, "uncertainty": dict(report["uncertainty"]), "derived": dict(report["derived"])}
    moved = []
    for block, values, other_values in (
        ("uncertainty", params, other["params"]),
        (
            "derived",
            {k: v["value"] for k, v in report["derived"].items()},
            {k: v["value"] for k, v in other["derived"].items()},
        ),
    ):
        for name, entry in report[block].items():
            own, theirs = entry["ci95"], other[block][name]["ci95"]
            value = other_values[name]
            out[block][name] = {**entry, "ci95": joined_interval(own, theirs, value), "ci95_hac": own}
            if own is not None and not own[0] <= value <= own[1]:
                moved.append((name, values[name], value))
    out["warnings"] = _weak_when_joined(report["warnings"], out["uncertainty"])
    if moved:
        change = ", ".join(f"{n} {a:.4g} → {b:.4g}" for n, a, b in moved)
        out["warnings"] = out["warnings"] + [
            _warning(
                "slip_law_sensitive",
                [n for n, _, _ in moved],
                (
                    f"under the other slip law ({change}) the estimate leaves this fit's own 95 % interval: "
                    "whether the smoother's slip error is Berkson or classical, which one recording cannot "
                    "tell, moves the curve; the 95 % intervals (ci95) join both laws' (ci95_hac: this law's)"
                ),
            )
        ]
    return out


def _weak_when_joined(warnings: list, uncertainty: dict) -> list:
    """``warnings`` with ``weakly_identified`` also naming the parameters whose joined ``ci95``
    (:func:`join_slip_laws`) is wider than :data:`WEAK_WIDTH` of the box, not only those whose own
    law's is: the warning follows the interval reported (a kA of [0, 1] went unnamed)."""
    wide = [
        n for n in PARAM_NAMES if (c := uncertainty[n]["ci95"]) is not None and not c[1] - c[0] <= WEAK_WIDTH
    ]
    old = next((w for w in warnings if w["code"] == "weakly_identified"), None)
    new = [n for n in wide if old is None or n not in old["params"]]
    if not new:
        return warnings
    part = (
        f"{', '.join(new)}: the 95 % interval joining both slip laws' is wider than {WEAK_WIDTH} of the "
        "box; the data under either law do not pin "
        f"{'it' if len(new) == 1 else 'them'} down"
    )
    if old is None:
        return warnings + [_warning("weakly_identified", new, part)]
    merged = _warning("weakly_identified", old["params"] + new, f"{old['message']}; {part}")
    return [merged if w is old else w for w in warnings]


def join_posterior_intervals(summary: dict, check: dict) -> dict:
    """``summary`` ({name: {``median``, ``q05``, ``q95``}}, a posterior's parameters or peak
    quantities) with each of ``check``'s quantities' ``q05``/``q95`` widened to hold the other slip
    law's LM 90 % interval (its estimate alone where it has none; ``check``: ``jadhesion
    posterior``'s ``slip_law_check``, with ``params``, ``derived`` and ``interval90`` from
    :func:`normal_intervals`), the posterior's own kept as ``q05_posterior``/``q95_posterior``;
    noise parameters unchanged. The posterior's counterpart of :func:`join_slip_laws`."""
    out = dict(summary)
    for name, entry in summary.items():
        if name not in check["interval90"]:
            continue
        value = {**check["params"], **check["derived"]}[name]
        own = [entry["q05"], entry["q95"]]
        lo, hi = joined_interval(own, check["interval90"][name], value)
        out[name] = {**entry, "q05": lo, "q95": hi, "q05_posterior": own[0], "q95_posterior": own[1]}
    return out
