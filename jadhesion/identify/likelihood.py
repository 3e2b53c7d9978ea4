"""Log-posterior of the Polach parameters for MCMC: priors and five likelihoods.

The sampled vector is ``phi = [kA, kS, mu0, A, B, log_scale(, rho)]``: the five Polach parameters,
the log noise scale (left out when it is fixed, ``fixed_log_scale``), and for the autoregressive
likelihoods the AR(1) coefficient ``rho`` last (:func:`noise_names` gives the layout).

Priors (documented choices):

* Polach parameters: uniform on the box ``[lower, upper]`` — by default the identification box
  ``[0, 1]^5`` of DESIGN §1 (:data:`jadhesion.models.polach.BOUNDS`); outside the box ``-inf``.
* noise scale (sigma [-]; b [-] for ``"laplace"``):
  log-uniform on ``[SCALE_MIN, SCALE_MAX] = [1e-4, 1]``, i.e. ``log_scale`` uniform on
  ``[log 1e-4, 0]``.
* AR(1) coefficient ``rho``: uniform on ``[-RHO_MAX, RHO_MAX]`` (stationary noise).

Likelihoods of the residuals ``r_i = mu_hat_i − prediction_i`` (n samples, time order for the
autoregressive two):

* ``"gauss"``:   ``log L = −n log sigma − Σ r²/(2 sigma²) − (n/2) log 2π``, prediction
  ``mu_adh(s_i, w_i; theta)``.
* ``"laplace"``: ``log L = −n log(2 b) − Σ |r| / b`` — the Bayesian counterpart of the paper's MAE
  fitness (eq 15): its maximum over b is at b = MAE.
* ``"student"``: Student-t noise, scale sigma, ν = :data:`STUDENT_NU` (fixed), ``log L = Σ [log Γ((ν+1)/2)
  − log Γ(ν/2) − ½ log(νπ) − log sigma − ((ν+1)/2) log(1 + r²/(ν sigma²))]``: the heavy-tailed
  ``"gauss"`` (as LM's pseudo-Huber second stage): a residual far in the tails (slip errors at
  walking pace, start-up transients) pulls with a force ``∝ 1/r`` instead of ``r``.
* ``"ar1"``: the same prediction, residuals an AR(1) process ``r_i = rho r_{i−1} + e_i``,
  ``e_i ~ N(0, sigma²)`` (sigma = the innovation scale), exact (stationary) first-sample term::

      log L = −n log sigma − (n/2) log 2π + ½ log(1 − rho²)
              − [(1 − rho²) r_1² + Σ_{i≥2} (r_i − rho r_{i−1})²] / (2 sigma²)

  It needs the rows in time order at a (roughly) uniform sample period.
* ``"observer"``: the ``"ar1"`` noise model around the *observer's* view of the curve. The paper's
  observer (eq 19) low-passes the wheel-speed derivative but not the torque; from the wheelset
  balance ``J ω̇ = T − mu m g r`` its output is exactly

      mu_hat = LP[mu] + (T − LP[T]) / (m g r) + LP[torque noise] / (m g r) + …

  (``LP`` the observer's first-order low-pass ``1/(1 + s T0)``): in transients the observed curve
  lags the true one and the unfiltered torque leaks through. The prediction is therefore
  ``LP[mu_adh(s, w; theta)] + (T − LP[T])/(m g r)`` with the recorded torque ``T`` and the same exact
  first-order-hold discretisation as :mod:`jadhesion.data.observer` (:mod:`.observer_view`:
  :class:`ObserverTerms` from a recording's ``time`` and ``traction_torque``); what is left is
  the low-passed (coloured) sensor noise, modelled as AR(1). For the ``"filtered_torque"`` variant
  the torque term is zero. Creepage-only datasets cannot use it (no time, no torque).

**Errors in variables.** When the dataset carries ``slip_sd`` (the smoother's posterior standard
deviation of the slip, :mod:`jadhesion.data.creep_state`), the true slip of sample i is
``N(w_i, sd_i²)`` given the recording, truncated to the sign of the adhesion force
(:mod:`.slip_law`: why, and the nodes; with the ``"population"`` law of :func:`with_node_slips`,
its posterior under the recording's own slips as the prior), and the curve is predicted by its
expectation under that law, by Gauss–Hermite quadrature mapped onto the truncated normal
(:func:`.slip_law.slip_nodes`: standardised nodes ``e_ij``, weights ``ω_j``; creep
``s = w / max(|v|, floor)`` at each node):

    m_i = Σ_j ω_j mu_adh(w_i + sd_i e_j),    V_i = Σ_j ω_j mu_adh(w_i + sd_i e_j)² − m_i²

``m_i`` replaces the curve in every prediction (low-passed for ``"observer"``); residuals are
heteroscedastic, ``r_i = λ_i e_i``, ``λ_i = √(1 + V_i / σ_m²)`` (``σ_m``: ``sigma``, AR(1)
``sigma/√(1 − rho²)``, or ``b``), ``e`` the likelihood's noise model, ``log L`` gains
``−Σ log λ_i`` — to first order the linearised ``σ_i² = σ² + (∂mu_adh/∂w · sd_i)²``. The moments
are ~10 % rough where an untruncated interval straddles w = 0 (the kink of ``mu(|w|)``). Without ``slip_sd``
(raw creep, creepage-only files) ``V_i = 0`` and ``m_i = mu_adh(s_i, w_i)``.

Why: on simulated 22E recordings the i.i.d. likelihoods are biased by the observer's lag during the
slip excursions — the very samples that carry ``mu0`` and ``B`` — so their 90 % intervals miss the
truth (``benchmarks/bench_mcmc.py --coverage``).

Any non-finite value becomes ``-inf``, so emcee never sees a NaN.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import PolachDataset, cut
from ..models.kinematics import SPEED_FLOOR
from ..models.polach import polach_adhesion
from .batch_fit import bucketed
from .observer_view import ObserverTerms, lowpass
from .slip_law import node_moments, node_slips, posterior_nodes

LIKELIHOODS = ("gauss", "laplace", "ar1", "observer", "student")
#: Likelihoods with an AR(1) noise coefficient ``rho`` (the last sampled coordinate).
AUTOREGRESSIVE = ("ar1", "observer")
SCALE_MIN, SCALE_MAX = 1e-4, 1.0
LOG_SCALE_BOUNDS = (math.log(SCALE_MIN), math.log(SCALE_MAX))
RHO_MAX = 0.99
#: ν of ``"student"``: the maximum-likelihood ν of the standardised residuals at the truth
#: (``benchmarks/results/coverage_posterior_student.json``: ``tails_at_truth``) is 0.8–8.5 (median 3.0) on
#: the independent generator's 18 recordings, 6.5–∞ (median 24) on ours; 4: their tails, finite variance.
STUDENT_NU = 4.0


def noise_names(likelihood: str, fixed_scale: bool = False) -> tuple:
    """Names of the sampled noise coordinates after the five Polach parameters."""
    if likelihood not in LIKELIHOODS:
        raise ValueError(f"likelihood must be one of {LIKELIHOODS}, got {likelihood!r}")
    scale = () if fixed_scale else ("b" if likelihood == "laplace" else "sigma",)
    return scale + (("rho",) if likelihood in AUTOREGRESSIVE else ())


#: The laws of the true slip given the smoothed one (:mod:`.slip_law`): ``"normal"`` (the default:
#: normal about the smoothed slip, sign-truncated; the smoother's error taken as Berkson) and
#: ``"population"`` (:func:`.slip_law.posterior_nodes`: classical error, the recording's own slips
#: as the prior).
SLIP_LAWS = ("normal", "population")


def with_node_slips(data: PolachDataset, law: str = "normal") -> PolachDataset:
    """``data`` with ``node_slips`` (n, :data:`.slip_law.GH_NODES`): the slip [m/s] at each node of
    the expectation under slip law ``law`` (:data:`SLIP_LAWS`), a function of the data alone.
    Evaluating the normal law's nodes (inverse normal CDFs) was two thirds of
    :func:`curve_moments`'s time (2 000 rows: 0.41 ms, 0.12 ms from stored nodes), so every fit and
    sampler sets them once where it starts. Unchanged without ``slip_sd`` or with the nodes set; a
    stack of datasets (leading axis) too."""
    if law not in SLIP_LAWS:
        raise ValueError(f"slip law must be one of {SLIP_LAWS}, got {law!r}")
    if data.slip_sd is None or data.node_slips is not None:
        return data
    if data.slip.ndim > 1:
        return jax.vmap(partial(with_node_slips, law=law))(data)
    if law == "population":
        return data._replace(node_slips=posterior_nodes(data.slip, data.slip_sd, data.adhesion, data.weight))
    return data._replace(node_slips=node_slips(data.slip, data.slip_sd, data.adhesion).T)


_stored_nodes = jax.jit(with_node_slips, static_argnames="law")


def with_slip_law(data: PolachDataset, law: str) -> PolachDataset:
    """:func:`with_node_slips` for eager callers (the CLI, before a fit or sampler): computed on
    ``data`` padded to its length bucket (:func:`.batch_fit.bucketed`: one program per bucket),
    then cut back to its rows. The normal law's nodes are left to the fit, which sets them."""
    if law not in SLIP_LAWS:
        raise ValueError(f"slip law must be one of {SLIP_LAWS}, got {law!r}")
    if law == "normal" or data.slip_sd is None or data.node_slips is not None:
        return data
    padded = _stored_nodes(bucketed(data), law=law)
    return cut(padded, data.adhesion.shape[0])._replace(weight=data.weight)


def other_slip_law(law: str) -> str:
    """The slip law a fit under ``law`` is checked against (:data:`SLIP_LAWS` has two)."""
    if law not in SLIP_LAWS:
        raise ValueError(f"slip law must be one of {SLIP_LAWS}, got {law!r}")
    return SLIP_LAWS[1 - SLIP_LAWS.index(law)]


def as_slip_law(data: PolachDataset, law: str) -> PolachDataset:
    """:func:`with_slip_law` of ``data`` whatever law its nodes were set for (they are dropped
    first: the normal law's are then left to the fit)."""
    return with_slip_law(data._replace(node_slips=None), law)


def curve_moments(theta, data: PolachDataset):
    """Mean and variance (n,) of ``mu_adh`` over the slip's uncertainty (module docstring), from
    the dataset's ``node_slips`` (:func:`with_node_slips`; computed here when not set);
    ``(mu_adh(s, w), 0)`` when the dataset has no ``slip_sd``."""
    if data.slip_sd is None:
        return polach_adhesion(theta, data.creep, data.slip, data.k_eps), jnp.zeros_like(data.slip)
    speed = jnp.maximum(jnp.abs(data.vehicle_speed), SPEED_FLOOR)
    w = with_node_slips(data).node_slips.T
    return node_moments(polach_adhesion(theta, w / speed[None, :], w, data.k_eps))


def _predict(theta, data, likelihood, obs):
    mean, var = curve_moments(theta, data)
    if likelihood != "observer":
        return mean, var
    if obs is None:
        raise ValueError("the observer likelihood needs ObserverTerms (observer_terms(...))")
    return lowpass(mean, obs) + obs.torque_term, var


@partial(jax.jit, static_argnames=("likelihood",))
def prediction(theta, data: PolachDataset, likelihood: str = "gauss", obs: Optional[ObserverTerms] = None):
    """The predicted ``mu_hat`` (n,) of a likelihood (the observer's view for ``"observer"``; the
    expectation over the slip's uncertainty when the dataset has ``slip_sd``). Jitted: op by op,
    the observer's associative scan cost ~0.35 s a call (a posterior's start, its colour check)."""
    return _predict(theta, data, likelihood, obs)[0]


def ar1_log_likelihood(r, log_sigma, rho):
    """Exact Gaussian AR(1) log-likelihood of the time-ordered residuals ``r`` (n,)."""
    n = r.shape[0]
    one_m = 1.0 - rho * rho
    e = r[1:] - rho * r[:-1]
    sse = one_m * r[0] ** 2 + jnp.sum(e * e)
    return (
        -n * log_sigma
        - 0.5 * n * math.log(2.0 * math.pi)
        + 0.5 * jnp.log(one_m)
        - 0.5 * sse * jnp.exp(-2.0 * log_sigma)
    )


def student_log_density(z, nu=STUDENT_NU):
    """Log-density of the standard Student-t with ``nu`` degrees of freedom at ``z`` (any shape)."""
    const = math.lgamma(0.5 * (nu + 1.0)) - math.lgamma(0.5 * nu) - 0.5 * math.log(nu * math.pi)
    return const - 0.5 * (nu + 1.0) * jnp.log1p(z * z / nu)


def log_likelihood(
    theta,
    log_scale,
    data: PolachDataset,
    likelihood: str = "gauss",
    rho=0.0,
    obs: Optional[ObserverTerms] = None,
):
    """Log-likelihood of the dataset's adhesion samples given ``theta`` (5,), ``log_scale`` and,
    for ``"ar1"``/``"observer"``, the AR(1) coefficient ``rho`` and (observer) ``obs``."""
    if likelihood not in LIKELIHOODS:
        raise ValueError(f"likelihood must be one of {LIKELIHOODS}, got {likelihood!r}")
    mean, var = _predict(theta, data, likelihood, obs)
    marginal = jnp.exp(2.0 * log_scale) / (1.0 - rho * rho)
    log_lam = 0.5 * jnp.log1p(var / marginal)
    r = (data.adhesion - mean) * jnp.exp(-log_lam)
    n = r.shape[0]
    if likelihood in AUTOREGRESSIVE:
        return ar1_log_likelihood(r, log_scale, rho) - jnp.sum(log_lam)
    scale = jnp.exp(log_scale)
    if likelihood == "student":
        return jnp.sum(student_log_density(r / scale)) - n * log_scale - jnp.sum(log_lam)
    if likelihood == "gauss":
        return (
            -n * log_scale
            - 0.5 * jnp.sum(r * r) / scale**2
            - 0.5 * n * math.log(2.0 * math.pi)
            - jnp.sum(log_lam)
        )
    return -n * (log_scale + math.log(2.0)) - jnp.sum(jnp.abs(r)) / scale - jnp.sum(log_lam)


def _split(phi, likelihood: str):
    """``(theta, log_scale or None, rho or None)`` from the sampled vector."""
    n_noise = phi.shape[0] - 5
    has_rho = likelihood in AUTOREGRESSIVE
    expected = {False: (0, 1), True: (1, 2)}[has_rho]
    if n_noise not in expected:
        raise ValueError(
            f"phi for likelihood {likelihood!r} must have {5 + expected[0]} or "
            f"{5 + expected[1]} entries, got shape {phi.shape}"
        )
    return phi[:5], phi[5] if n_noise == expected[1] else None, phi[-1] if has_rho else None


def log_prior(phi, lower, upper, likelihood: str = "gauss"):
    """Log prior density up to a constant: 0 inside the box (and scale, rho ranges), else ``-inf``."""
    theta, log_scale, rho = _split(phi, likelihood)
    inside = jnp.all((theta >= lower) & (theta <= upper))
    if log_scale is not None:
        inside &= (log_scale >= LOG_SCALE_BOUNDS[0]) & (log_scale <= LOG_SCALE_BOUNDS[1])
    if rho is not None:
        inside &= jnp.abs(rho) <= RHO_MAX
    return jnp.where(inside, 0.0, -jnp.inf)


def log_posterior(
    phi,
    data: PolachDataset,
    lower,
    upper,
    fixed_log_scale=0.0,
    likelihood: str = "gauss",
    obs: Optional[ObserverTerms] = None,
    weight=1.0,
):
    """Unnormalised log-posterior of one parameter vector ``phi`` (see the module docstring for its
    layout; the scale fixed at ``exp(fixed_log_scale)`` when left out), the log-likelihood
    multiplied by ``weight`` = 1/κ (tempering, :func:`.uncertainty.colour_factor`; 1: none).
    ``-inf`` outside the prior support or when not finite."""
    theta, log_scale, rho = _split(phi, likelihood)
    # The likelihood is evaluated at the point clipped into the support: finite everywhere, so an
    # out-of-box walker gets exactly -inf from the prior and never a NaN.
    log_scale = fixed_log_scale if log_scale is None else jnp.clip(log_scale, *LOG_SCALE_BOUNDS)
    rho = 0.0 if rho is None else jnp.clip(rho, -RHO_MAX, RHO_MAX)
    ll = log_likelihood(jnp.clip(theta, lower, upper), log_scale, data, likelihood, rho, obs)
    value = log_prior(phi, lower, upper, likelihood) + weight * ll
    return jnp.where(jnp.isfinite(value), value, -jnp.inf)


@partial(jax.jit, static_argnames=("likelihood",))
def batch_log_posterior(
    phis,
    data: PolachDataset,
    lower,
    upper,
    fixed_log_scale=0.0,
    likelihood: str = "gauss",
    obs: Optional[ObserverTerms] = None,
    weight=1.0,
):
    """:func:`log_posterior` of a whole ensemble ``phis`` (W, d) in one jitted, vmapped call."""
    return jax.vmap(log_posterior, in_axes=(0, None, None, None, None, None, None, None))(
        phis, data, lower, upper, fixed_log_scale, likelihood, obs, weight
    )


def ensemble_log_prob(
    data: PolachDataset,
    likelihood: str = "gauss",
    bounds=None,
    fixed_scale: float | None = None,
    obs: Optional[ObserverTerms] = None,
    weight: float = 1.0,
):
    """A NumPy-in/NumPy-out log-probability for ``emcee.EnsembleSampler(vectorize=True)``.

    The dataset, box and observer terms become float64 device arrays once; each call is one
    dispatch of the module-level jitted :func:`batch_log_posterior` (compiled once per likelihood,
    walker count and data shape — a new dataset of the same shape does not re-trace) on the NumPy
    walker array, and one device→host copy of W numbers.

    ``data``: the dataset; ``likelihood``: one of :data:`LIKELIHOODS`; ``bounds``: prior box
    ``(lower, upper)`` of the Polach parameters (default ``[0, 1]^5``); ``fixed_scale``: a fixed
    noise scale [-] instead of sampling ``log_scale``; ``obs``: :class:`ObserverTerms` (required by
    ``"observer"``, ignored otherwise); ``weight``: the tempering 1/κ of :func:`log_posterior`.
    """
    if likelihood not in LIKELIHOODS:
        raise ValueError(f"likelihood must be one of {LIKELIHOODS}, got {likelihood!r}")
    if likelihood == "observer":
        if obs is None:
            raise ValueError("the observer likelihood needs ObserverTerms (observer_terms(...))")
        if obs.torque_term.shape != data.adhesion.shape:
            raise ValueError(
                f"observer terms for {obs.torque_term.shape[0]} samples, dataset has {data.adhesion.shape[0]}"
            )
    else:
        obs = None
    lower, upper = (np.zeros(5), np.ones(5)) if bounds is None else bounds
    f64 = lambda x: jnp.asarray(x, jnp.float64)  # noqa: E731
    lower, upper = f64(lower), f64(upper)
    data = with_node_slips(jax.tree_util.tree_map(f64, data))
    obs = None if obs is None else jax.tree_util.tree_map(f64, obs)
    fixed = f64(0.0 if fixed_scale is None else math.log(fixed_scale))
    weight = f64(weight)

    def log_prob(phis: np.ndarray) -> np.ndarray:
        return np.asarray(
            batch_log_posterior(
                np.asarray(phis, np.float64), data, lower, upper, fixed, likelihood, obs, weight
            )
        )

    return log_prob
