"""One driver for every population optimiser: a fixed-budget scan or a bounded run to a target.

``objective(x, args) -> f``: ``args`` is any pytree (typically a dataset) passed as a traced
argument, so fits over batches of datasets or seeds vmap and never retrace for a new dataset of the
same shape. ``algorithm``, ``objective``, ``pop_size`` and ``max_iter`` are static (they fix the
program); ``bounds``, ``key``, ``target``, ``params`` and ``args`` are data.

Keys: ``init_key, step_key = split(key)``; iteration ``i`` (1-based) uses ``fold_in(step_key, i)``,
so :func:`run` and :func:`run_until` visit identical states.
"""

from __future__ import annotations

import functools
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp


class History(NamedTuple):
    """Per-iteration trace of a scanned run, leading axis ``max_iter``."""

    best_f: jax.Array
    best_x: jax.Array
    n_evals: jax.Array


class RunResult(NamedTuple):
    """Outcome of a run. ``hit_iteration``/``hit_evaluations``: when ``best_f ≤ target`` first held
    (iteration 0 is the initial population; -1 if never or no target). ``history`` is ``None`` for
    :func:`run_until`."""

    best_x: jax.Array
    best_f: jax.Array
    iterations: jax.Array
    n_evals: jax.Array
    hit_iteration: jax.Array
    hit_evaluations: jax.Array
    state: object
    history: Optional[History]


def iteration_key(key, i):
    """The key of iteration ``i`` (1-based) for a run started with ``key``."""
    return jax.random.fold_in(jax.random.split(key)[1], i)


def _setup(algorithm, objective, bounds, key, pop_size, params, args):
    bounds = tuple(jnp.asarray(b) for b in bounds)
    params = algorithm.default_params if params is None else params
    fn = (lambda x: objective(x, args)) if args is not None else objective
    state = algorithm.init(jax.random.split(key)[0], fn, bounds, pop_size, params)
    return bounds, params, fn, state


def _target(target, dtype):
    return jnp.asarray(-jnp.inf if target is None else target, dtype)


@functools.partial(jax.jit, static_argnames=("algorithm", "objective", "pop_size", "max_iter"))
def run(algorithm, objective, bounds, key, pop_size, max_iter, target=None, params=None, args=None):
    """Run ``max_iter`` iterations under ``lax.scan``, keeping the best-so-far history."""
    bounds, params, fn, state0 = _setup(algorithm, objective, bounds, key, pop_size, params, args)

    def body(state, i):
        state, _ = algorithm.step(iteration_key(key, i), state, fn, bounds, params)
        return state, History(state.best_f, state.best_x, state.n_evals)

    state, hist = jax.lax.scan(body, state0, jnp.arange(1, max_iter + 1))
    target = _target(target, state.best_f.dtype)
    f_all = jnp.concatenate([state0.best_f[None], hist.best_f])
    e_all = jnp.concatenate([state0.n_evals[None], hist.n_evals])
    hit = f_all <= target
    first = jnp.argmax(hit)
    reached = jnp.any(hit)
    return RunResult(state.best_x, state.best_f, jnp.asarray(max_iter), state.n_evals,
                     jnp.where(reached, first, -1), jnp.where(reached, e_all[first], -1), state, hist)


@functools.partial(jax.jit, static_argnames=("algorithm", "objective", "pop_size", "max_iter"))
def run_until(algorithm, objective, bounds, key, pop_size, max_iter, target, params=None, args=None):
    """Iterate under a bounded ``lax.while_loop`` until ``best_f ≤ target`` or ``max_iter``.

    Under ``vmap`` the loop runs until its slowest member stops; each member's state stays frozen
    once it has stopped, so results equal separate runs.
    """
    bounds, params, fn, state0 = _setup(algorithm, objective, bounds, key, pop_size, params, args)
    target = _target(target, state0.best_f.dtype)

    def cond(carry):
        i, state = carry
        return (i < max_iter) & ~(state.best_f <= target)

    def body(carry):
        i, state = carry
        state, _ = algorithm.step(iteration_key(key, i + 1), state, fn, bounds, params)
        return i + 1, state

    i, state = jax.lax.while_loop(cond, body, (jnp.asarray(0), state0))
    reached = state.best_f <= target
    return RunResult(state.best_x, state.best_f, i, state.n_evals, jnp.where(reached, i, -1),
                     jnp.where(reached, state.n_evals, -1), state, None)
