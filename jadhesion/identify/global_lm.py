"""Global LM: a cheap search on ``‖r‖²`` seeds several projected-LM runs; the best is kept (and
optionally polished on the full data)."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from .box_lm import DEFAULT_OPTIONS, box_lm
from .driver import run
from .lm_result import best_of, sse_objective
from .population import evaluate, uniform_population
from .tlbo import ITLBO


def seed_starts(residual, bounds, key, args=None, *, n_starts=4, pop_size=20, search_iter=5):
    """The ``n_starts`` best points (rows, best first) of a search on ``‖r‖²`` — a short
    improved-TLBO run (``search_iter`` iterations on a class of ``pop_size``) or, with
    ``search_iter = 0``, a plain uniform random search of ``pop_size`` points — and its number of
    evaluations. These seed :func:`global_lm`'s LM runs."""
    objective = sse_objective(residual)
    if search_iter > 0:
        run_ = run(ITLBO, objective, bounds, key, pop_size, search_iter, args=args)
        population, fitness, n_evals = run_.state.population, run_.state.fitness, run_.n_evals
    else:  # plain random search: one vmapped evaluation, no optimiser to compile
        population = uniform_population(key, tuple(jnp.asarray(b) for b in bounds), pop_size)
        fitness = evaluate(lambda p: objective(p, args), population)
        n_evals = jnp.asarray(pop_size)
    return population[jnp.argsort(fitness)[:n_starts]], n_evals


def with_start(starts, start):
    """``starts`` (…, n, d) with its last row (the search's worst) replaced by ``start`` (…, d),
    e.g. an earlier stage's optimum, so an LM run begins there; where a ``start`` row is not finite
    the search's row stays."""
    keep = jnp.all(jnp.isfinite(start), axis=-1, keepdims=True)
    return starts.at[..., -1, :].set(jnp.where(keep, start, starts[..., -1, :]))


def global_lm(
    residual,
    bounds,
    key,
    args=None,
    *,
    n_starts=4,
    pop_size=20,
    search_iter=5,
    search_args=None,
    max_steps=100,
    polish_steps=None,
    options=DEFAULT_OPTIONS,
    block_rows=None,
    polish=True,
    start=None,
):
    """ "Global LM": :func:`seed_starts` (a search on ``‖r‖²``) seeds ``n_starts`` :func:`box_lm`
    runs from its best members; the lowest-SSE answer is returned (a converged one first, as
    :func:`.lm_result.best_of`; with ``search_args``, the lowest-SSE run is polished converged or
    not).

    With ``search_args`` (e.g. a subsample of the data) the search *and* the multi-start LM use
    it, and only the best of them is polished by one :func:`box_lm` on ``args`` (capped at
    ``polish_steps``, default ``max_steps``): the expensive full-data Jacobians are then paid
    once, not ``n_starts`` times; ``polish`` (a bool, may be
    traced) false skips that polish and returns the subsample's best. ``block_rows``: see
    :func:`box_lm` (row-wise residuals only). ``start`` (d,): run one LM from there instead of the
    search's last start (:func:`with_start`; not finite: ignored). Returns ``(LMResult,
    population evaluations)``; ``steps`` sums every LM run's steps."""
    sub = args if search_args is None else search_args
    starts, n_evals = seed_starts(
        residual, bounds, key, sub, n_starts=n_starts, pop_size=pop_size, search_iter=search_iter
    )
    if start is not None:
        starts = with_start(starts, start)

    def solve(p, a, steps=max_steps):
        return box_lm(residual, p, a, bounds, options, max_steps=steps, block_rows=block_rows)

    # runs on a subsample only seed the polish: the lowest cost wins, converged or not
    out = best_of(jax.vmap(solve, in_axes=(0, None))(starts, sub), converged_first=search_args is None)
    if search_args is not None:

        def polished():
            final = solve(out.params, args, max_steps if polish_steps is None else polish_steps)
            return final._replace(steps=final.steps + out.steps)

        out = polished() if polish is True else jax.lax.cond(polish, polished, lambda: out)
    return out, n_evals
