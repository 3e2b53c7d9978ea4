"""A thin, reproducible driver around ``emcee.EnsembleSampler`` for vectorised log-probabilities.

``run_ensemble(log_prob, p0, steps, seed)`` runs the affine-invariant stretch move with
``vectorize=True`` (``log_prob`` maps a (W, d) array of walkers to W values in one call), discards
burn-in, thins, and measures the integrated autocorrelation time τ per coordinate. A chain shorter
than ``MIN_TAU_MULTIPLE`` τ triggers :class:`ChainTooShortWarning` (also listed in the diagnostics).
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Callable, NamedTuple, Optional

import emcee
import numpy as np

#: A chain shorter than this many integrated autocorrelation times triggers a warning.
MIN_TAU_MULTIPLE = 50


class ChainTooShortWarning(UserWarning):
    """The chain is shorter than ``MIN_TAU_MULTIPLE`` autocorrelation times: intervals are rough."""


class Diagnostics(NamedTuple):
    """Sampler diagnostics; ``tau`` and ``ess`` per sampled coordinate."""

    acceptance: float  # mean acceptance fraction of the walkers
    tau: np.ndarray  # integrated autocorrelation time [kept (thinned) steps]
    ess: np.ndarray  # effective sample size = n_samples / tau
    n_samples: int  # walkers × kept steps
    steps: int  # total steps run (burn-in included)
    burn: int
    thin: int
    seconds: float  # wall time of the sampling loop [s]
    warnings: tuple  # messages (e.g. chain too short)
    compile_seconds: float = 0.0  # first (compiling) log-probability calls, outside ``seconds``


def integrated_time(chain: np.ndarray) -> np.ndarray:
    """emcee's integrated autocorrelation time per coordinate of ``chain`` (steps, walkers, d),
    computed whatever the chain length (``tol=0``; judge it against the length yourself)."""
    return emcee.autocorr.integrated_time(chain, tol=0)


def run_ensemble(
    log_prob: Callable[[np.ndarray], np.ndarray],
    p0: np.ndarray,
    steps: int,
    seed: int | np.random.Generator,
    *,
    burn: int = 0,
    thin: int = 1,
    callback: Optional[Callable[[int], None]] = None,
    callback_every: int = 100,
):
    """Run emcee from walkers ``p0`` (W, d); returns ``(chain, diagnostics)`` with ``chain`` of shape
    (kept steps, W, d) after discarding ``burn`` steps and keeping every ``thin``-th.

    ``seed`` (an int or a NumPy Generator) fixes emcee's random state, so runs are reproducible.
    ``callback(i)`` is called every ``callback_every`` steps and at the end (progress display).
    """
    if not 0 <= burn < steps:
        raise ValueError(f"burn must be in [0, steps), got burn={burn}, steps={steps}")
    rng = np.random.default_rng(seed)
    walkers, dim = p0.shape
    sampler = emcee.EnsembleSampler(walkers, dim, log_prob, vectorize=True)
    sampler.random_state = np.random.RandomState(int(rng.integers(2**32))).get_state()
    start = time.perf_counter()
    for i, _ in enumerate(sampler.sample(p0, iterations=steps), start=1):
        if callback is not None and (i % callback_every == 0 or i == steps):
            callback(i)
    seconds = time.perf_counter() - start

    chain = sampler.get_chain(discard=burn, thin=thin)
    # tol=0: emcee logs nothing; the chain-length check is ours (ChainTooShortWarning).
    tau = integrated_time(chain)
    messages = []
    if chain.shape[0] < MIN_TAU_MULTIPLE * np.max(tau):
        messages.append(
            f"chain of {chain.shape[0]} kept steps is shorter than {MIN_TAU_MULTIPLE} "
            f"autocorrelation times (tau_max = {np.max(tau):.1f} steps): run at least "
            f"{int(math.ceil(MIN_TAU_MULTIPLE * np.max(tau) * thin + burn))} steps"
        )
        warnings.warn(messages[-1], ChainTooShortWarning, stacklevel=3)
    n = chain.shape[0] * walkers
    return chain, Diagnostics(
        float(np.mean(sampler.acceptance_fraction)),
        tau,
        n / tau,
        n,
        steps,
        burn,
        thin,
        seconds,
        tuple(messages),
    )
