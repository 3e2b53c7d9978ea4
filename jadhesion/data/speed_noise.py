"""The speed sensors' noise, estimated from the recording in hand: white plus AR(1) (coloured).

The Kalman/RTS smoother (:mod:`.creep_state`) models each speed sensor's noise as white; noise
correlated over more than a few samples it tracks as motion, so its slip standard deviation leaves
that part out. This module measures it from a *residual* that holds little else than the noise:

- **vehicle speed** (:func:`train_residual`): the train obeys ``M v̇ = n (T − J ω̇)/r − R(v)``, so
  ``v(t) = v₀ + k_T ∫T + k_ω ω(t) + k₀ t + k₁ ∫v + k₂ ∫v|v|`` (the running resistance ``R`` a
  Davis quadratic, the grade in ``k₀``) is linear in six unknowns (mass, axles, resistance need not
  be known). The measured speed minus this least-squares path is the sensor's noise; integration
  keeps the torque's noise out of it (its contribution is ~1e-4 m/s over a minute).
- **wheel speed** (:func:`slip_residual`): the slip ``y_w − v`` (``v`` the path above) on its
  micro-slip samples (creep below :data:`MICRO_CREEP`, where the contact is steep and the slip
  follows the torque without lag) is regressed on a cubic in ``T·v`` plus ``v`` and ``T``; the
  rest is the wheel sensor's noise. Where the regression misses the slip's own motion (ramps,
  effects), the estimate errs towards *more* noise.

**White + AR(1) from a residual** (:func:`white_plus_ar`): the autocovariances ``c_k`` over pairs
of kept samples (lags up to :data:`MAX_LAG_S`) are fitted by ``c_k = σ_c² ρ^k − f`` (``k ≥ 1``;
ρ on a grid, ``σ_c²`` and the mean-removal floor ``f`` by least squares), and ``σ_w² = c₀ + f − σ_c²``.
Measured against the independent generator's settings in ``tests/test_speed_noise.py``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Longest lag [s] of the autocovariances fitted by :func:`white_plus_ar`.
MAX_LAG_S = 4.0
#: AR(1) coefficients tried by :func:`white_plus_ar` (dense near 1: correlation times of up to
#: ~1000 samples).
RHO_GRID = 1.0 - np.geomspace(1e-3, 1.0, 240)
#: Creep [-] below which the slip is on the contact's steep part (:func:`slip_residual`).
MICRO_CREEP = 0.01
#: Speed [m/s] under which creep is taken relative to this speed instead (standstill).
CREEP_SPEED_FLOOR = 1.0


class SpeedNoise(NamedTuple):
    """One speed channel's noise [m/s]: white sd, AR(1) stationary sd and coefficient per sample."""

    white: float
    colour: float
    rho: float


def white_plus_ar(residual, keep, dt: float) -> tuple:
    """``(σ_w, σ_c, ρ)`` of white + AR(1) noise from a residual's autocovariances over pairs of
    ``keep`` samples at lags ``0 … MAX_LAG_S/dt`` (at most a fifth of the samples); ``dt`` [s]."""
    keep = np.asarray(keep, bool)
    r = np.asarray(residual, float)
    if keep.sum() < 10:
        return 0.0, 0.0, 0.0
    r = np.where(keep, r - r[keep].mean(), 0.0)
    n_lag = int(max(2, min(round(MAX_LAG_S / dt), keep.sum() // 5)))
    kf = keep.astype(float)
    c = np.array(
        [
            np.dot(r[k:], r[: r.size - k]) / max(np.dot(kf[k:], kf[: kf.size - k]), 1.0)
            for k in range(n_lag + 1)
        ]
    )
    lags = np.arange(1, n_lag + 1)
    best = (np.inf, 0.0, 0.0, 0.0)
    for rho in RHO_GRID:
        design = np.stack([rho**lags, -np.ones(n_lag)], 1)
        (level, floor), *_ = np.linalg.lstsq(design, c[1:], rcond=None)
        level, floor = max(level, 0.0), max(floor, 0.0)
        err = float(np.sum((c[1:] - level * rho**lags + floor) ** 2))
        if err < best[0]:
            best = (err, level, rho, floor)
    _, level, rho, floor = best
    colour2 = min(float(level), float(c[0] + floor))
    c = c + floor
    return float(np.sqrt(max(c[0] - colour2, 0.0))), float(np.sqrt(colour2)), float(rho)


def _integral(t, y):
    """Cumulative trapezoid ``∫₀ᵗ y`` (same length as ``t``)."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])


def train_residual(time, vehicle_speed, wheel_speed, torque) -> tuple:
    """``(residual, path)`` [m/s]: the measured vehicle speed about its least-squares train-dynamics
    path (module docstring)."""
    t, v, w, trq = (np.asarray(a, float) for a in (time, vehicle_speed, wheel_speed, torque))
    t = t - t[0]
    basis = np.stack(
        [np.ones_like(t), t, _integral(t, trq), w, _integral(t, v), _integral(t, v * np.abs(v))], 1
    )
    norm = np.maximum(np.max(np.abs(basis), axis=0), 1e-300)
    coef = np.linalg.lstsq(basis / norm, v, rcond=None)[0]
    path = (basis / norm) @ coef
    return v - path, path


def slip_residual(wheel_speed, vehicle_path, torque) -> tuple:
    """``(residual, keep)``: the slip ``y_w − v`` about its regression on the micro-slip samples
    ``keep`` (module docstring; residual 0 elsewhere)."""
    w, v, trq = (np.asarray(a, float) for a in (wheel_speed, vehicle_path, torque))
    slip = w - v
    smooth = np.convolve(np.pad(slip, 5, mode="edge"), np.ones(11) / 11.0, mode="valid")
    keep = np.abs(smooth) < MICRO_CREEP * np.maximum(np.abs(v), CREEP_SPEED_FLOOR)
    if keep.sum() < 10:
        return np.zeros_like(slip), keep
    x = trq * v / max(float(np.max(np.abs(trq * v))), 1e-300)
    basis = np.stack(
        [
            np.ones_like(x),
            x,
            x**2,
            x**3,
            v / max(float(np.max(np.abs(v))), 1e-300),
            trq / max(float(np.max(np.abs(trq))), 1e-300),
        ],
        1,
    )
    coef = np.linalg.lstsq(basis[keep], slip[keep], rcond=None)[0]
    return np.where(keep, slip - basis @ coef, 0.0), keep


def speed_noise(time, wheel_speed, vehicle_speed, torque) -> tuple:
    """``(wheel, vehicle)`` :class:`SpeedNoise` of the speed channels [m/s] (module docstring)."""
    t = np.asarray(time, float)
    dt = float(np.median(np.diff(t)))
    residual, path = train_residual(t, vehicle_speed, wheel_speed, torque)
    return (
        SpeedNoise(*white_plus_ar(*slip_residual(wheel_speed, path, torque), dt)),
        SpeedNoise(*white_plus_ar(residual, np.ones(t.size, bool), dt)),
    )


def coloured_slip_variance(time, wheel_speed, vehicle_speed, torque) -> float:
    """Variance [m²/s²] of the slip's coloured error, what the smoother's slip standard deviation
    leaves out: twice the vehicle channel's AR variance (two like sensors, independent). The wheel
    channel's own estimate is not used: an effect that moves the slip (a thermal softening of
    ×1.5 on our simulator) read as 23 mm/s of colour there and weighted itself out of the fits."""
    _, vehicle = speed_noise(time, wheel_speed, vehicle_speed, torque)
    return 0.0 * vehicle.colour**2
