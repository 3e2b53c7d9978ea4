"""LM optimum of the Polach parameters and its Laplace (Gauss-Newton) approximation.

At the least-squares optimum ``theta_hat`` with residual Jacobian ``J`` (n, 5)::

    sigma_hat² = SSE / (n − 5),     Cov(theta) ≈ sigma_hat² (JᵀJ)⁻¹

This is the posterior covariance of the Gaussian likelihood under a flat prior when the posterior
is close to Gaussian — valid for well-identified parameters away from the box faces, not for a
parameter on a face (kS = 1 on dry rail) or one the data barely constrain (B, A at low speed).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import PolachDataset
from ..models.polach import BOUNDS
from .batch_fit import valid_samples
from .box_lm import box_lm
from .likelihood import prediction
from .lm_result import LMResult, best_of
from .observer_view import ObserverTerms
from .polach_residuals import polach_residual
from .uncertainty import colour_factor, covariance, lag1_autocorrelation

#: Multi-start points of :func:`lm_optimum` (rows of [kA, kS, mu0, A, B]).
STARTS = np.array(
    [
        [0.5, 0.5, 0.35, 0.5, 0.3],
        [0.2, 0.8, 0.30, 0.2, 0.1],
        [0.9, 0.3, 0.40, 0.7, 0.6],
        [0.6, 0.9, 0.35, 0.4, 0.2],
    ]
)


def observer_residual(theta, args):
    """``prediction − mu_hat`` of the ``"observer"`` likelihood; ``args = (data, obs)``."""
    data, obs = args
    return prediction(theta, data, "observer", obs) - data.adhesion


def _residual(obs):
    if obs is None:
        return polach_residual, lambda data: data
    return observer_residual, lambda data: (data, obs)


def lm_start(data: PolachDataset, starts=STARTS, obs: ObserverTerms | None = None) -> LMResult:
    """Least-squares optimum in the box ``[0, 1]^5`` with its solver's status: the projected box LM
    (:func:`.box_lm.box_lm`, the one bounded LM of every Polach least-squares problem) from each of
    ``starts``, the best converged one kept (the best of all when none converged); with ``obs``
    (:class:`ObserverTerms`), of the observer's view of the curve."""
    residual, args = _residual(obs)
    bounds = tuple(jnp.asarray(b) for b in BOUNDS)
    solve = jax.vmap(lambda p0, a: box_lm(residual, p0, a, bounds), in_axes=(0, None))
    return best_of(solve(jnp.asarray(starts), args(data)))


def lm_optimum(data: PolachDataset, starts=STARTS, obs: ObserverTerms | None = None):
    """The parameters (5,) of :func:`lm_start`."""
    return lm_start(data, starts, obs).params


def laplace_covariance(theta_hat, data: PolachDataset, obs: ObserverTerms | None = None):
    """``sigma_hat² (JᵀJ)⁻¹`` (5, 5) at the optimum by :func:`.uncertainty.covariance` (i.i.d.);
    ``inf`` rows/columns for parameters in a singular direction of ``JᵀJ``; of a padded dataset's
    samples alone (its ``weight``: one program per length bucket).
    With ``obs``, of the observer residual (i.i.d. errors assumed: a starting scale only)."""
    return _laplace_covariance(theta_hat, data, obs)


@jax.jit
def _laplace_covariance(theta_hat, data, obs):
    residual, args = _residual(obs)
    r = residual(theta_hat, args(data))
    jac = jax.jacfwd(residual)(theta_hat, args(data))
    return covariance(jac, r, hac=False, weight=data.weight)[0]


#: Samples above which the tempered posterior samples a thinned dataset (:func:`thinning`).
POSTERIOR_SAMPLES = 2000


def thinning(samples: int, kappa: float) -> int:
    """Every how many samples the posterior tempered by 1/κ evaluates (1: all): as few as bring
    ``samples`` to :data:`POSTERIOR_SAMPLES`, and never more than κ/4. Residuals correlated over
    many samples (an oversampled recording: κ ≈ twice the correlation length for AR(1)) carry
    about n/κ samples' information whether all or every d-th are kept while d ≤ κ/4 (an AR(1)'s
    effective samples then drop by under 3 %), and the likelihood costs d times less: a 1 kHz
    recording of 23 436 samples (κ = 59) took 590 s in full."""
    if samples <= POSTERIOR_SAMPLES:
        return 1
    return int(max(1, min(np.ceil(samples / POSTERIOR_SAMPLES), np.floor(kappa / 4.0))))


def initial_spread(
    theta_hat, data: PolachDataset, floor: float = 1e-4, cap: float = 0.05, obs: ObserverTerms | None = None
):
    """Per-parameter walker-ball radius (fraction of the unit box): half the Laplace standard
    deviation, kept within ``[floor, cap]`` (the cap also covers a singular ``JᵀJ``)."""
    std = jnp.sqrt(jnp.diag(laplace_covariance(theta_hat, data, obs)))
    return jnp.clip(jnp.where(jnp.isfinite(std), 0.5 * std, cap), floor, cap)


@functools.partial(jax.jit, static_argnames="likelihood")
def _colour(data, theta, likelihood, obs):
    r = data.adhesion - prediction(theta, data, likelihood, obs)
    r = r if data.weight is None else r * data.weight
    kappa, lags = colour_factor(r, data.weight)
    return kappa, lags, lag1_autocorrelation(r)


def colour_check(data: PolachDataset, theta, likelihood: str = "gauss", obs: ObserverTerms | None = None):
    """The residuals' colour at ``theta`` (e.g. the LM optimum), rows in time order: ``{"kappa"``
    (:func:`.uncertainty.colour_factor`, ≥ 1), ``"effective_samples"`` (n/κ), ``"samples"`` (n),
    ``"residual_rho"`` (lag-1 autocorrelation), ``"lags"`` (bandwidth)``}``. A Gaussian
    likelihood tempered by 1/κ counts n/κ independent samples instead of n correlated ones. A
    padded dataset (``weight``, trailing padding) gives its samples' numbers, one program per
    length bucket."""
    kappa, lags, rho = _colour(data, jnp.asarray(theta), likelihood, obs)
    n = valid_samples(data)
    return {
        "kappa": float(kappa),
        "effective_samples": n / float(kappa),
        "samples": n,
        "residual_rho": float(rho),
        "lags": int(lags),
    }
