"""Residual analysis of the base fit: which signal the misfit follows, starting values for the
nonlinear extras, and a generic sparse discrepancy term for structure no catalogue effect explains.
"""

from __future__ import annotations

import numpy as np

from ..data.observer import lowpass_foh
from ..models.effects import EFFECTS
from .extensions import N_EXTRA, POWER_REF, STEP_WIDTH, predict
from .signals import Signals

#: The signal each effect's residual signature follows (from the effect registry).
REVEALING_SIGNAL = {name: spec.signal for name, spec in EFFECTS.items()}
#: Candidate thermal lags τ_th [s] and rail-change times (fractions of the duration) scanned.
THERMAL_LAGS = (0.5, 1.0, 2.0, 5.0, 10.0, 30.0)
CHANGE_GRID = np.linspace(0.05, 0.95, 37)
#: Sequentially thresholded least squares: threshold on |coefficient| of standardised features,
#: relative to the residual's standard deviation, and the number of refits.
STLSQ_THRESHOLD = 0.1
STLSQ_ITERATIONS = 10


def library(sig: Signals, mu_pred) -> dict:
    """The residual-analysis signals (and the generic discrepancy's feature library), each (n,):
    time [s], creep [-], speed [m/s], accel [m/s²], torque_rate [1/s], heat [W], traction_ratio [-],
    adhesion (the base prediction) [-]."""
    v = np.asarray(sig.speed)
    slip = np.asarray(sig.wheel_speed) - v
    return {
        "time": np.asarray(sig.time),
        "creep": slip / np.maximum(np.abs(v), 0.01),
        "speed": v,
        "accel": np.asarray(sig.accel),
        "torque_rate": np.asarray(sig.torque_rate),
        "heat": np.asarray(sig.heat),
        "traction_ratio": np.asarray(sig.traction_ratio),
        "adhesion": np.asarray(mu_pred),
    }


def explained_fraction(residual, x, bins: int = 10) -> float:
    """Correlation ratio η² ∈ [0, 1]: the share of the residual's variance explained by its means in
    ``bins`` quantile bins of ``x`` (catches steps and bends a linear correlation misses)."""
    r = np.asarray(residual) - np.mean(residual)
    edges = np.quantile(x, np.linspace(0, 1, bins + 1)[1:-1])
    idx = np.searchsorted(edges, x)
    counts = np.bincount(idx, minlength=bins)
    means = np.bincount(idx, weights=r, minlength=bins) / np.maximum(counts, 1)
    return float(np.sum(counts * means**2) / max(np.sum(r * r), 1e-300))


def signatures(residual, signals: dict) -> dict:
    """η² of the base residual against every library signal."""
    return {k: explained_fraction(residual, x) for k, x in signals.items()}


def _ls_gain(residual, column):
    """Least-squares coefficient and SSE reduction of ``residual ≈ c · column``."""
    denom = float(np.dot(column, column))
    c = float(np.dot(column, residual)) / denom if denom > 0 else 0.0
    return c, c * c * denom


def starting_values(sig: Signals, residual, mu_pred) -> tuple:
    """Grid starts from the base residual: ``(drop, u_change, tau_th)``.

    Rail change: ``residual ≈ −drop · mu_pred · σ((t − t_c)/W)`` over a grid of ``t_c``;
    thermal lag: ``residual ≈ −m · mu_pred · heat_τ / P_ref`` over :data:`THERMAL_LAGS`.
    """
    r, mu = np.asarray(residual), np.asarray(mu_pred)
    t, duration = np.asarray(sig.time), float(sig.duration)
    best = (0.0, 0.0, 0.5)
    for u in CHANGE_GRID:
        z = (t - t[0] - u * duration) / (STEP_WIDTH * duration)
        step = 0.5 * (1.0 + np.tanh(0.5 * z))
        c, gain = _ls_gain(r, -mu * step)
        if gain > best[0]:
            best = (gain, c, u)
    _, drop, u_change = best
    gains = [
        _ls_gain(r, -mu * np.asarray(lowpass_foh(sig.time, sig.power, tau)) / POWER_REF)[1]
        for tau in THERMAL_LAGS
    ]
    tau_th = THERMAL_LAGS[int(np.argmax(gains))]
    return float(np.clip(drop, -1.0, 0.9)), float(u_change), float(tau_th)


def starting_values_at(sig: Signals, params) -> tuple:
    """:func:`starting_values` on the residual of the plain model at ``params`` (P,) over the
    selected samples (``sig.weight > 0``): the data-driven starts of a recording, and of each of
    its null's replicas, which must pick theirs the same way (:func:`jadhesion.diagnose.null.
    null_statistics`)."""
    target, pred = (np.asarray(x) for x in predict(params, np.zeros(N_EXTRA, bool), sig))
    keep = np.asarray(sig.weight) > 0
    return starting_values(sig, (target - pred) * keep, pred * keep)


def stlsq(
    features, residual, weights, threshold: float = STLSQ_THRESHOLD, iterations: int = STLSQ_ITERATIONS
):
    """Sparse ``residual ≈ Φ ξ`` by sequentially thresholded least squares (SINDy, Brunton 2016).

    Columns of ``features`` (n, K) are standardised; coefficients with ``|ξ_k| < threshold·std(r)``
    are zeroed and the rest refitted, ``iterations`` times. Each row's error is multiplied by its
    ``weights`` (n,) ≥ 0 (rows at zero left out), as in the candidates' fits (:mod:`.fitting`);
    ``std(r)`` weighted alike. Returns ``(xi, mean, scale, low, high)`` with the prediction
    ``((clip(Φ, low, high) − mean)/scale) ξ``: ``low``/``high`` the fitted rows' range of each
    feature, beyond which the term is not extrapolated (on a held-out block, a steady run's
    collinear speed and time, fitted with cancelling coefficients, once predicted a held-out error
    700× the residual's).
    """
    weights = np.asarray(weights, float)
    w = weights > 0
    phi, r = np.asarray(features), np.asarray(residual)
    mean, scale = phi[w].mean(0), phi[w].std(0)
    scale = np.where(scale > 0, scale, 1.0)
    z = (phi - mean) / scale
    z = np.column_stack([np.ones(len(r)), z])
    row = weights[w]
    keep = np.ones(z.shape[1], bool)
    xi = np.zeros(z.shape[1])
    level = np.average(r[w], weights=row**2)
    cut = threshold * np.sqrt(np.average((r[w] - level) ** 2, weights=row**2))
    for _ in range(iterations):
        xi = np.zeros(z.shape[1])
        if keep.any():
            xi[keep] = np.linalg.lstsq(z[w][:, keep] * row[:, None], r[w] * row, rcond=None)[0]
        new_keep = np.abs(xi) >= cut
        new_keep[0] = True
        if np.array_equal(new_keep, keep):
            break
        keep = new_keep
    return xi, mean, scale, phi[w].min(0), phi[w].max(0)


def stlsq_predict(features, fit) -> np.ndarray:
    """Prediction of an :func:`stlsq` fit on ``features`` (n, K), each feature held within the
    range it was fitted on."""
    xi, mean, scale, low, high = fit
    z = (np.clip(np.asarray(features), low, high) - mean) / scale
    return xi[0] + z @ xi[1:]
