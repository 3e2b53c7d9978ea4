"""A thin, reproducible driver around ``emcee.EnsembleSampler`` for vectorised log-probabilities.

``run_ensemble(log_prob, p0, steps, seed)`` runs one of emcee's move sets (:data:`MOVES`,
differential evolution by default) with ``vectorize=True`` (``log_prob`` maps a (W, d) array of
walkers to W values in one call), discards burn-in, thins, and measures the integrated
autocorrelation time τ per coordinate. With ``max_steps`` the chain is extended in rounds until it
holds ``MIN_TAU_MULTIPLE`` τ_max kept steps or reaches ``max_steps``. A chain still shorter than
``MIN_TAU_MULTIPLE`` τ triggers :class:`ChainTooShortWarning` (also listed in the diagnostics).
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

#: emcee's moves by name, each with its probability: ``"de"`` (the default), differential evolution
#: (ter Braak 2006, as Nelson et al. 2014 scale it); ``"stretch"``, the affine-invariant stretch move
#: (Goodman & Weare 2010). On 12 recordings their 90 % intervals agreed within 7 %, and DE held 50 τ
#: on 10 where the stretch move did on 6, in 5 000 steps on ours against 7 700–10 200 (README,
#: *Commands*, ``posterior``). Not the 80/20 mix with ``DESnookerMove`` that emcee's documentation
#: shows: on a 6-D Gaussian (condition number 10⁴) that mix's 90 % intervals came out 5 % narrow
#: after 6 000 steps of 32 walkers (4 seeds, every coordinate), ``DEMove`` alone within 1 %, the
#: snooker move alone never left its start.
MOVES = {
    "stretch": ((emcee.moves.StretchMove(), 1.0),),
    "de": ((emcee.moves.DEMove(), 1.0),),
}


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
    moves: str = "de"  # the move set run, a name in MOVES


def integrated_time(chain: np.ndarray) -> np.ndarray:
    """emcee's integrated autocorrelation time per coordinate of ``chain`` (steps, walkers, d),
    computed whatever the chain length (``tol=0``; judge it against the length yourself). NaN for a
    coordinate in which some walker never moved, without NumPy's warning: :func:`run_ensemble`
    reports it as a chain that did not mix. emcee gives NaN there only when the walker's series
    minus its mean is exactly 0; where the mean rounds, the series is a constant offset whose
    autocorrelation never decays, emcee's window never closes and it returns τ(0) = 1, as if every
    step were independent (a 45-step posterior chain at acceptance 0.1 reported τ = 1 and an ESS
    of every sample in four of six coordinates)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = emcee.autocorr.integrated_time(chain, tol=0)
    stuck = np.any(np.ptp(chain, axis=0) == 0.0, axis=0)
    return np.where(stuck, np.nan, tau)


def unmixed(tau: np.ndarray, kept: int) -> np.ndarray:
    """Per coordinate (bool, like ``tau``): a chain of ``kept`` steps holds fewer than
    :data:`MIN_TAU_MULTIPLE` of its autocorrelation times, or τ is undefined (a walker never
    moved). The one rule behind :class:`ChainTooShortWarning`."""
    tau = np.asarray(tau, float)
    return ~np.isfinite(tau) | (kept < MIN_TAU_MULTIPLE * np.where(np.isfinite(tau), tau, 0.0))


def steps_needed(tau: np.ndarray, burn: int, thin: int) -> Optional[int]:
    """Steps a chain with autocorrelation times ``tau`` (kept steps) must run, burn-in included, to
    keep :data:`MIN_TAU_MULTIPLE` of the slowest; None where some τ is undefined (a walker never
    moved: no length would do)."""
    tau_max = np.max(tau)
    return int(math.ceil(MIN_TAU_MULTIPLE * tau_max * thin + burn)) if np.isfinite(tau_max) else None


def run_ensemble(
    log_prob: Callable[[np.ndarray], np.ndarray],
    p0: np.ndarray,
    steps: int,
    seed: int | np.random.Generator,
    *,
    burn: int = 0,
    thin: int = 1,
    max_steps: Optional[int] = None,
    callback: Optional[Callable[[int, int], None]] = None,
    callback_every: int = 100,
    moves: str = "de",
):
    """Run emcee from walkers ``p0`` (W, d) with the :data:`MOVES` named ``moves``; returns
    ``(chain, diagnostics)`` with ``chain`` of shape (kept steps, W, d) after discarding ``burn``
    steps and keeping every ``thin``-th.

    ``seed`` (an int or a NumPy Generator) fixes emcee's random state, so runs are reproducible.
    ``max_steps`` (> ``steps``): extend the chain while it is shorter than ``MIN_TAU_MULTIPLE``
    τ_max, each round to 1.2× the length that the current τ asks for (at least 1.25× the chain),
    up to ``max_steps`` in all. ``callback(done, total)`` is called every ``callback_every`` steps
    and at the end of each round (progress display; ``total`` grows when the chain is extended).
    """
    if not 0 <= burn < steps:
        raise ValueError(f"burn must be in [0, steps), got burn={burn}, steps={steps}")
    rng = np.random.default_rng(seed)
    walkers, dim = p0.shape
    sampler = emcee.EnsembleSampler(walkers, dim, log_prob, moves=list(MOVES[moves]), vectorize=True)
    sampler.random_state = np.random.RandomState(int(rng.integers(2**32))).get_state()
    start = time.perf_counter()
    done, total, state = 0, steps, p0
    while True:
        for _ in sampler.sample(state, iterations=total - done):
            done += 1
            if callback is not None and (done % callback_every == 0 or done == total):
                callback(done, total)
        chain = sampler.get_chain(discard=burn, thin=thin)
        # tol=0: emcee logs nothing; the chain-length check is ours (ChainTooShortWarning).
        tau = integrated_time(chain)
        need = steps_needed(tau, burn, thin)  # None for a coordinate that never moved: nothing to extend for
        if max_steps is None or done >= max_steps or need is None or done >= need:
            break
        total, state = min(max_steps, max(int(1.2 * need), int(1.25 * done))), sampler.get_last_sample()
    seconds = time.perf_counter() - start
    messages = []
    if need is None:  # unmixed(), first case
        messages.append(
            f"the chain did not mix: in {int(np.sum(~np.isfinite(tau)))} of {dim} coordinates a walker "
            "never moved (autocorrelation time undefined); start the walkers elsewhere or check the "
            "posterior's support"
        )
        warnings.warn(messages[-1], ChainTooShortWarning, stacklevel=3)
    elif np.any(unmixed(tau, chain.shape[0])):
        messages.append(
            f"chain of {chain.shape[0]} kept steps is shorter than {MIN_TAU_MULTIPLE} "
            f"autocorrelation times (tau_max = {np.max(tau):.1f} steps): run at least {need} steps"
        )
        warnings.warn(messages[-1], ChainTooShortWarning, stacklevel=3)
    n = chain.shape[0] * walkers
    return chain, Diagnostics(
        float(np.mean(sampler.acceptance_fraction)),
        tau,
        n / tau,
        n,
        done,
        burn,
        thin,
        seconds,
        tuple(messages),
        moves=moves,
    )
