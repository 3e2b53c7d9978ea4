"""A null for this recording: the distribution of each candidate's held-out gain on clean
re-synthesised versions of the very recording (parametric bootstrap), and max-T p-values.

**Re-synthesis.** A replica keeps the recording's own measured speeds (its speed and creep
history, with their noise) and replaces the torque: the replica's adhesion is the *base* Polach
fit along the locally averaged creep (:func:`local_mean`, 2·:data:`HALF` + 1 samples, short
enough to keep the slip excursions), and its torque follows the wheelset dynamics through the
observer exactly, ``T/(m g r) = μ_base + J d/(m g r)`` with ``d`` from the measured wheel speed,
so the observer returns ``μ_base``; then torque noise is drawn from the model estimated on the
recording (:func:`noise_model`: level σ, colour as AR(1) with coefficient ρ, quantisation step q
when the samples lie on a grid; the same model is reported for all three measured signals).
The regressors carry the recording's own speed noise while the replica's target does not follow
it, so the errors-in-variables bias of the base fit is present in the null too (only the part of
the speed noise that the local average removes; the wheel speed's noise cannot be told from the
stiff wheelset's slip dynamics by differences, so it is not re-drawn).

**Test.** Every replica runs the same round-1 candidate fits (one compiled program: vmapped over
candidates × cross-validation folds, replicas one after another by ``lax.map`` so the Jacobian
memory does not grow with R). With ``G_r = max_c gain_{r,c}`` the largest gain
among the replica's candidates, candidate c's p-value is ``(1 + #{r: G_r ≥ gain_c})/(R + 1)``
(single-step max-T, Westfall & Young 1993): rejecting at ``p ≤ α`` holds the family-wise false
alarm rate over all candidates at α by construction (up to the re-synthesis being faithful).
Bonferroni or Holm would need R ≥ 7/α − 1 = 139 replicas to be able to reject at all.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from scipy.signal import lfilter

from ..data.creep_state import difference_sd, smooth_creep
from ..data.observer import lowpass_foh
from ..data.vehicle import GRAVITY, Vehicle
from . import extensions as ext
from . import fitting
from .signals import from_columns

RAW = ("time", "vehicle_speed", "wheel_speed", "traction_torque")
#: Replicas of the null (the smallest R for which p ≤ 0.05 is attainable is 19) and the level.
N_REPLICAS = 19
ALPHA = 0.05
#: How replicas are made: ``"measured"`` keeps the recording's measured speeds (default) and
#: ``"latent"`` re-draws speed noise about the smoothed speeds (experimental: measured on four
#: clean foreign recordings of 30 s it flagged 1 of 3 finished and gave p = 1.0 to a 59 % gain on
#: the third, i.e. its replicas are not faithful yet — see the branch report).
RESYNTHESIS = "measured"
#: Half-width [samples] of the moving average separating a signal's noise from its dynamics.
HALF = 2
#: Samples on a quantisation grid: at least this share of |x/q − round(x/q)| below 1e-6.
GRID_SHARE = 0.9
#: Tolerance [steps] of "on the grid" (CSV files keep a finite number of digits).
GRID_TOL = 1e-3


@jax.jit
def _fit_batch(starts, idx, actives, batch, n_valid):
    """:func:`fitting.fit_candidates` of every replica in ``batch``, one after another."""
    return jax.lax.map(
        lambda s: fitting.fit_candidates(starts, idx, actives, s, n_valid)._replace(residual=jnp.zeros(0)),
        batch,
    )


def local_mean(x, half: int = HALF) -> np.ndarray:
    """Centred moving average over ``2·half + 1`` samples (edges padded with the end values)."""
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    return np.convolve(np.pad(np.asarray(x, float), half, mode="edge"), kernel, mode="valid")


def _second_difference_acf(rho):
    """Variance factor and lag-1 correlation of ``Δ²e`` for AR(1) noise ``e`` of unit variance."""
    c = np.array([1.0, -2.0, 1.0])
    lag = np.arange(-4, 5)
    gamma = rho[:, None] ** np.abs(lag)[None, :]
    cov = [sum(c[i] * c[j] * gamma[:, 4 + k + i - j] for i in range(3) for j in range(3)) for k in (0, 1)]
    return cov[0], cov[1] / cov[0]


RHO_GRID = np.linspace(0.0, 0.98, 99)
_VAR_FACTOR, _LAG1 = _second_difference_acf(RHO_GRID)


def noise_model(x) -> dict:
    """``{"sigma", "rho", "q"}`` of one signal's noise: level [signal units], AR(1) coefficient and
    quantisation step (0 when the samples are not on a grid). Estimated from the second difference
    ``Δ²x``, which suppresses the signal's slow dynamics (a 1 Hz swing is attenuated ~250× at
    50 Hz): ρ matches the lag-1 correlation of ``Δ²x`` to its AR(1) value (−2/3 for white noise),
    then ``σ² = var(Δ²x)/(6 − 8ρ + 2ρ²)``."""
    x = np.asarray(x, float)
    d2 = np.diff(x, 2)
    d2 = d2 - d2.mean()
    r1 = float(np.dot(d2[1:], d2[:-1]) / max(np.dot(d2, d2), 1e-300))
    k = int(np.argmin(np.abs(_LAG1 - r1)))
    rho = float(RHO_GRID[k])
    sigma = float(np.sqrt(np.mean(d2 * d2) / _VAR_FACTOR[k]))
    steps = np.abs(np.diff(x))
    steps = steps[steps > 0]
    q = float(np.min(steps)) if steps.size else 0.0
    on_grid = q > 0 and np.mean(np.abs(x / q - np.round(x / q)) < 1e-6) >= GRID_SHARE
    return {"sigma": sigma, "rho": rho, "q": q if on_grid else 0.0}


def _noisy(clean, model, rng):
    """``clean`` plus AR(1) noise of the model's level and colour, then quantised."""
    rho = model["rho"]
    e = (
        lfilter([1.0], [1.0, -rho], rng.standard_normal(clean.size))
        * model["sigma"]
        * np.sqrt(1.0 - rho * rho)
    )
    x = clean + e
    return np.round(x / model["q"]) * model["q"] if model["q"] > 0 else x


def _grid_step(x) -> float:
    """Quantisation step of a signal (0 when its samples are not on a grid)."""
    steps = np.abs(np.diff(x))
    steps = steps[steps > 0]
    q = float(np.min(steps)) if steps.size else 0.0
    on_grid = q > 0 and np.mean(np.abs(x / q - np.round(x / q)) < GRID_TOL) >= GRID_SHARE
    return q if on_grid else 0.0


def residual_model(raw, latent, floor: float = 0.0, q=None) -> dict:
    """``{"sigma", "rho", "q"}`` of a speed sensor's noise from its residual about the smoothed
    latent speed: lag-1 autocorrelation ρ (clipped to [0, 0.98]), the level σ with the
    quantisation's share q²/12 taken out (it is put back by rounding the replica to the grid)."""
    e = np.asarray(raw, float) - np.asarray(latent, float)
    e = e - e.mean()
    q = _grid_step(np.asarray(raw, float)) if q is None else q
    rho = float(np.clip(np.dot(e[1:], e[:-1]) / max(np.dot(e, e), 1e-300), 0.0, 0.98))
    sigma = float(np.sqrt(max(np.mean(e * e) - q * q / 12.0, 0.25 * np.mean(e * e), floor**2)))
    return {"sigma": sigma, "rho": rho, "q": q}


def replicas_measured(columns: dict, vehicle: Vehicle, p_base, n_replicas: int, seed: int) -> tuple:
    """``(replica column dicts, noise models)``, speeds kept as measured (the default, see
    :data:`RESYNTHESIS`): the torque follows the base fit along the locally averaged measured
    speeds, plus torque noise from :func:`noise_model`."""
    t = np.asarray(columns["time"], float)
    raw = {k: np.asarray(columns[k], float) for k in RAW}
    models = {k: noise_model(raw[k]) for k in RAW[1:]}
    slow = from_columns({"time": t, **{k: local_mean(raw[k]) for k in RAW[1:]}}, vehicle)
    _, mu = ext.predict(np.asarray(p_base), np.zeros(ext.N_EXTRA, bool), slow)
    measured = from_columns(raw, vehicle)
    scale = vehicle.axle_load_kg * GRAVITY * vehicle.wheel_radius_m
    clean_torque = (np.asarray(mu) + np.asarray(measured.deriv_mu)) * scale
    rng = np.random.default_rng(seed)
    out = [
        {**raw, "traction_torque": _noisy(clean_torque, models["traction_torque"], rng)}
        for _ in range(n_replicas)
    ]
    return out, models


def replicas_latent(columns: dict, vehicle: Vehicle, p_base, n_replicas: int, seed: int) -> tuple:
    """``(replica column dicts, noise models)`` re-synthesised from the smoothed latent speeds
    (experimental, :data:`RESYNTHESIS` = ``"latent"``): fresh speed noise (level and AR(1) from the
    residual about the RTS-smoothed speeds, floored by the Δ³ white level; quantised on the
    recording's grid), torque = base fit along the latent creep + the latent wheel dynamics, plus
    white torque noise at the Δ³ level."""
    t = np.asarray(columns["time"], float)
    raw = {k: np.asarray(columns[k], float) for k in RAW}
    est = smooth_creep(
        t,
        raw["wheel_speed"],
        raw["vehicle_speed"],
        raw["traction_torque"],
        vehicle.wheelset_inertia_kgm2,
        vehicle.wheel_radius_m,
        vehicle.axle_load_kg,
    )
    v_lat = np.asarray(est.vehicle_speed)
    w_lat = v_lat + np.asarray(est.slip)
    floor_w, floor_v = (float(x) for x in np.asarray(est.measurement_sd))
    models = {
        "vehicle_speed": residual_model(raw["vehicle_speed"], v_lat, floor_v),
        "wheel_speed": residual_model(raw["wheel_speed"], w_lat, floor_w),
    }
    scale = vehicle.axle_load_kg * GRAVITY * vehicle.wheel_radius_m
    none = np.zeros(ext.N_EXTRA, bool)
    latent = from_columns(
        {"time": t, "vehicle_speed": v_lat, "wheel_speed": w_lat, "traction_torque": raw["traction_torque"]},
        vehicle,
    )
    _, mu = ext.predict(np.asarray(p_base), none, latent)
    clean_torque = (np.asarray(mu) + np.asarray(latent.deriv_mu)) * scale
    q_t = _grid_step(raw["traction_torque"])
    sd_t = float(difference_sd(raw["traction_torque"]))
    models["traction_torque"] = {
        "sigma": float(np.sqrt(max(sd_t**2 - q_t**2 / 12, 0.25 * sd_t**2))),
        "rho": 0.0,
        "q": q_t,
    }
    rng = np.random.default_rng(seed)
    out = [
        {
            "time": t,
            "vehicle_speed": _noisy(v_lat, models["vehicle_speed"], rng),
            "wheel_speed": _noisy(w_lat, models["wheel_speed"], rng),
            "traction_torque": _noisy(clean_torque, models["traction_torque"], rng),
        }
        for _ in range(n_replicas)
    ]
    return out, models


def null_gains(
    columns, vehicle, p_base, tau_heat, rows, merge, n_valid: int, n_replicas: int = N_REPLICAS, seed: int = 0
) -> tuple:
    """Round-1 gains (R, C − 1) of every replica and the noise models.

    ``rows = (starts, idx, actives)`` are the observed recording's round-1 rows (base first) and
    ``merge(table) -> table`` the same post-processing (best radius start); ``tau_heat`` the
    thermal lag picked on the recording. Replicas are fitted one after another
    (:func:`jax.lax.map` inside one compiled program), so memory does not grow with R.
    """
    make = replicas_latent if RESYNTHESIS == "latent" else replicas_measured
    cols, models = make(columns, vehicle, p_base, n_replicas, seed)
    sigs = []
    for c in cols:
        s = from_columns(c, vehicle)
        s = s._replace(heat=lowpass_foh(s.time, s.power, tau_heat))
        sigs.append(fitting.pad_signals(s))
    batch = jax.tree_util.tree_map(lambda *x: np.stack(x), *sigs)
    tables = _fit_batch(*rows, batch, n_valid)
    gains = []
    for r in range(n_replicas):
        table = merge({k: np.array(v[r]) for k, v in tables._asdict().items() if k != "residual"})
        held = table["heldout_mae"]
        ok = (table["status"] == 0) & (table["fold_status"] == 0)
        g = np.where(ok[1:], 1.0 - held[1:] / held[0], -np.inf)
        gains.append(g)
    return np.array(gains), models


def max_t_pvalues(observed, null) -> np.ndarray:
    """Max-T p-values of the observed gains (C,) against replica gains (R, C)."""
    top = np.max(null, axis=1)
    return (1.0 + np.sum(top[None, :] >= np.asarray(observed)[:, None], axis=1)) / (top.size + 1.0)
