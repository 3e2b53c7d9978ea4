"""A null for this recording: the distribution of each candidate's statistic on clean
re-synthesised versions of the very recording (parametric bootstrap), and max-T p-values.

**Regressors.** Every diagnosis fit (recording and replicas) takes as its speeds the latent ones
of the Kalman/RTS smoother (:func:`latent_speeds`, :func:`jadhesion.data.creep_state.smooth_creep`):
white sensor noise is mostly removed from the creep before it meets Polach's steep initial slope
(errors in variables); the target ``mu_hat`` is the measured torque less ``J ω̇`` of the latent
wheel speed. What slip error is left is weighted by Orear's effective variance
(:func:`jadhesion.diagnose.fitting.eiv_weights`), the same weights in recording and replicas.

**Re-synthesis** (without coasting; with it, below). A replica keeps the recording's measured speeds
(so its regressors are the recording's) and replaces the torque by what a clean Polach wheelset
would have needed along a "true" creep path: the base fit's adhesion (where the base fit sits at the
identification box's upper edge in μ0, the fit past that edge,
:func:`jadhesion.diagnose.fitting.fit_truth`: the replicas then carry the box's misfit as the
recording does) along the speeds ``x̄ + γ (x̂ − x̄)``, where ``x̂`` are the latent speeds and ``x̄``
their centred moving average over ±:data:`SLOW_HALF_WIDTH_S`. The regressor then differs from the
replica's truth by ``(1 − γ)(x̂ − x̄)``: *classical* errors in variables (the truth is the smoother,
slower path; the regressor scatters about it), which dilute Polach's slope and push an intercept
into the fits as the recording's own sensor errors do. (A truth scattered about the regressor
instead — Berkson errors — leaves the slope undiluted: such replicas gave radius/offset statistics
20× and more below the recording's on an effect-free recording of our simulator at realistic sensor
noise.) γ ∈ [0, 1] is the largest value on :data:`GAMMA_GRID` whose replica residual *fast* power
about the base fit (its first difference, :func:`fast_power`) reaches the upper 95 % confidence
bound of the recording's own (:func:`fast_power_bound`, :func:`error_share`): the regressors'
remaining error is not observable, and γ gives the replicas as much as the recording's fast residual
allows. (Matched on the estimate itself, γ was a coin toss wherever the error's whole fast power
lies within the estimate's sampling error, ~3 % at 2 000 samples: on two clean wet recordings of
ours γ came out 1, replicas without errors in variables, and the radius error's 4–7 % SSE reduction
was named against a critical value of 0.4 %.) (Matched on the whole residual power instead, a
concealed slow effect raised γ's error to its maximum and the null swallowed effects of any size: a
33 % rail change got p = 1.) The torque follows the wheelset dynamics along the latent wheel speed,
``T/(m g r) = μ_base + J ω̂̇/(m g r)``, plus torque noise drawn from the model estimated on the
recording (:func:`noise_model`: white level σ, quantisation step q); the target, whose ``J ω̇`` is
the same latent derivative in recording and replica
(:func:`jadhesion.diagnose.signals.from_columns`), is then ``μ_base`` + torque noise. The replicas
share the recording's errors-in-variables weights (the ``mask`` of :func:`null_statistics`). The
fast part of the regressor error of such a replica is one fixed path, so replicas differ only by
their torque noise (and the white noise's smoother error, below).
That serves where the torque noise dominates the replicas' fast residual; where the fixed path
adds more (``path_power``, the fast power of ``μ(x̄ + γ(x̂ − x̄)) − μ(x̂)``, above the torque
noise's: the independent generator's coloured sensor noise, 3 to 6 850× the torque noise's), the
19 replicas gave nearly one statistic, which the recording's own error realisation beat about as
often as not. There each replica's regressor wheel speed swaps the latent slip's fast part ``f``
(slip less its moving average) for a fresh stationary Gaussian path ``g_r`` with ``f``'s robust
level and autocorrelation (:func:`fast_slip_error`): ``v̂_w + (1 − γ)(g_r − f)``, so its slip
error about the truth is ``(1 − γ) g_r``, drawn afresh per replica (``error.fresh``). Measured
(``benchmarks/results/diagnose_null_{foreign,ours}_*_fresh.json``, 2026-11-29, three seeds): 40 of
the independent generator's 41 clean recordings without coasting and 4 of our 96 took this path;
false alarms 8 → 5 of 96 there and 4 → 3 of 96 on ours, with no verdict lost on either blind set.
On every recording without coasting, whatever the powers, it cost our blind set 4 of its 7 named
effects: there the fast part is mostly real slip motion, and as error it widened the null.
**The smoother's own error from white sensor noise** is in every replica without coasting too
(:func:`white_smoother_errors`, ``error.white``): the smoother re-run on the latent speeds plus
fresh white noise at each speed channel's measured level and quantisation, its departure from
the latent speeds added to the replica's regressors. White sensor noise is what the smoother's
third-difference estimate measures, so this much error the recording's regressors carry for
certain; the smoother turns it into slow error (averaged over the seconds the slip may vary),
which the fast-part share above cannot reach. Without it, clean recordings of a third, kinematic
generator (mainline speeds, white speed noise of 0.01 m/s at 50 Hz, no coasting) were named a
rail change (p = 0.05 against a critical SSE reduction of 0.022) and a radius error (0.008);
with it their critical values were 0.09 and 0.11, and the verdict none.

**Where the recording coasts** (:func:`coasting_error`: at least
:data:`~jadhesion.data.creep_state.COAST_MIN_SAMPLES` samples moving with ``|μ̂|`` below
:data:`~jadhesion.data.creep_state.COAST_ADHESION`), the true slip is a small known fraction of the
sensors' noise, so the smoothed slip there *is* its error: its level against the regressors'
sd (:func:`jadhesion.data.creep_state.coasting_sd_scale`; the smoother's sd falls 1.0–8.3× short
on the independent generator, and :func:`latent_speeds` has already scaled it by that, so this
``scale`` is what remains: 1.00–1.01 on 22 such recordings, the two μ̂ that pick the coasting
samples differing slightly) and
its autocorrelation (:func:`error_autocorrelation`, pooled within the coasting runs) are
measured on this recording. The truth is then the latent speeds, and each replica's regressors are
the smoother re-run (:func:`jadhesion.data.creep_state.smooth_creep`) on fresh raw signals: the
latent speeds plus white noise at each speed channel's measured level and quantisation step
(:func:`noise_model`, the smoother's own third-difference estimate), the wheel channel plus an
AR(1) colour (:func:`ar1_paths`) of the coasting error's level and the correlation time its
autocorrelation has at :data:`COLOUR_LAG_S`, and the replica's torque. The errors in variables are
then the smoother's answer to coloured sensor noise, as in the recording. Adding a stationary path
of the measured level and autocorrelation to the latent wheel speed instead (before 2026-11-29)
left the null too narrow: on the independent generator's clean recordings taking this path, 23 of
83 had a min p ≤ 0.05; against 19 of the generator's own replicas (same world, fresh sensor noise)
its critical values were 0.572, 0.456, 0.038, 0.104 on four of them where the generator's 90 %
points are 0.506, 0.676, 0.265, 0.308; re-smoothed, 0.639, 0.599, 0.259, 0.116 (recordings 47016,
47020, 47017, 47002). Our simulator's recordings coast only when asked (``simulate --coast``).

**Test.** The statistic of candidate c is its in-sample relative reduction of the sum of squares
against the base fit, ``T_c = 1 − SSE_c/SSE_0`` (no cross-validation folds in the null: the
replicas are fitted on all data only, one compiled program for a replica's candidates, one after
another by ``lax.map``; the replicas on :func:`workers` threads, so memory grows with the cores,
not with R). With ``M_r = max_c T_{r,c}`` the largest
statistic among replica r's candidates, c's p-value is ``(1 + #{r: M_r ≥ T_c})/(R + 1)``
(single-step max-T, Westfall & Young 1993): rejecting at ``p ≤ α`` holds the family-wise false
alarm rate over all candidates at α by construction (up to the re-synthesis being faithful).
Bonferroni or Holm would need R ≥ 7/α − 1 = 139 replicas to be able to reject at all.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import jax
import jax.numpy as jnp
import numpy as np

from ..data.creep_state import (
    COAST_MIN_SAMPLES,
    coasting_residual,
    coasting_scale,
    coasting_sd_scale,
    difference_sd,
    smooth_creep,
)
from ..data.observer import lowpass_foh
from ..data.sensors import ar1_path
from ..data.vehicle import GRAVITY, Vehicle
from ..identify.uncertainty import Z90
from ..status import Status
from . import extensions as ext
from . import fitting
from .features import starting_values_at
from .signals import torque_builder

#: Replicas of the null (the smallest R for which p ≤ 0.05 is attainable is 19) and the level.
N_REPLICAS = 19
ALPHA = 0.05
#: Most threads fitting replicas at once: each holds one fit's working memory (at 180 000 samples
#: the whole diagnosis peaked at 1.46 GB with two), so many cores must not multiply it unbounded.
MAX_WORKERS = 4
#: Shares γ of the latent speeds' fast part kept as true motion in the replicas, tried from 1 down.
GAMMA_GRID = 1.0 - np.array(
    [0.0, 0.002, 0.005, 0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0]
)
#: Half-width [s] of the moving average that separates the latent speeds' slow path from their
#: fast part (what the replicas may treat as regressor error).
SLOW_HALF_WIDTH_S = 2.0
#: Longest lag [s] of the coasting error's autocorrelation (:func:`error_autocorrelation`).
ERROR_MAX_LAG_S = 4.0
#: Lag [s] at which the coasting error's autocorrelation sets the colour's correlation time in the
#: re-smoothed replicas (short: the coasting runs measure it well; 0.1–4 s runs).
COLOUR_LAG_S = 0.25
#: Contiguous batches of :func:`fast_power_bound`.
N_BATCHES = 40
#: Signals on a quantisation grid: at least this share of their changes within GRID_TOL of a
#: multiple of the step.
GRID_SHARE = 0.9
#: Tolerance [steps] of "on the grid" (CSV files keep a finite number of digits).
GRID_TOL = 1e-3


def _fit_replica(starts, idx, actives, sig, n_valid):
    """In-sample :func:`fitting.fit_candidates` (no folds) of one replica: ``(sse (C,), status (C,))``.
    Not wrapped in a jit of its own: the call reuses the base fit's compiled program (same rows and
    padded length), where a wrapper compiled the same fits again (~3 s of a cold diagnosis)."""
    table = fitting.fit_candidates(starts, idx, actives, sig, n_valid, folds=False, upper=fitting.UPPER)
    return table.sse, table.status


def noise_model(x) -> dict:
    """``{"sigma", "rho", "q"}`` of one signal's noise (the torque): white level [signal units]
    from the third difference (:func:`jadhesion.data.creep_state.difference_sd`, the smoother's
    own: ``1.4826 MAD(Δ³x)/√20``; the MAD ignores command steps), with the quantisation's ``q²/12``
    taken out (:func:`grid_step`; put back by rounding the replica to the grid); ``rho = 0``. An
    AR(1) fit to the second difference, used before, read white + AR(1) torque noise of the
    independent generator as 10–60× its level (ρ at the grid's end, 0.98): correlated torque noise
    is not separable from the torque's own motion in one recording."""
    x = np.asarray(x, float)
    sigma = float(difference_sd(x))
    q = grid_step(x)
    white = np.sqrt(max(sigma * sigma - q * q / 12.0, 0.25 * sigma * sigma))
    return {"sigma": float(white), "rho": 0.0, "q": q}


def _noisy(clean, model, rng):
    """``clean`` plus white noise of the model's level, then quantised (:func:`noise_model`'s
    ``rho`` is always 0)."""
    x = clean + model["sigma"] * rng.standard_normal(clean.size)
    return np.round(x / model["q"]) * model["q"] if model["q"] > 0 else x


def grid_step(x) -> float:
    """Quantisation step of a signal (0 when its changes are not multiples of one step): the smallest
    change, refined by least squares over all changes ``Δx ≈ m q`` (a CSV's ~10 significant digits
    leave the smallest change alone good to ~1e-6 relative, too coarse to test thousands of steps
    up a speed of 7 m/s against the grid)."""
    steps = np.abs(np.diff(np.asarray(x, float)))
    steps = steps[steps > 0]
    if not steps.size:
        return 0.0
    q = float(np.min(steps))
    m = np.round(steps / q)
    q = float(np.dot(m, steps) / np.dot(m, m))
    on_grid = np.mean(np.abs(steps / q - np.round(steps / q)) < GRID_TOL) >= GRID_SHARE
    return q if on_grid else 0.0


def latent_speeds(columns: dict, vehicle: Vehicle) -> tuple:
    """``((v̂, v̂_w, sd_w), scale)``: the Kalman/RTS smoother's latent vehicle and wheel speeds
    [m/s] and the slip's standard deviation [m/s] (:func:`jadhesion.data.creep_state.smooth_creep`),
    the regressors of every diagnosis fit; ``sd_w`` is the smoother's times ``scale``, the factor
    by which the recording's coasting shows it understated
    (:func:`jadhesion.data.creep_state.coasting_sd_scale`; 1 without coasting), as ``fit``'s
    dataset does (:func:`jadhesion.data.dataset.to_dataset`). Unscaled, the independent
    generator's coloured speed sensors left slip errors of 5–10 mm/s against an sd of 1 mm/s on
    its starts: the sign-truncated law then put walking-pace samples at zero slip with full
    weight, and a rail change took up their misfit."""
    est = smooth_creep(
        *(np.asarray(columns[k], float) for k in ("time", "wheel_speed", "vehicle_speed", "traction_torque")),
        vehicle.wheelset_inertia_kgm2,
        vehicle.wheel_radius_m,
        vehicle.axle_load_kg,
    )
    scale, _ = coasting_sd_scale(est.slip, est.slip_sd, est.adhesion, est.vehicle_speed)
    v = np.asarray(est.vehicle_speed)
    return (v, v + np.asarray(est.slip), float(scale) * np.asarray(est.slip_sd)), float(scale)


def local_mean(x, half: int) -> np.ndarray:
    """Centred moving average over ``2·half + 1`` samples (edges padded with the end values)."""
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    return np.convolve(np.pad(np.asarray(x, float), half, mode="edge"), kernel, mode="valid")


def _fast_squares(r, keep) -> np.ndarray:
    """Squared first differences of a residual over pairs of selected samples, in time order."""
    d = np.diff(np.asarray(r, float))
    both = np.asarray(keep[1:], bool) & np.asarray(keep[:-1], bool)
    return d[both] ** 2


def fast_power(r, keep) -> float:
    """Mean square of the first difference of a residual over pairs of selected samples: its fast
    part, which slowly varying effects (rail change, speed dependence, heating, load) leave alone."""
    return float(np.mean(_fast_squares(r, keep)))


def fast_power_bound(r, keep) -> float:
    """One-sided upper 95 % confidence bound of :func:`fast_power`: the mean plus
    :data:`~jadhesion.identify.uncertainty.Z90` (the normal's 95 % quantile) standard errors by
    batch means over :data:`N_BATCHES` contiguous batches (robust to the squares' correlation over
    less than a batch)."""
    x = _fast_squares(r, keep)
    batches = np.array([b.mean() for b in np.array_split(x, max(1, min(N_BATCHES, x.size))) if b.size])
    se = batches.std(ddof=1) / np.sqrt(batches.size) if batches.size > 1 else 0.0
    return float(x.mean() + Z90 * se)


def error_share(data_power: float, torque_power: float, power_of) -> float:
    """The largest γ on :data:`GAMMA_GRID` (from 1 down) whose replica residual fast power
    ``power_of(γ) + torque_power`` (:func:`fast_power`) reaches ``data_power``, the upper
    confidence bound of the recording's own (:func:`fast_power_bound`; 0 when none does)."""
    for gamma in GAMMA_GRID:
        if power_of(gamma) + torque_power >= data_power:
            return float(gamma)
    return 0.0


def coasting_error(latent, adhesion) -> dict | None:
    """The smoothed slip's error as the recording's coasting shows it
    (:func:`jadhesion.data.creep_state.coasting_residual`), or None with fewer than
    :data:`~jadhesion.data.creep_state.COAST_MIN_SAMPLES` coasting samples: ``{"scale", "samples",
    "z", "runs"}``, the factor by which the smoother's slip sd understates it
    (:func:`jadhesion.data.creep_state.coasting_scale`), the coasting samples, the
    standardised error ``z`` (n,) (0 off coasting) and the coasting runs ``[start, stop)`` for
    :func:`error_autocorrelation`. ``latent = (v̂, v̂_w, sd_w)`` [m/s]; ``adhesion`` μ̂ [-]."""
    v, vw, sd = (np.asarray(x, float) for x in latent)
    coast, z = coasting_residual(vw - v, sd, np.asarray(adhesion, float), v)
    scale, count = (float(x) for x in coasting_scale(coast, z))
    if count < COAST_MIN_SAMPLES:
        return None
    coast, z = np.asarray(coast), np.asarray(z)
    return {"scale": scale, "samples": int(count), "z": z, "runs": runs_of(coast)}


def runs_of(mask) -> list:
    """The runs ``[start, stop)`` of consecutive true samples of a boolean mask (n,)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], np.asarray(mask, bool).astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2], strict=True))


def error_autocorrelation(z, runs, max_lag: int) -> np.ndarray:
    """Autocorrelation (max_lag + 1,) of ``z`` pooled over pairs within each run ``[a, b)``."""
    num, cnt = np.zeros(max_lag + 1), np.zeros(max_lag + 1)
    for a, b in runs:
        seg = z[a:b]
        for k in range(min(max_lag + 1, seg.size)):
            num[k] += np.dot(seg[: seg.size - k], seg[k:])
            cnt[k] += seg.size - k
    acov = np.where(cnt > 0, num / np.maximum(cnt, 1), 0.0)
    return acov / acov[0]


def gaussian_paths(rho, n: int, n_paths: int, rng) -> list:
    """Stationary Gaussian paths (n,) of unit variance with autocorrelation ``rho`` (lags 0…K,
    Bartlett-tapered, 0 beyond) by circulant embedding (the spectrum clipped at 0)."""
    k = rho.size - 1
    taper = rho * (1.0 - np.arange(k + 1) / (k + 1))
    m = 1 << int(np.ceil(np.log2(2 * (n + k))))
    c = np.zeros(m)
    c[: k + 1] = taper
    c[m - k :] = taper[1:][::-1]
    root = np.sqrt(np.maximum(np.fft.rfft(c).real, 0.0))
    return [np.fft.irfft(root * np.fft.rfft(rng.standard_normal(m)), n=m)[:n] for _ in range(n_paths)]


#: :func:`jadhesion.data.sensors.ar1_path` of unit sd for each row of standard normal draws (R, n).
ar1_paths = jax.jit(jax.vmap(ar1_path, in_axes=(0, None, None)))


def fast_slip_error(fast_slip, keep, max_lag: int) -> tuple:
    """``(level [m/s], autocorrelation (max_lag + 1,))`` of the latent slip's fast part on the
    selected samples ``keep``, the error a replica without coasting draws afresh: the level robust
    (``1.4826 MAD``: real slip excursions are the fast part's tail, not its bulk), the
    autocorrelation pooled within the selected runs (:func:`error_autocorrelation`)."""
    fast_slip, keep = np.asarray(fast_slip, float), np.asarray(keep, bool)
    level = float(1.4826 * np.median(np.abs(fast_slip[keep]))) if keep.any() else 0.0
    z = np.where(keep, fast_slip, 0.0) / (level if level > 0 else 1.0)
    return level, error_autocorrelation(z, runs_of(keep), max_lag)


def resmoothed(time, speed, wheel, sensors, vehicle: Vehicle, rng) -> tuple:
    """``(v, v_w)`` [m/s]: the smoother's latent speeds
    (:func:`jadhesion.data.creep_state.smooth_creep`, which does not use the torque for them) of the
    raw vehicle and wheel speeds ``speed``, ``wheel`` [m/s] plus fresh white noise, quantised, at
    the levels of ``sensors = (vehicle_speed, wheel_speed)`` (:func:`noise_model` of the
    recording's raw speeds)."""
    est = smooth_creep(
        time,
        _noisy(wheel, sensors[1], rng),
        _noisy(speed, sensors[0], rng),
        np.zeros_like(np.asarray(time, float)),
        vehicle.wheelset_inertia_kgm2,
        vehicle.wheel_radius_m,
        vehicle.axle_load_kg,
    )
    v = np.asarray(est.vehicle_speed)
    return v, v + np.asarray(est.slip)


def white_smoother_errors(time, latent, sensors, vehicle: Vehicle, n_replicas: int, rng) -> list:
    """What white sensor noise alone leaves in the smoother's latent speeds, one draw per replica:
    ``[(δv, δv_w)] × R`` [m/s], :func:`resmoothed` of the latent speeds ``latent = (v̂, v̂_w, …)``
    less the latent speeds (``sensors``: the smoother's own third-difference levels). The smoother
    averages such noise over the seconds its process model lets the slip vary, so its error is
    slow, correlated over seconds, and at low creep steep enough on Polach's curve to look like a
    slow effect."""
    out = []
    for _ in range(n_replicas):
        v, vw = resmoothed(time, latent[0], latent[1], sensors, vehicle, rng)
        out.append((v - latent[0], vw - latent[1]))
    return out


def replicas(
    torque, measured, vehicle: Vehicle, p_truth, n_replicas: int, seed: int, latent, speeds
) -> tuple:
    """``([(torque [N·m], regressors (v, v_w, sd_w) [m/s])] × R, {"torque": noise model, "gamma",
    "fast_power", "error"})``: each replica's torque, re-synthesised from the Polach curve
    ``p_truth`` (the base fit, or where that sits at the identification box's edge the fit past
    it: :func:`jadhesion.diagnose.fitting.fit_truth`) plus the recording's torque noise, and the
    regressors its fits take (module docstring). Where the recording coasts
    (:func:`coasting_error`), the truth is the latent speeds ``latent = (v̂, v̂_w, sd_w)`` and each
    replica's regressors are the smoother re-run on fresh raw speeds, white and quantised as the
    recording's raw ``speeds = (v, v_w)`` [m/s], the wheel's coloured as its coasting error
    (``gamma`` None; ``error``: ``source`` "coasting", ``coasting_samples``, ``sd_scale``,
    ``autocorrelation_1s``, ``colour_level`` [m/s], ``colour_tau_s`` [s], ``sensors``); otherwise
    the truth is the speeds ``x̄ + γ (x̂ − x̄)``
    and the regressors the latent speeds plus the white sensor noise's smoother error
    (:func:`white_smoother_errors`; ``error.white``: its ``slip_rms`` [m/s] and the ``sensors``)
    (``error.source`` "fast_part", with ``path_power`` and
    ``fresh``: where that path's fast power beats the torque noise's, each replica's regressor
    wheel speed swaps the fast part for a fresh path of its ``level`` [m/s] and
    ``autocorrelation_1s``). ``torque``: the
    recording's; ``measured``: its :class:`Signals` on the latent speeds, whose weights select the
    samples γ is matched on. ``fast_power`` [-, adhesion²]: the recording's residual fast power
    (``recording``) and its upper bound (``upper95``, :func:`fast_power_bound`), the torque
    noise's (``torque_noise``) and what the whole fixed error path adds at γ = 0 (``error_path``)."""
    torque = np.asarray(torque, float)
    keep = np.asarray(measured.weight) > 0
    t = np.asarray(measured.time)
    dt = float(np.median(np.diff(t)))
    half = max(1, int(round(SLOW_HALF_WIDTH_S / dt)))
    slow = [local_mean(x, half) for x in latent[:2]]
    scale = vehicle.axle_load_kg * GRAVITY * vehicle.wheel_radius_m
    none = np.zeros(ext.N_EXTRA, bool)
    exact = measured._replace(slip_sd=np.zeros_like(latent[2]))  # the replica's truth: no slip error
    model = noise_model(torque)

    def path_mu(gamma):
        v, vw = (xs + gamma * (x - xs) for xs, x in zip(slow, latent[:2], strict=True))
        return np.asarray(ext.predict(np.asarray(p_truth), none, exact._replace(speed=v, wheel_speed=vw))[1])

    mu_fit = path_mu(1.0)
    torque_power = (2.0 * model["sigma"] ** 2 + model["q"] ** 2 / 6.0) / scale**2
    residual = np.asarray(measured.adhesion) - mu_fit
    powers = {
        "recording": fast_power(residual, keep),
        "upper95": fast_power_bound(residual, keep),
        "torque_noise": torque_power,
        "error_path": fast_power(path_mu(0.0) - mu_fit, keep),
    }
    rng = np.random.default_rng(seed)
    deriv = np.asarray(measured.deriv_mu)
    coast = coasting_error(latent, measured.adhesion)
    sensors = [noise_model(x) for x in speeds]
    max_lag = max(1, int(round(ERROR_MAX_LAG_S / dt)))
    lag_1s = min(max_lag, int(round(1.0 / dt)))
    if coast is None:
        gamma = error_share(powers["upper95"], torque_power, lambda g: fast_power(path_mu(g) - mu_fit, keep))
        mu_gamma = path_mu(gamma)
        clean_torque = (mu_gamma + deriv) * scale
        path_power = fast_power(mu_gamma - mu_fit, keep)
        error = {"source": "fast_part", "fresh": bool(path_power > torque_power), "path_power": path_power}
        white = white_smoother_errors(t, latent, sensors, vehicle, n_replicas, rng)
        error["white"] = {
            "slip_rms": float(np.sqrt(np.mean([np.mean((dw - dv)[keep] ** 2) for dv, dw in white]))),
            "sensors": {"vehicle_speed": sensors[0], "wheel_speed": sensors[1]},
        }
        if error["fresh"]:
            fast_slip = (latent[1] - slow[1]) - (latent[0] - slow[0])
            level, rho = fast_slip_error(fast_slip, keep, max_lag)
            paths = gaussian_paths(rho, t.size, n_replicas, rng)
            shifts = [(1.0 - gamma) * (level * z - fast_slip) for z in paths]
            error.update(level=level, autocorrelation_1s=float(rho[lag_1s]))
        else:  # the fast part's error is one fixed path, shared by every replica
            shifts = [0.0] * n_replicas
        draws = [
            (_noisy(clean_torque, model, rng), (latent[0] + dv, latent[1] + d + dw, latent[2]))
            for d, (dv, dw) in zip(shifts, white, strict=True)
        ]
        return draws, {"torque": model, "gamma": gamma, "fast_power": powers, "error": error}
    rho = error_autocorrelation(coast["z"], coast["runs"], max_lag)
    clean_torque = (mu_fit + deriv) * scale
    lag = min(max_lag, max(1, int(round(COLOUR_LAG_S / dt))))
    level = coast["scale"] * float(np.median(np.asarray(latent[2], float)))
    tau = -lag * dt / float(np.log(np.clip(rho[lag], 0.01, 0.99)))
    colour = np.asarray(
        ar1_paths(jnp.asarray(rng.standard_normal((n_replicas, t.size))), np.exp(-dt / tau), 1.0)
    )
    draws = []
    for c in colour:
        replica_torque = _noisy(clean_torque, model, rng)
        v, vw = resmoothed(t, latent[0], latent[1] + level * c, sensors, vehicle, rng)
        draws.append((replica_torque, (v, vw, latent[2])))
    error = {
        "source": "coasting",
        "coasting_samples": coast["samples"],
        "sd_scale": coast["scale"],
        "autocorrelation_1s": float(rho[lag_1s]),
        "colour_level": level,
        "colour_tau_s": tau,
        "sensors": {"vehicle_speed": sensors[0], "wheel_speed": sensors[1]},
    }
    return draws, {"torque": model, "gamma": None, "fast_power": powers, "error": error}


def null_statistics(
    columns,
    mask,
    latent,
    vehicle,
    p_truth,
    p_base,
    round_rows,
    merge,
    n_valid: int,
    n_replicas=N_REPLICAS,
    seed=0,
) -> tuple:
    """``(statistics (R, C − 1), noise model)``: every replica's :func:`statistic` of the
    round-1 candidates.

    ``round_rows(drop, u_change) -> (starts, idx, actives)`` gives the round-1 rows (base first)
    from the rail change's starts, and ``merge(table) -> table`` the recording's post-processing
    (best start of an effect with extra starts); ``mask`` its fit weights (> 0 on the selected
    samples); ``latent`` its :func:`latent_speeds`; ``p_truth`` the curve the replicas are
    re-synthesised from (:func:`replicas`), ``p_base`` the recording's base fit. Each replica's
    signals are built from its torque and regressors (:func:`torque_builder`, the recording's
    weights ``mask``), and each picks its data-driven starts — the rail change's time and size,
    the thermal lag — from its own residual at ``p_base``
    (:func:`jadhesion.diagnose.features.starting_values_at`), as the recording picked its own:
    with the recording's starts, a replica's rail change started at a time chosen for another
    series' noise and its LM ended in a lesser local optimum, so the null of that candidate was
    too narrow. They are fitted on :func:`workers` threads (XLA runs them in parallel; the
    results are those of one after another).
    """
    torque = columns["traction_torque"]
    on_latent = torque_builder(columns, vehicle, mask=mask, regressors=latent)
    speeds = (columns["vehicle_speed"], columns["wheel_speed"])
    draws, model = replicas(torque, on_latent(torque), vehicle, p_truth, n_replicas, seed, latent, speeds)

    def fit(draw):
        replica_torque, regressors = draw
        build = (
            on_latent
            if regressors is latent
            else torque_builder(columns, vehicle, mask=mask, regressors=regressors)
        )
        sig = build(replica_torque)
        drop, u_change, tau_heat = starting_values_at(sig, p_base)
        sig = sig._replace(heat=lowpass_foh(sig.time, sig.power, tau_heat))
        sse, status = _fit_replica(*round_rows(drop, u_change), fitting.pad_signals(sig), n_valid)
        return statistic(merge({"sse": np.array(sse), "status": np.array(status)}), converged_only=False)

    with ThreadPoolExecutor(workers(n_replicas)) as pool:
        stats = list(pool.map(fit, draws))
    return np.array(stats), model


def workers(n_replicas: int) -> int:
    """Threads fitting the replicas: one per CPU core this process may use, at most one per replica
    and :data:`MAX_WORKERS`."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return max(1, min(cores, n_replicas, MAX_WORKERS))


def statistic(table: dict, converged_only: bool = True) -> np.ndarray:
    """``1 − SSE_c/SSE_0`` of the candidates (rows 1…) of a fit table against its base row 0;
    −inf where a fit did not converge (such a candidate of the recording is never ranked).

    ``converged_only=False`` (the replicas): −inf only where the SSE is not finite. LM accepts only
    decreases, so a stalled fit's SSE bounds its optimum from above and its reduction is a lower
    bound; dropping it instead took that candidate out of the replica's max, which made the null
    narrower than the fits it stands for."""
    ok = table["status"][1:] == int(Status.CONVERGED) if converged_only else np.isfinite(table["sse"][1:])
    return np.where(ok, 1.0 - table["sse"][1:] / table["sse"][0], -np.inf)


def max_t_pvalues(observed, null) -> np.ndarray:
    """Max-T p-values of the observed statistics (C,) against the replicas' (R, C)."""
    top = np.max(null, axis=1)
    return (1.0 + np.sum(top[None, :] >= np.asarray(observed)[:, None], axis=1)) / (top.size + 1.0)
