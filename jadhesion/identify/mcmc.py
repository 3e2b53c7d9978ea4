"""Bayesian posterior of the Polach parameters with emcee's affine-invariant ensemble sampler.

The whole ensemble's log-probability is one jitted, vmapped JAX call
(:func:`jadhesion.identify.likelihood.ensemble_log_prob`, ``vectorize=True``); priors and
likelihoods are documented there. Walkers start in a small ball around an optimum ``theta0``
(reflected into the prior box) and the run is reproducible from ``seed`` alone.

    result = sample_posterior(dataset, theta0, walkers=32, steps=5000, likelihood="gauss", seed=0)
    result.params["mu0"]          # {"median", "q05", "q95"}
    result.derived["mu_max"]      # peak adhesion [-] at the dataset's median speed
    result.diagnostics.warnings   # non-empty when the chain is shorter than 50 autocorrelation times
"""

from __future__ import annotations

from typing import Callable, NamedTuple, Optional

import warnings

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import PolachDataset
from ..models.polach import PARAM_NAMES, adhesion_peak, polach_adhesion
from .ensemble import MIN_TAU_MULTIPLE, ChainTooShortWarning, Diagnostics, run_ensemble  # noqa: F401
from .likelihood import LOG_SCALE_BOUNDS, ensemble_log_prob
from .polach_fit import polach_mae, polach_residual

QUANTILES = (0.05, 0.5, 0.95)


class PosteriorResult(NamedTuple):
    """Posterior samples and their summaries.

    ``params`` and ``derived`` map a name to ``{"median", "q05", "q95"}``. ``names`` lists the
    sampled coordinates: the five Polach parameters, then ``"sigma"``/``"b"`` (the noise scale,
    sampled as its logarithm; ``samples`` holds the scale itself) unless the scale was fixed.
    """

    samples: np.ndarray      # (n_samples, d) after burn-in and thinning
    chain: np.ndarray        # (kept steps, walkers, d), same coordinates as ``samples``
    names: tuple
    params: dict
    derived: dict
    derived_samples: dict    # name -> (m,) samples of mu_max and creep_opt
    diagnostics: Diagnostics
    likelihood: str
    vehicle_speed: float     # speed [m/s] at which the derived quantities are evaluated

    def theta(self) -> np.ndarray:
        """Samples of the five Polach parameters, (n_samples, 5)."""
        return self.samples[:, :5]

    def to_inference_data(self):
        """An ``arviz.InferenceData`` (one arviz chain per walker); needs ``arviz`` installed."""
        import arviz

        posterior = {name: np.swapaxes(self.chain[..., i], 0, 1) for i, name in enumerate(self.names)}
        return arviz.from_dict(posterior=posterior)


_peaks = jax.jit(jax.vmap(adhesion_peak, in_axes=(0, None, None)))


def summarise(samples: np.ndarray) -> dict:
    """Median and 5 / 95 % quantiles of 1-D samples."""
    q05, median, q95 = np.quantile(samples, QUANTILES)
    return {"median": float(median), "q05": float(q05), "q95": float(q95)}


def initial_ball(theta0, log_scale0: Optional[float], walkers: int, rng: np.random.Generator,
                 bounds, spread=1e-3) -> np.ndarray:
    """Walker positions: ``theta0`` (clipped into the box) plus Gaussian jitter of ``spread`` × box
    width (a scalar or one value per parameter), reflected back into the box, so walkers at a box
    face stay distinct and the ensemble keeps full rank. ``log_scale0``: the 6th coordinate."""
    lower, upper = (np.asarray(b, float) for b in bounds)
    jitter = np.asarray(spread, float) * (upper - lower) * rng.standard_normal((walkers, 5))
    theta = np.clip(np.asarray(theta0, float), lower, upper) + jitter
    theta = upper - np.abs(upper - (lower + np.abs(theta - lower)))
    if log_scale0 is None:
        return theta
    lo, hi = LOG_SCALE_BOUNDS
    ls = np.clip(log_scale0, lo + 0.1, hi - 0.1) + 0.01 * rng.standard_normal((walkers, 1))
    return np.concatenate([theta, ls], axis=1)


def _initial_log_scale(data: PolachDataset, theta0, likelihood: str) -> float:
    r = np.asarray(polach_residual(jnp.asarray(theta0), data))
    scale = np.sqrt(np.mean(r**2)) if likelihood == "gauss" else np.mean(np.abs(r))
    return float(np.log(max(scale, 1e-4)))


def sample_posterior(data: PolachDataset, theta0, *, walkers: int = 32, steps: int = 5000,
                     likelihood: str = "gauss", seed: int = 0, burn: Optional[int] = None,
                     thin: int = 1, bounds=None, fixed_scale: Optional[float] = None,
                     spread=1e-3, max_derived: int = 4000,
                     callback: Optional[Callable[[int], None]] = None,
                     callback_every: int = 100) -> PosteriorResult:
    """Sample the posterior of ``[kA, kS, mu0, A, B]`` (and the noise scale) with emcee.

    Args:
        data: the fitting dataset.
        theta0: a point near the mode (e.g. the LM optimum), shape (5,).
        walkers, steps: ensemble size and chain length (burn-in included).
        likelihood: ``"gauss"`` (scale sigma) or ``"laplace"`` (scale b).
        seed: seeds the initial ball and emcee's random state.
        burn: steps discarded as burn-in (default ``steps // 4``); ``thin``: keep every thin-th.
        bounds: prior box ``(lower, upper)`` of the Polach parameters, default ``[0, 1]^5``.
        fixed_scale: a known noise scale [-] (not sampled) instead of the log-uniform prior.
        spread: initial ball radius as a fraction of the box width, scalar or (5,) — e.g.
            :func:`jadhesion.identify.laplace.initial_spread` to start near the posterior's width.
        max_derived: at most this many (evenly spaced) samples feed ``mu_max`` / ``creep_opt``.
        callback: called with the number of steps done every ``callback_every`` steps (progress).

    Emits :class:`ChainTooShortWarning` when ``steps − burn < 50 τ_max``.
    """
    bounds = (np.zeros(5), np.ones(5)) if bounds is None else tuple(np.asarray(b, float) for b in bounds)
    burn = steps // 4 if burn is None else burn
    rng = np.random.default_rng(seed)
    log_scale0 = None if fixed_scale is not None else _initial_log_scale(data, theta0, likelihood)
    p0 = initial_ball(theta0, log_scale0, walkers, rng, bounds, spread)
    log_prob = ensemble_log_prob(data, likelihood, bounds, fixed_scale)
    chain, diagnostics = run_ensemble(log_prob, p0, steps, rng, burn=burn, thin=thin,
                                      callback=callback, callback_every=callback_every)
    names = PARAM_NAMES if fixed_scale is not None else PARAM_NAMES + (
        "sigma" if likelihood == "gauss" else "b",)
    if fixed_scale is None:
        chain = np.concatenate([chain[..., :5], np.exp(chain[..., 5:])], axis=-1)
    samples = chain.reshape(-1, chain.shape[-1])

    speed = float(np.median(np.asarray(data.vehicle_speed)))
    idx = np.linspace(0, samples.shape[0] - 1, min(max_derived, samples.shape[0])).astype(int)
    mu_max, creep_opt = _peaks(jnp.asarray(samples[idx, :5]), jnp.asarray(data.k_eps, float), speed)
    derived_samples = {"mu_max": np.asarray(mu_max), "creep_opt": np.asarray(creep_opt)}
    return PosteriorResult(
        samples=samples, chain=chain, names=names,
        params={n: summarise(samples[:, i]) for i, n in enumerate(names)},
        derived={k: summarise(v) for k, v in derived_samples.items()},
        derived_samples=derived_samples, diagnostics=diagnostics, likelihood=likelihood,
        vehicle_speed=speed)


@jax.jit
def posterior_curves(theta_samples, creep, vehicle_speed, k_eps):
    """Adhesion curves ``mu_adh(s, s·v)`` [-] of each sample (m, 5) on a creep grid (g,) → (m, g)."""
    return jax.vmap(lambda th: polach_adhesion(th, creep, creep * vehicle_speed, k_eps))(theta_samples)


def table2_row(data: PolachDataset, theta0, *, walkers: int = 32, steps: int = 5000, seed: int = 0,
               likelihood: str = "gauss") -> dict:
    """The ``mcmc`` row of a Table-2-style comparison for one dataset.

    ``error``: MAE (the paper's fitness, eq 15) of the posterior-median parameters; ``steps`` /
    ``evaluations`` / ``seconds``: what a converged chain costs — burn-in plus ``50 τ_max`` steps,
    seconds scaled from this run (the chain must be long enough for τ to be trusted: check
    ``converged``); ``width90``: 90 % interval widths of the parameters and derived quantities.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ChainTooShortWarning)
        result = sample_posterior(data, theta0, walkers=walkers, steps=steps, seed=seed,
                                  likelihood=likelihood)
    d = result.diagnostics
    median = np.array([result.params[n]["median"] for n in PARAM_NAMES])
    needed = int(np.ceil(d.burn + MIN_TAU_MULTIPLE * np.max(d.tau) * d.thin))
    return {"method": "mcmc", "error": float(polach_mae(jnp.asarray(median), data)),
            "params": dict(zip(PARAM_NAMES, median.tolist())), "steps": needed,
            "evaluations": needed * walkers, "seconds": d.seconds * needed / d.steps,
            "converged": not d.warnings,
            "width90": {n: q["q95"] - q["q05"] for n, q in {**result.params, **result.derived}.items()}}
