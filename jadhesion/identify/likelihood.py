"""Log-posterior of the Polach parameters for MCMC: priors, Gaussian and Laplace likelihoods.

The sampled vector is ``phi = [kA, kS, mu0, A, B, log_scale]`` (6 entries), or the five Polach
parameters alone when the noise scale is fixed (``fixed_log_scale`` given).

Priors (documented choices):

* Polach parameters: uniform on the box ``[lower, upper]`` — by default the identification box
  ``[0, 1]^5`` of DESIGN §1 (:data:`jadhesion.models.polach.BOUNDS`); outside the box ``-inf``.
* noise scale (sigma [-] for ``"gauss"``, b [-] for ``"laplace"``): log-uniform on
  ``[SCALE_MIN, SCALE_MAX] = [1e-4, 1]``, i.e. ``log_scale`` uniform on ``[log 1e-4, 0]``.

Likelihoods of the residuals ``r_i = mu_hat_i − mu_adh(s_i, w_i; theta)`` (n samples):

* ``"gauss"``:   ``log L = −n log sigma − Σ r²/(2 sigma²) − (n/2) log 2π``
* ``"laplace"``: ``log L = −n log(2 b) − Σ |r| / b`` — the Bayesian counterpart of the paper's MAE
  fitness (eq 15): its maximum over b is at b = MAE.

Any non-finite value becomes ``-inf``, so emcee never sees a NaN.
"""

from __future__ import annotations

import math
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import PolachDataset
from ..models.polach import polach_adhesion

LIKELIHOODS = ("gauss", "laplace")
SCALE_MIN, SCALE_MAX = 1e-4, 1.0
LOG_SCALE_BOUNDS = (math.log(SCALE_MIN), math.log(SCALE_MAX))


def log_likelihood(theta, log_scale, data: PolachDataset, likelihood: str = "gauss"):
    """Log-likelihood of the dataset's adhesion samples given ``theta`` (5,) and ``log_scale``."""
    r = data.adhesion - polach_adhesion(theta, data.creep, data.slip, data.k_eps)
    n = r.shape[0]
    scale = jnp.exp(log_scale)
    if likelihood == "gauss":
        return -n * log_scale - 0.5 * jnp.sum(r * r) / scale**2 - 0.5 * n * math.log(2.0 * math.pi)
    if likelihood == "laplace":
        return -n * (log_scale + math.log(2.0)) - jnp.sum(jnp.abs(r)) / scale
    raise ValueError(f"likelihood must be one of {LIKELIHOODS}, got {likelihood!r}")


def log_prior(phi, lower, upper):
    """Log prior density up to a constant: 0 inside the box (and scale range), ``-inf`` outside."""
    theta = phi[:5]
    inside = jnp.all((theta >= lower) & (theta <= upper))
    if phi.shape[0] == 6:
        inside &= (phi[5] >= LOG_SCALE_BOUNDS[0]) & (phi[5] <= LOG_SCALE_BOUNDS[1])
    return jnp.where(inside, 0.0, -jnp.inf)


def log_posterior(phi, data: PolachDataset, lower, upper, fixed_log_scale=0.0,
                  likelihood: str = "gauss"):
    """Unnormalised log-posterior of one parameter vector ``phi`` (6,) — or (5,) with the scale
    fixed at ``exp(fixed_log_scale)``. ``-inf`` outside the prior support or when not finite."""
    if phi.shape[0] not in (5, 6):
        raise ValueError(f"phi must have 5 or 6 entries, got shape {phi.shape}")
    # The likelihood is evaluated at the point clipped into the support: finite everywhere, so an
    # out-of-box walker gets exactly -inf from the prior and never a NaN.
    log_scale = jnp.clip(phi[5], *LOG_SCALE_BOUNDS) if phi.shape[0] == 6 else fixed_log_scale
    theta = jnp.clip(phi[:5], lower, upper)
    ll = log_likelihood(theta, log_scale, data, likelihood)
    value = log_prior(phi, lower, upper) + ll
    return jnp.where(jnp.isfinite(value), value, -jnp.inf)


@partial(jax.jit, static_argnames=("likelihood",))
def batch_log_posterior(phis, data: PolachDataset, lower, upper, fixed_log_scale=0.0,
                        likelihood: str = "gauss"):
    """:func:`log_posterior` of a whole ensemble ``phis`` (W, d) in one jitted, vmapped call."""
    return jax.vmap(log_posterior, in_axes=(0, None, None, None, None, None))(
        phis, data, lower, upper, fixed_log_scale, likelihood)


def ensemble_log_prob(data: PolachDataset, likelihood: str = "gauss", bounds=None,
                      fixed_scale: float | None = None):
    """A NumPy-in/NumPy-out log-probability for ``emcee.EnsembleSampler(vectorize=True)``.

    Args:
        data: the dataset (arrays become float64 device arrays once).
        likelihood: ``"gauss"`` or ``"laplace"``.
        bounds: prior box ``(lower, upper)`` of the five Polach parameters; default ``[0, 1]^5``.
        fixed_scale: fix the noise scale [-] instead of sampling ``log_scale`` (then d = 5).
    """
    if likelihood not in LIKELIHOODS:
        raise ValueError(f"likelihood must be one of {LIKELIHOODS}, got {likelihood!r}")
    lower, upper = (np.zeros(5), np.ones(5)) if bounds is None else bounds
    lower, upper = jnp.asarray(lower, jnp.float64), jnp.asarray(upper, jnp.float64)
    data = jax.tree_util.tree_map(lambda x: jnp.asarray(x, jnp.float64), data)
    fixed = jnp.asarray(0.0 if fixed_scale is None else math.log(fixed_scale), jnp.float64)

    def log_prob(phis: np.ndarray) -> np.ndarray:
        return np.asarray(batch_log_posterior(jnp.asarray(phis, jnp.float64), data, lower, upper,
                                              fixed, likelihood))

    return log_prob
