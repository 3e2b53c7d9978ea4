"""Identification of Polach's parameters ``[kA, kS, mu0, A, B]`` from a :class:`PolachDataset`.

Population methods minimise the paper's fitness (eq 15), the mean absolute error
``MAE = (1/N) Σ |mu_adh(theta; s_i, w_i) − mu_hat_i|`` over the box ``[0, 1]⁵``; LM minimises the
sum of squares over the same box (sine map, :mod:`.lm`), seeded by a short improved-TLBO search
("global LM"), and reports the MAE as well. Datasets are pytrees: :func:`fit_polach_batch` vmaps
over a leading axis of stacked datasets and keys, compiled once per shape.
"""

from __future__ import annotations

import functools
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp

from ..data.dataset import PolachDataset
from ..models.polach import polach_adhesion
from .driver import run, run_until
from .lm import global_lm
from .pso import PSO
from .tlbo import ITLBO, TLBO

ALGORITHMS = {"itlbo": ITLBO, "tlbo": TLBO, "pso": PSO}
METHODS = (*ALGORITHMS, "lm")


class PolachFit(NamedTuple):
    """A fit: ``params`` (5,) ``[kA, kS, mu0, A, B]``; ``mae`` (eq 15) and ``sse`` at them;
    ``iterations`` (optimiser iterations; LM: steps), ``evaluations`` (objective evaluations, the
    LM's seeding search included); ``reached`` (MAE ≤ target; without a target: finite result);
    ``history`` best MAE per iteration for a fixed-budget population fit, else ``None``."""

    params: jax.Array
    mae: jax.Array
    sse: jax.Array
    iterations: jax.Array
    evaluations: jax.Array
    reached: jax.Array
    history: Optional[jax.Array]


def polach_residual(theta, data: PolachDataset):
    """``mu_adh(theta) − mu_hat`` per sample, shape (n,)."""
    return polach_adhesion(theta, data.creep, data.slip, data.k_eps) - data.adhesion


def polach_mae(theta, data: PolachDataset):
    """The paper's fitness (eq 15): mean absolute error of the adhesion coefficient."""
    return jnp.mean(jnp.abs(polach_residual(theta, data)))


def _box(dtype):
    return jnp.zeros(5, dtype), jnp.ones(5, dtype)


def _fit(method, pop_size, max_iter, use_target, data, key, target):
    bounds = _box(data.adhesion.dtype)
    if method == "lm":
        out, n_pop = global_lm(polach_residual, bounds, key, data)
        theta, iterations, evaluations, history = out.params, out.steps, n_pop + out.steps, None
    else:
        driver = run_until if use_target else run
        out = driver(ALGORITHMS[method], polach_mae, bounds, key, pop_size, max_iter, target,
                     args=data)
        theta, iterations, evaluations = out.best_x, out.iterations, out.n_evals
        history = None if use_target else out.history.best_f
    r = polach_residual(theta, data)
    mae = jnp.mean(jnp.abs(r))
    reached = (mae <= target) if use_target else jnp.isfinite(mae)
    return PolachFit(theta, mae, jnp.sum(r * r), iterations, evaluations, reached, history)


_STATIC = ("method", "pop_size", "max_iter", "use_target")
_fit_one = jax.jit(_fit, static_argnames=_STATIC)


@functools.partial(jax.jit, static_argnames=_STATIC)
def _fit_many(method, pop_size, max_iter, use_target, data, keys, target):
    return jax.vmap(lambda d, k: _fit(method, pop_size, max_iter, use_target, d, k, target))(data, keys)


def _check(method):
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")


def fit_polach(dataset: PolachDataset, method: str, key, *, pop_size: int = 50,
               max_iter: int = 300, target: Optional[float] = None) -> PolachFit:
    """Identify Polach's parameters from one dataset.

    ``method``: ``"itlbo"`` (improved TLBO, paper §3.2), ``"tlbo"``, ``"pso"`` or ``"lm"``. With a
    ``target`` MAE a population method stops as soon as it is reached (bounded while loop,
    ``iterations`` = iterations used); without one it runs ``max_iter`` iterations (``history``
    kept). ``pop_size``/``max_iter`` do not apply to LM (5 improved-TLBO iterations on a class of 20
    seed 4 LM starts).
    """
    _check(method)
    target_ = jnp.asarray(0.0 if target is None else target, dataset.adhesion.dtype)
    return _fit_one(method, pop_size, max_iter, target is not None, dataset, key, target_)


def fit_polach_batch(datasets: PolachDataset, method: str, keys, *, pop_size: int = 50,
                     max_iter: int = 300, target: Optional[float] = None) -> PolachFit:
    """:func:`fit_polach` vmapped over a leading axis of stacked ``datasets`` and ``keys``.

    Stack datasets with ``jax.tree.map(lambda *a: jnp.stack(a), *datasets)`` (equal lengths).
    Note that a batched while loop (``target`` given) runs until its slowest member stops.
    """
    _check(method)
    target_ = jnp.asarray(0.0 if target is None else target, datasets.adhesion.dtype)
    return _fit_many(method, pop_size, max_iter, target is not None, datasets, keys, target_)
