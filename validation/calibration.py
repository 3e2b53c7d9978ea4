"""Calibration of posterior intervals on simulated data with known truth.

Over many datasets simulated from known parameters, a calibrated posterior's central q-intervals
contain the truth in a fraction q of the cases (per parameter and per derived quantity). With m
datasets the observed fraction is Binomial(m, q)/m; :func:`binomial_band` gives the band it must
fall in. Checking both q = 0.9 and q = 0.5 catches under-dispersion (too-narrow intervals) and
over-dispersion (e.g. a sampler that ignores the data and returns the prior).
"""

from __future__ import annotations

import math
import warnings
from typing import Callable, NamedTuple, Optional

import jax.numpy as jnp
import numpy as np

from jadhesion.data.dataset import PolachDataset
from jadhesion.identify.laplace import initial_spread, lm_optimum
from jadhesion.identify.mcmc import ChainTooShortWarning, sample_posterior
from jadhesion.models.polach import PARAM_NAMES, adhesion_peak, polach_adhesion

LEVELS = (0.9, 0.5)
# Faces of the default prior box for the 5 parameters; the derived quantities have none.
_BOX_LO = np.array([0.0] * 5 + [-np.inf] * 2)
_BOX_HI = np.array([1.0] * 5 + [np.inf] * 2)
QUANTITIES = PARAM_NAMES + ("mu_max", "creep_opt")


class CoverageReport(NamedTuple):
    """``hits[level]``: (m, len(QUANTITIES)) booleans; ``coverage[level]``: name → fraction;
    ``width90``: name → median 90 % interval width; ``seconds``: sampling time per dataset [s]."""

    hits: dict
    coverage: dict
    n_datasets: int
    width90: dict
    seconds: float


def synthetic_dataset(
    rng: np.random.Generator,
    theta,
    n: int = 300,
    sigma: float = 0.013,
    k_eps: float = 130.0,
    speed=(0.6, 3.0),
    creep=(1e-3, 1.0),
) -> PolachDataset:
    """``n`` samples of ``polach_adhesion(theta)`` plus Gaussian noise ``sigma`` [-]: creep
    log-uniform on ``creep`` (dense around the peak at s ≈ 0.01–0.2), vehicle speed uniform on
    ``speed`` [m/s], slip ``w = s·v`` [m/s]."""
    s = np.exp(rng.uniform(np.log(creep[0]), np.log(creep[1]), n))
    v = rng.uniform(*speed, n)
    mu = np.asarray(polach_adhesion(jnp.asarray(theta, float), s, s * v, k_eps))
    return PolachDataset(
        jnp.asarray(s),
        jnp.asarray(s * v),
        jnp.asarray(mu + sigma * rng.standard_normal(n)),
        jnp.asarray(v),
        jnp.asarray(float(k_eps)),
    )


def binomial_band(m: int, q: float, level: float = 0.99) -> tuple:
    """Central ``level`` band of Binomial(m, q)/m (exact, from the CDF)."""
    pmf = [math.comb(m, k) * q**k * (1 - q) ** (m - k) for k in range(m + 1)]
    cdf = np.cumsum(pmf)
    tail = (1 - level) / 2
    lo = int(np.searchsorted(cdf, tail))
    hi = int(np.searchsorted(cdf, 1 - tail))
    return lo / m, hi / m


def truth_quantities(theta, data: PolachDataset) -> np.ndarray:
    """The true values of :data:`QUANTITIES` (derived ones at the dataset's median speed)."""
    mu_max, creep_opt = adhesion_peak(
        jnp.asarray(theta, float), data.k_eps, float(np.median(np.asarray(data.vehicle_speed)))
    )
    return np.concatenate([np.asarray(theta, float), [float(mu_max), float(creep_opt)]])


def interval_hits(draws: np.ndarray, truth: np.ndarray, level: float, lower=None, upper=None):
    """Whether each column's ``level`` interval of ``draws`` (m, k) contains ``truth`` (k,).

    Central intervals, except for a truth on a face of the prior box (``lower``/``upper``, (k,),
    ``±inf`` where there is none): no central interval can contain it, so the one-sided interval
    reaching that face is used (``[q(1 − level), upper]`` on the upper face).
    """
    k = draws.shape[1]
    lower = np.full(k, -np.inf) if lower is None else np.asarray(lower, float)
    upper = np.full(k, np.inf) if upper is None else np.asarray(upper, float)
    lo, hi = np.quantile(draws, [(1 - level) / 2, (1 + level) / 2], axis=0)
    lo = np.where(
        truth >= upper, np.quantile(draws, 1 - level, axis=0), np.where(truth <= lower, -np.inf, lo)
    )
    hi = np.where(truth <= lower, np.quantile(draws, level, axis=0), np.where(truth >= upper, np.inf, hi))
    return (lo <= truth) & (truth <= hi)


def posterior_draws(result) -> np.ndarray:
    """Posterior draws of :data:`QUANTITIES` (derived ones on their thinned subset)."""
    m = result.derived_samples["mu_max"].shape[0]
    idx = np.linspace(0, result.samples.shape[0] - 1, m).astype(int)
    return np.column_stack(
        [result.samples[idx, :5], result.derived_samples["mu_max"], result.derived_samples["creep_opt"]]
    )


def coverage_study(
    datasets,
    thetas,
    *,
    sampler: Optional[Callable] = None,
    seed: int = 0,
    progress: Optional[Callable[[int], None]] = None,
    observers=None,
    on_result: Optional[Callable] = None,
    **options,
) -> CoverageReport:
    """Posterior for each (dataset, true theta) pair; interval hits at :data:`LEVELS`.

    ``sampler(data, theta0, seed=..., spread=..., **options)`` defaults to :func:`sample_posterior`;
    walkers start around the LM optimum (:func:`lm_optimum`, ball from :func:`initial_spread`),
    never at the truth. ``observers``: one :class:`~.likelihood.ObserverTerms` per dataset, passed
    on as ``obs`` (and used for the LM start) — for ``likelihood="observer"``.
    ``on_result(i, result)`` sees each posterior (e.g. to collect diagnostics). Short-chain
    warnings are silenced here (the study reports coverage; chain length is the caller's choice).
    """
    sampler = sample_posterior if sampler is None else sampler
    hits = {level: [] for level in LEVELS}
    widths, seconds = [], []
    for i, (data, theta) in enumerate(zip(datasets, thetas, strict=True)):
        obs = None if observers is None else observers[i]
        extra = {} if obs is None else {"obs": obs}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ChainTooShortWarning)
            theta0 = lm_optimum(data, obs=obs)
            result = sampler(
                data,
                np.asarray(theta0),
                seed=seed + i,
                spread=np.asarray(initial_spread(theta0, data, obs=obs)),
                **options,
                **extra,
            )
        if on_result is not None:
            on_result(i, result)
        draws, truth = posterior_draws(result), truth_quantities(theta, data)
        widths.append(np.diff(np.quantile(draws, [0.05, 0.95], axis=0), axis=0)[0])
        seconds.append(result.diagnostics.seconds)
        for level in LEVELS:
            hits[level].append(interval_hits(draws, truth, level, _BOX_LO, _BOX_HI))
        if progress is not None:
            progress(i + 1)
    hits = {level: np.array(h) for level, h in hits.items()}
    coverage = {
        level: dict(zip(QUANTITIES, h.mean(axis=0).tolist(), strict=True)) for level, h in hits.items()
    }
    width90 = dict(zip(QUANTITIES, np.median(widths, axis=0).tolist(), strict=True))
    return CoverageReport(hits, coverage, len(thetas), width90, float(np.mean(seconds)))
