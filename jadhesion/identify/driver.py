"""One driver for every population optimiser: a fixed-budget scan or a bounded run to a target.

``objective(x, args) -> f``: ``args`` is any pytree (typically a dataset) passed as a traced
argument, so fits over batches of datasets or seeds vmap and never retrace for a new dataset of the
same shape. ``algorithm``, ``objective``, ``pop_size`` and ``max_iter`` are static (they fix the
program); ``bounds``, ``key``, ``target``, ``params`` and ``args`` are data.

Keys: ``init_key, step_key = split(key)``; iteration ``i`` (1-based) uses ``fold_in(step_key, i)``,
so :func:`run` and :func:`run_until` visit identical states.

**Convergence test** (the iteration count is only a cap): a run has converged when its best
fitness reached ``target``, or when it improved by no more than ``ftol`` relative over the last
``window`` iterations, ``f(i − window) − f(i) ≤ ftol·|f(i − window)|`` (the populations here are
elitist, so ``f`` never rises). Defaults :data:`STALL_FTOL` and :data:`STALL_WINDOW`. The result's
``status`` (an int32 :class:`jadhesion.status.Status` code) says why a run stopped: ``CONVERGED``,
``MAX_STEPS`` (cap reached first) or ``NONFINITE`` (no finite fitness was ever found).
"""

from __future__ import annotations

import functools
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp

from ..status import Status

#: Relative improvement of the best fitness over :data:`STALL_WINDOW` iterations below which a
#: population run has converged (``1e-6``: far below the change a 1-σ parameter shift makes to a
#: noisy MAE, far above rounding).
STALL_FTOL = 1e-6
#: Iterations over which the stall test compares the best fitness (static: it sizes a buffer).
STALL_WINDOW = 25


class History(NamedTuple):
    """Per-iteration trace of a scanned run, leading axis ``max_iter``."""

    best_f: jax.Array
    best_x: jax.Array
    n_evals: jax.Array


class RunResult(NamedTuple):
    """Outcome of a run. ``hit_iteration``/``hit_evaluations``: when ``best_f ≤ target`` first held
    (iteration 0 is the initial population; -1 if never or no target). ``history`` is ``None`` for
    :func:`run_until`. ``status``: why it stopped (see the module docstring)."""

    best_x: jax.Array
    best_f: jax.Array
    iterations: jax.Array
    n_evals: jax.Array
    hit_iteration: jax.Array
    hit_evaluations: jax.Array
    state: object
    history: Optional[History]
    status: jax.Array


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


def _ftol(ftol, dtype):
    """``None`` disables the stall test (a negative tolerance never passes)."""
    return jnp.asarray(-1.0 if ftol is None else ftol, dtype)


def _stalled(f_old, f_new, ftol):
    return (f_old - f_new <= ftol * jnp.abs(f_old)) & jnp.isfinite(f_new)


def _status(best_f, converged):
    return jnp.where(
        ~jnp.isfinite(best_f),
        int(Status.NONFINITE),
        jnp.where(converged, int(Status.CONVERGED), int(Status.MAX_STEPS)),
    ).astype(jnp.int32)


@functools.partial(jax.jit, static_argnames=("algorithm", "objective", "pop_size", "max_iter", "window"))
def run(
    algorithm,
    objective,
    bounds,
    key,
    pop_size,
    max_iter,
    target=None,
    params=None,
    args=None,
    ftol=STALL_FTOL,
    window=STALL_WINDOW,
):
    """Run ``max_iter`` iterations under ``lax.scan``, keeping the best-so-far history; the
    status is ``CONVERGED`` when the target was hit or the last ``window`` iterations pass the
    stall test."""
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
    back = min(window, max_iter)
    stalled = (max_iter >= window) & _stalled(f_all[-1 - back], f_all[-1], _ftol(ftol, f_all.dtype))
    return RunResult(
        state.best_x,
        state.best_f,
        jnp.asarray(max_iter),
        state.n_evals,
        jnp.where(reached, first, -1),
        jnp.where(reached, e_all[first], -1),
        state,
        hist,
        _status(state.best_f, reached | stalled),
    )


@functools.partial(jax.jit, static_argnames=("algorithm", "objective", "pop_size", "max_iter", "window"))
def run_until(
    algorithm,
    objective,
    bounds,
    key,
    pop_size,
    max_iter,
    target=None,
    params=None,
    args=None,
    ftol=None,
    window=STALL_WINDOW,
):
    """Iterate under a bounded ``lax.while_loop`` until ``best_f ≤ target``, the stall test
    (``ftol`` over ``window`` iterations; ``ftol=None`` switches it off) passes, or ``max_iter``.

    Under ``vmap`` the loop runs until its slowest member stops; each member's state stays frozen
    once it has stopped, so results equal separate runs.
    """
    bounds, params, fn, state0 = _setup(algorithm, objective, bounds, key, pop_size, params, args)
    target = _target(target, state0.best_f.dtype)
    ftol = _ftol(ftol, state0.best_f.dtype)
    ring0 = jnp.full((window,), state0.best_f)  # ring[j % window] = best f after iteration j

    def cond(carry):
        i, state, _, stalled = carry
        return (i < max_iter) & ~(state.best_f <= target) & ~stalled

    def body(carry):
        i, state, ring, _ = carry
        state, _ = algorithm.step(iteration_key(key, i + 1), state, fn, bounds, params)
        slot = (i + 1) % window  # still holds f(i + 1 − window)
        stalled = (i + 1 >= window) & _stalled(ring[slot], state.best_f, ftol)
        return i + 1, state, ring.at[slot].set(state.best_f), stalled

    i, state, _, stalled = jax.lax.while_loop(cond, body, (jnp.asarray(0), state0, ring0, jnp.asarray(False)))
    reached = state.best_f <= target
    return RunResult(
        state.best_x,
        state.best_f,
        i,
        state.n_evals,
        jnp.where(reached, i, -1),
        jnp.where(reached, state.n_evals, -1),
        state,
        None,
        _status(state.best_f, reached | stalled),
    )
