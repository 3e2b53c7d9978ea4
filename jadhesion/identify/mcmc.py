"""Bayesian posterior of the Polach parameters with emcee's ensemble sampler (differential-evolution
moves by default, :data:`jadhesion.identify.ensemble.MOVES`).

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

import time
import warnings
from typing import Callable, NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import PolachDataset
from ..models.polach import PARAM_NAMES, adhesion_peak, polach_adhesion
from .ensemble import (  # noqa: F401
    MIN_TAU_MULTIPLE,
    ChainTooShortWarning,
    Diagnostics,
    integrated_time,
    run_ensemble,
    unmixed,
)
from .likelihood import (
    AUTOREGRESSIVE,
    LOG_SCALE_BOUNDS,
    RHO_MAX,
    ensemble_log_prob,
    log_posterior,
    noise_names,
    prediction,
    with_node_slips,
)
from .observer_view import ObserverTerms
from .peak import reference_speed
from .polach_residuals import residual_scale

QUANTILES = (0.05, 0.5, 0.95)


class PosteriorResult(NamedTuple):
    """Posterior samples and their summaries.

    ``params`` and ``derived`` map a name to ``{"median", "q05", "q95"}``. ``names`` lists the
    sampled coordinates: the five Polach parameters, then ``"sigma"``/``"b"`` (the noise scale,
    sampled as its logarithm; ``samples`` holds the scale itself) unless the scale was fixed, then
    ``"rho"`` (AR(1) coefficient) for the ``"ar1"`` and ``"observer"`` likelihoods.
    """

    samples: np.ndarray  # (n_samples, d) after burn-in and thinning
    chain: np.ndarray  # (kept steps, walkers, d), same coordinates as ``samples``
    names: tuple
    params: dict
    derived: dict
    derived_samples: dict  # name -> (m,) samples of mu_max and creep_opt
    diagnostics: Diagnostics
    likelihood: str
    vehicle_speed: float  # speed [m/s] at which the derived quantities are evaluated (median |v|)

    def chain_warning(self) -> Optional[dict]:
        """``{code: "chain_too_short", params, message}`` when the kept chain is shorter than
        :data:`MIN_TAU_MULTIPLE` autocorrelation times of some coordinates or did not mix in some
        (a walker that never moved: τ undefined) — ``params``: those, the unmixed and then the
        slowest first — else None. The message is the diagnostics' own, naming them."""
        if not self.diagnostics.warnings:
            return None
        tau = np.asarray(self.diagnostics.tau, float)
        short = unmixed(tau, self.chain.shape[0])
        slow = [self.names[i] for i in np.argsort(-np.where(np.isfinite(tau), tau, np.inf)) if short[i]]
        still = [n for n, t in zip(self.names, tau, strict=True) if not np.isfinite(t)]
        named = ([f"never moved: {', '.join(still)}"] if still else []) + (
            [f"short of {MIN_TAU_MULTIPLE} tau: {', '.join(n for n in slow if n not in still)}"]
            if len(slow) > len(still)
            else []
        )
        message = f"{self.diagnostics.warnings[-1]} ({'; '.join(named)}); intervals from this chain are rough"
        return {"code": "chain_too_short", "params": slow, "message": message}

    def theta(self) -> np.ndarray:
        """Samples of the five Polach parameters, (n_samples, 5)."""
        return self.samples[:, :5]

    def to_inference_data(self):
        """An ``arviz.InferenceData`` (one arviz chain per walker); needs ``arviz`` installed."""
        with warnings.catch_warnings():  # arviz 0.23 announces its 1.0 refactor on import
            warnings.simplefilter("ignore", FutureWarning)
            import arviz  # optional (the bench extra): imported only when asked for

        posterior = {name: np.swapaxes(self.chain[..., i], 0, 1) for i, name in enumerate(self.names)}
        return arviz.from_dict(posterior=posterior)


_peaks = jax.jit(jax.vmap(adhesion_peak, in_axes=(0, None, None)))


def summarise(samples: np.ndarray) -> dict:
    """Median and 5 / 95 % quantiles of 1-D samples."""
    q05, median, q95 = np.quantile(samples, QUANTILES)
    return {"median": float(median), "q05": float(q05), "q95": float(q95)}


def initial_ball(
    theta0,
    log_scale0: Optional[float],
    walkers: int,
    rng: np.random.Generator,
    bounds,
    spread=1e-3,
    rho0: Optional[float] = None,
) -> np.ndarray:
    """Walker positions: ``theta0`` (clipped into the box) plus Gaussian jitter of ``spread`` × box
    width (a scalar or one value per parameter), reflected back into the box, so walkers at a box
    face stay distinct and the ensemble keeps full rank. ``log_scale0``: the 6th coordinate;
    ``rho0``: the AR(1) coefficient, last."""
    lower, upper = (np.asarray(b, float) for b in bounds)
    jitter = np.asarray(spread, float) * (upper - lower) * rng.standard_normal((walkers, 5))
    theta = np.clip(np.asarray(theta0, float), lower, upper) + jitter
    theta = upper - np.abs(upper - (lower + np.abs(theta - lower)))
    columns = [theta]
    if log_scale0 is not None:
        lo, hi = LOG_SCALE_BOUNDS
        columns.append(np.clip(log_scale0, lo + 0.1, hi - 0.1) + 0.01 * rng.standard_normal((walkers, 1)))
    if rho0 is not None:
        rho = np.clip(rho0, -RHO_MAX + 0.02, RHO_MAX - 0.02) + 0.005 * rng.standard_normal((walkers, 1))
        columns.append(np.clip(rho, -RHO_MAX, RHO_MAX))
    return np.concatenate(columns, axis=1)


def initial_noise(data: PolachDataset, theta0, likelihood: str, obs: Optional[ObserverTerms] = None) -> tuple:
    """``(log_scale, rho or None)`` of the residuals at ``theta0``: RMS (``"gauss"``), mean |r|
    (``"laplace"``), 1.4826 MAD (``"student"``), or lag-1 autocorrelation and innovation RMS (AR(1))."""
    r = np.asarray(data.adhesion) - np.asarray(prediction(jnp.asarray(theta0), data, likelihood, obs))
    rho = None
    if likelihood in AUTOREGRESSIVE:
        rho = float(np.clip(np.sum(r[1:] * r[:-1]) / max(np.sum(r[:-1] ** 2), 1e-300), -0.95, 0.95))
        r = r[1:] - rho * r[:-1]
    if likelihood == "laplace":
        scale = np.mean(np.abs(r))
    elif likelihood == "student":
        scale = float(residual_scale(jnp.asarray(r), data))
    else:
        scale = np.sqrt(np.mean(r**2))
    return float(np.log(max(scale, 1e-4))), rho


def sample_posterior(
    data: PolachDataset,
    theta0,
    *,
    walkers: int = 32,
    steps: int = 5000,
    likelihood: str = "gauss",
    seed: int = 0,
    burn: Optional[int] = None,
    thin: int = 1,
    bounds=None,
    fixed_scale: Optional[float] = None,
    spread=1e-3,
    max_derived: int = 4000,
    max_steps: Optional[int] = None,
    callback: Optional[Callable[[int, int], None]] = None,
    callback_every: int = 100,
    obs: Optional[ObserverTerms] = None,
    weight: float = 1.0,
    moves: str = "de",
) -> PosteriorResult:
    """Sample the posterior of ``[kA, kS, mu0, A, B]`` (and the noise scale) with emcee.

    Args:
        data: the fitting dataset.
        theta0: a point near the mode (e.g. the LM optimum), shape (5,).
        walkers, steps: ensemble size and chain length (burn-in included).
        likelihood: ``"gauss"``, ``"student"`` (scale sigma), ``"laplace"`` (b), ``"ar1"`` (AR(1) residuals
            in time order: innovation scale sigma, coefficient rho) or ``"observer"`` (the
            observer's lag and torque leak modelled, AR(1) noise; needs ``obs``) — see
            :mod:`jadhesion.identify.likelihood`.
        seed: seeds the initial ball and emcee's random state.
        burn: steps discarded as burn-in (default ``steps // 4``); ``thin``: keep every thin-th.
        bounds: prior box ``(lower, upper)`` of the Polach parameters, default ``[0, 1]^5``.
        fixed_scale: a known noise scale [-] (not sampled) instead of the log-uniform prior.
        spread: initial ball radius as a fraction of the box width, scalar or (5,) — e.g.
            :func:`jadhesion.identify.laplace.initial_spread` to start near the posterior's width.
        max_derived: at most this many (evenly spaced) samples feed ``mu_max`` / ``creep_opt``.
        max_steps: extend the chain until it holds 50 autocorrelation times, up to this many
            steps in all (:func:`.ensemble.run_ensemble`); ``None``: exactly ``steps``.
        callback: ``callback(done, total)`` every ``callback_every`` steps (progress).
        moves: emcee's move set, a name in :data:`.ensemble.MOVES`.
        obs: :class:`ObserverTerms` of the recording (``"observer"`` only).
        weight: the log-likelihood's tempering 1/κ (1: none): with κ the residuals' colour factor
            (:func:`jadhesion.identify.uncertainty.colour_factor`) the posterior counts n/κ
            effective samples instead of n correlated ones.

    Emits :class:`ChainTooShortWarning` when the chain run (``steps``, or up to ``max_steps``)
    keeps fewer than 50 τ_max steps after ``burn``.
    """
    bounds = (np.zeros(5), np.ones(5)) if bounds is None else tuple(np.asarray(b, float) for b in bounds)
    burn = steps // 4 if burn is None else burn
    rng = np.random.default_rng(seed)
    names = PARAM_NAMES + noise_names(likelihood, fixed_scale is not None)
    log_prob = ensemble_log_prob(data, likelihood, bounds, fixed_scale, obs, weight)
    log_scale0, rho0 = initial_noise(data, theta0, likelihood, obs)
    p0 = initial_ball(
        theta0, None if fixed_scale is not None else log_scale0, walkers, rng, bounds, spread, rho0
    )
    t0 = time.perf_counter()
    log_prob(p0)  # emcee calls it on the whole ensemble, then on halves:
    log_prob(p0[: walkers // 2])  # compile both shapes here, outside the timed loop
    compile_seconds = time.perf_counter() - t0
    chain, diagnostics = run_ensemble(
        log_prob,
        p0,
        steps,
        rng,
        burn=burn,
        thin=thin,
        max_steps=max_steps,
        callback=callback,
        callback_every=callback_every,
        moves=moves,
    )
    diagnostics = diagnostics._replace(compile_seconds=compile_seconds)
    if fixed_scale is None:
        chain = np.concatenate([chain[..., :5], np.exp(chain[..., 5:6]), chain[..., 6:]], axis=-1)
    samples = chain.reshape(-1, chain.shape[-1])

    speed = float(reference_speed(jnp.asarray(data.vehicle_speed)))
    idx = np.linspace(0, samples.shape[0] - 1, min(max_derived, samples.shape[0])).astype(int)
    mu_max, creep_opt = _peaks(jnp.asarray(samples[idx, :5]), jnp.asarray(data.k_eps, float), speed)
    derived_samples = {"mu_max": np.asarray(mu_max), "creep_opt": np.asarray(creep_opt)}
    return PosteriorResult(
        samples=samples,
        chain=chain,
        names=names,
        params={n: summarise(samples[:, i]) for i, n in enumerate(names)},
        derived={k: summarise(v) for k, v in derived_samples.items()},
        derived_samples=derived_samples,
        diagnostics=diagnostics,
        likelihood=likelihood,
        vehicle_speed=speed,
    )


@jax.jit
def posterior_curves(theta_samples, creep, vehicle_speed, k_eps):
    """Adhesion curves ``mu_adh(s, s·v)`` [-] of each sample (m, 5) on a creep grid (g,) → (m, g)."""
    return jax.vmap(lambda th: polach_adhesion(th, creep, creep * vehicle_speed, k_eps))(theta_samples)


class NutsResult(NamedTuple):
    """Draws of :func:`sample_nuts` (constrained; the scale itself, not its log) and costs."""

    samples: np.ndarray  # (samples, d)
    names: tuple
    tau: np.ndarray  # integrated autocorrelation time per coordinate [draws]
    ess: np.ndarray  # samples / tau
    seconds: float  # warm wall time of warm-up + sampling [s]
    compile_seconds: float
    integration_steps: int  # leapfrog steps (gradient evaluations) after warm-up
    step_size: float


def sample_nuts(
    data: PolachDataset,
    theta0,
    *,
    likelihood: str = "gauss",
    obs: Optional[ObserverTerms] = None,
    warmup: int = 500,
    samples: int = 1000,
    seed: int = 0,
    bounds=None,
) -> NutsResult:
    """The same posterior as :func:`sample_posterior` with NUTS (blackjax, an optional extra:
    ``pip install 'jadhesion[nuts]'``), for comparison.

    Every sampled coordinate has a box prior (the Polach box, the log-scale range, ``|rho| ≤
    RHO_MAX``), so NUTS runs on ``z = logit((phi − lo)/(hi − lo))`` with the log-Jacobian added;
    Stan's window adaptation tunes the step size and a diagonal mass matrix during ``warmup``.
    One chain; warm-up and sampling are one jitted program (compiled ahead, timed apart).
    """
    try:
        import blackjax
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError(
            "sample_nuts needs the optional dependency blackjax "
            "(pip install 'jadhesion[nuts]' or pip install blackjax)"
        ) from None

    names = PARAM_NAMES + noise_names(likelihood)
    lower, upper = (
        (np.zeros(5), np.ones(5)) if bounds is None else tuple(np.asarray(b, float) for b in bounds)
    )
    lo = np.concatenate([lower, [LOG_SCALE_BOUNDS[0]], [-RHO_MAX] if likelihood in AUTOREGRESSIVE else []])
    hi = np.concatenate([upper, [LOG_SCALE_BOUNDS[1]], [RHO_MAX] if likelihood in AUTOREGRESSIVE else []])
    log_scale0, rho0 = initial_noise(data, theta0, likelihood, obs)
    phi0 = np.concatenate([np.asarray(theta0, float), [log_scale0], [] if rho0 is None else [rho0]])
    u0 = np.clip((phi0 - lo) / (hi - lo), 1e-3, 1 - 1e-3)
    lo_j, width = jnp.asarray(lo), jnp.asarray(hi - lo)
    data = with_node_slips(jax.tree_util.tree_map(lambda x: jnp.asarray(x, jnp.float64), data))
    lower_j, upper_j = jnp.asarray(lower), jnp.asarray(upper)

    def logdensity(z):
        phi = lo_j + width * jax.nn.sigmoid(z)
        jac = jnp.sum(jnp.log(width) + jax.nn.log_sigmoid(z) + jax.nn.log_sigmoid(-z))
        return log_posterior(phi, data, lower_j, upper_j, 0.0, likelihood, obs) + jac

    def run(key, z0):
        k_warm, k_draw = jax.random.split(key)
        warm = blackjax.window_adaptation(blackjax.nuts, logdensity)
        (state, params), _ = warm.run(k_warm, z0, num_steps=warmup)
        kernel = blackjax.nuts(logdensity, **params)

        def one(st, k):
            st, info = kernel.step(k, st)
            return st, (st.position, info.num_integration_steps)

        _, (zs, n_steps) = jax.lax.scan(one, state, jax.random.split(k_draw, samples))
        return lo_j + width * jax.nn.sigmoid(zs), jnp.sum(n_steps), params["step_size"]

    key, z0 = jax.random.key(seed), jnp.asarray(np.log(u0) - np.log1p(-u0))
    t0 = time.perf_counter()
    compiled = jax.jit(run).lower(key, z0).compile()
    compile_seconds = time.perf_counter() - t0
    t0 = time.perf_counter()
    draws, n_steps, step_size = jax.block_until_ready(compiled(key, z0))
    seconds = time.perf_counter() - t0
    draws = np.array(draws)
    draws[:, 5] = np.exp(draws[:, 5])
    tau = integrated_time(draws[:, None, :])
    return NutsResult(
        draws, names, tau, samples / tau, seconds, compile_seconds, int(n_steps), float(step_size)
    )
