"""Shared pieces of the box-constrained population optimisers (TLBO, improved TLBO, PSO).

Every optimiser is an :class:`Algorithm`: a pure ``init``/``step`` pair over an explicit state
pytree whose fields include ``best_x``, ``best_f`` and ``n_evals`` (what the driver reads)::

    state = init(key, objective, bounds, pop_size, params)
    state, info = step(key, state, objective, bounds, params)

``objective(x) -> f`` maps one candidate of shape (d,) to a scalar; the optimisers evaluate a whole
(sub)population with one vmapped call and treat a NaN or infinite value as ``+inf`` so a bad
candidate never leads. ``bounds = (lower, upper)``, each of shape (d,); candidates are clipped to it.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp


class Algorithm(NamedTuple):
    """A population optimiser: ``init``/``step`` plus its default coefficients (a params pytree)."""

    name: str
    init: Callable[..., Any]
    step: Callable[..., Any]
    default_params: Any


class StepInfo(NamedTuple):
    """Per-step diagnostics (not carried between steps)."""

    best_f: jax.Array
    mean_f: jax.Array


def evaluate(objective, x):
    """Fitness of a population ``x`` (n, d) by one vmapped call; NaN/inf become ``+inf``."""
    f = jax.vmap(objective)(x)
    return jnp.where(jnp.isfinite(f), f, jnp.inf)


def clip(x, bounds):
    """Project candidates (n, d) onto the box ``[lower, upper]``."""
    return jnp.clip(x, bounds[0][None], bounds[1][None])


def uniform_population(key, bounds, pop_size):
    """``pop_size`` candidates drawn uniformly in the box, shape (pop_size, d)."""
    lower, upper = (jnp.asarray(b) for b in bounds)
    u = jax.random.uniform(key, (pop_size, lower.shape[0]), dtype=lower.dtype)
    return lower[None] + u * (upper - lower)[None]


def greedy(x_old, f_old, x_new, f_new):
    """Keep, row by row, the better (lower-fitness) of the old and new candidates."""
    better = f_new < f_old
    return jnp.where(better[:, None], x_new, x_old), jnp.where(better, f_new, f_old)


def info(fitness):
    """Step diagnostics from a fitness vector (infinite values excluded from the mean)."""
    finite = jnp.isfinite(fitness)
    mean = jnp.sum(jnp.where(finite, fitness, 0.0)) / jnp.maximum(jnp.sum(finite), 1)
    return StepInfo(jnp.min(fitness), mean)
