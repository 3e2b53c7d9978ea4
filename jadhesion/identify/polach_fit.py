"""Identification of Polach's parameters ``[kA, kS, mu0, A, B]`` from a :class:`PolachDataset`.

Population methods minimise the paper's fitness (eq 15), the mean absolute error
``MAE = (1/N) Σ |mu_adh(theta; s_i, w_i) − mu_hat_i|`` over the box ``[0, 1]⁵``; LM minimises the
sum of squares over the same box (projected LM, :func:`.lm.box_lm`, seeded by a random search on a
subsample: "global LM", :data:`LM_POP`) in two stages: first of the errors-in-variables residual
(:mod:`.polach_residuals`: the expected curve over the smoothed slip's uncertainty when the dataset
has ``slip_sd``, else the plain one), whose robust spread gives the noise scale σ of ``mu_hat``; then,
with σ, of the standardised robust residual :func:`.polach_residuals.polach_lm_residual` (effective
variance σ² + Var[mu_adh], pseudo-Huber), one of its LM runs starting at the first stage's optimum.
It reports the MAE as well. Datasets are pytrees:
:func:`fit_polach_batch` vmaps over a leading axis of stacked datasets and keys, compiled once per
shape.
"""

from __future__ import annotations

import functools
from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..data.dataset import SAMPLE_FIELDS, PolachDataset
from ..errors import InputError
from .batch_fit import bucketed
from .driver import STALL_FTOL, run_until
from .likelihood import with_node_slips
from .lm import best_of, box_lm, box_lm_queue, global_lm, seed_starts, with_start
from .methods import NAMES as METHODS
from .methods import POPULATION as ALGORITHMS
from .polach_residuals import (
    MIN_SCALE,
    dataset_mae,
    eiv_scale,
    mean_abs,
    polach_lm_residual,
    polach_mae,
    polach_residual,
)

#: Global LM for Polach: ``LM_POP`` uniform random points scored on a subsample of at most
#: :data:`SEED_SAMPLES` rows seed ``LM_STARTS`` projected-LM runs (:func:`.lm.box_lm`, ``ftol =
#: 1e-10`` on the cost, ``xtol = 1e-8`` on the box-scaled parameters — far below the noise, whose
#: 1-σ parameter change moves the SSE by σ²) on that subsample; the lowest-cost one, converged or
#: not, is polished on all rows. Eight starts, not four: on 24 clean starts of the independent
#: generator, four (the best by the search's cost, which did not predict the basin) missed the
#: global minimum once (seed 8: cost 6.7× the truth's, peak 3.5 % off), eight on none.
#: Each subsample LM run is capped at ``LM_MAX_STEPS``, the full-data polish at
#: ``LM_POLISH_STEPS``: a cap, not the rule (the polish stops at its convergence test; where the
#: data determine only a combination such as (1 − A)·B it may crawl along that valley for
#: hundreds of steps: 243 on a 100 000-sample recording whose 100-step polish ended
#: ``max_steps``). (A random search compiles in a fraction of the time of an improved-TLBO search
#: and found the global minimum as often on noisy 1000-point data.)
LM_POP, LM_SEARCH_ITER, LM_STARTS, LM_MAX_STEPS, LM_POLISH_STEPS = 64, 0, 8, 100, 1000
#: Rows per block of a full-data LM linearisation (:func:`.box_lm.box_lm`'s ``block_rows``: the
#: residuals are row-wise): an hour of data needs one block's Jacobian in memory, not all rows'.
LM_BLOCK_ROWS = 8192


class PolachFit(NamedTuple):
    """A fit: ``params`` (5,) ``[kA, kS, mu0, A, B]``; ``mae`` (eq 15) and ``sse`` at them;
    ``iterations`` (optimiser iterations; LM: steps), ``evaluations`` (objective evaluations, the
    LM's seeding search included); ``reached`` (MAE ≤ target; false without a target);
    ``status`` (int32 :class:`jadhesion.status.Status` code: why the solver stopped);
    ``residual_scale``: LM's noise scale σ of ``mu_hat`` (the trust block's residual needs it:
    :func:`scaled`), None for the population methods."""

    params: jax.Array
    mae: jax.Array
    sse: jax.Array
    iterations: jax.Array
    evaluations: jax.Array
    reached: jax.Array
    status: jax.Array
    residual_scale: Optional[jax.Array] = None


def scaled(data: PolachDataset, fit) -> PolachDataset:
    """``data`` with the noise scale LM's fit used (unchanged for a population method's fit): the
    dataset on which :data:`LM_RESIDUAL` is the residual that fit minimised."""
    scale = getattr(fit, "residual_scale", None)
    return data if scale is None else data._replace(residual_scale=scale)


def _box(dtype):
    return jnp.zeros(5, dtype), jnp.ones(5, dtype)


#: The residual LM minimises (population methods keep the paper's MAE of :func:`polach_residual`).
LM_RESIDUAL = polach_lm_residual
#: Samples (at most) used by the global-LM seeding search and multi-start (strided subsample).
SEED_SAMPLES = 128
#: Work-queue lanes of a batched global LM: the subsample runs are small, so more of them step
#: side by side (32 × 128 rows); the full-data polish keeps the queue's default (8 × 1000 rows).
SEED_LANES = 32


def subsample(data: PolachDataset, n_max: int = SEED_SAMPLES) -> PolachDataset:
    """Every ``n/n_max``-th sample (evenly strided indices; static shape ``min(n, n_max)``).
    A padded dataset (``weight``; its valid samples first, more than ``n_max`` of them) gives
    the same rows as its unpadded self."""
    n = data.adhesion.shape[-1]
    if n <= n_max:
        return data
    if data.weight is not None:
        valid = jnp.sum(data.weight).astype(jnp.int32)
        idx = jnp.round(jnp.arange(n_max) * ((valid - 1) / (n_max - 1))).astype(jnp.int32)
    else:
        idx = np.linspace(0, n - 1, n_max).round().astype(np.int32)
    fields = (*SAMPLE_FIELDS, "weight")
    return data._replace(**{k: getattr(data, k)[idx] for k in fields if getattr(data, k) is not None})


def _global_lm(data, key, polish=True, start=None):
    seed_data = subsample(data)
    return global_lm(
        LM_RESIDUAL,
        _box(data.adhesion.dtype),
        key,
        data,
        n_starts=LM_STARTS,
        pop_size=LM_POP,
        search_iter=LM_SEARCH_ITER,
        search_args=None if seed_data is data else seed_data,
        max_steps=LM_MAX_STEPS,
        polish_steps=LM_POLISH_STEPS,
        block_rows=LM_BLOCK_ROWS,
        polish=polish,
        start=start,
    )


def refit_lm(params, data: PolachDataset):
    """One :func:`.lm.box_lm` run of LM's residual from ``params`` on ``data`` (its
    ``residual_scale`` the robust stage's, :func:`scaled`) with the fit's box, step cap and row
    blocks (the polish's): a refit of changed data near a fit's optimum, as the block jackknife of
    :func:`.trust.trust_numbers` makes."""
    return box_lm(
        LM_RESIDUAL,
        params,
        data,
        _box(data.adhesion.dtype),
        max_steps=LM_POLISH_STEPS,
        block_rows=LM_BLOCK_ROWS,
    )


#: Noise scale of LM's first stage: far above any residual of ``mu_hat``, so its standardised
#: robust residual is the errors-in-variables least squares to within a few per cent (only the
#: spread of its residuals is used: the second stage's scale).
FIRST_STAGE_SCALE = 1.0


def _two_stages(run, data, key):
    """LM's two stages (module docstring) as one ``lax.scan`` over the noise scale, so a program
    holds one copy of the global LM (the fit program's size is start-up time). ``run(data, key,
    polish, start)`` is one global-LM stage, ``(LMResult, seeding evaluations)``, on one dataset or
    a stack; the first stage skips the full-data polish (its scale is the spread over all rows of the
    residuals at the subsample's optimum: an hour's recording pays the full-data steps once). The
    second stage also starts one LM run at the first stage's optimum (``start``; NaN in the first):
    its random seeds alone can all fall into another basin, and on a clean start of the independent
    generator (seed 8) they did, ending at a robust cost 12× the first stage's basin's.
    Returns the second stage's result (the first's where the scale is at
    :data:`.polach_residuals.MIN_SCALE`: noise-free data, where a standardised stage would fit
    rounding; its steps stay counted), its scale, and the steps and evaluations of both."""

    def next_scale(params):
        return jax.vmap(eiv_scale)(params, data) if data.adhesion.ndim > 1 else eiv_scale(params, data)

    def stage(carry, index):
        scale, start = carry
        out, n_pop = run(data._replace(residual_scale=scale), key, index == 1, start)
        # the second stage's result needs no further scale (a full-data residual and a median)
        new = jax.lax.cond(index == 0, next_scale, lambda _: scale, out.params)
        return (new, out.params), (out, n_pop, scale)

    batch, dtype = data.adhesion.shape[:-1], data.adhesion.dtype
    init = jnp.full(batch, FIRST_STAGE_SCALE, dtype), jnp.full((*batch, 5), jnp.nan, dtype)
    _, (outs, n_pops, scales) = jax.lax.scan(stage, init, jnp.arange(2))
    first, second = (jax.tree.map(lambda a, i=i: a[i], outs) for i in (0, 1))
    scale = scales[1]
    free = scale <= MIN_SCALE

    def pick(a, b):
        return jnp.where(jnp.reshape(free, free.shape + (1,) * (a.ndim - free.ndim)), a, b)

    out = jax.tree.map(pick, first, second)
    steps = first.steps + second.steps
    return out, scale, steps, n_pops[0] + n_pops[1] + steps


def _fit(method, pop_size, max_iter, use_target, data, key, target):
    bounds = _box(data.adhesion.dtype)
    scale = None
    if method == "lm":
        out, scale, iterations, evaluations = _two_stages(_global_lm, with_node_slips(data), key)
        theta = out.params
    else:
        out = run_until(
            ALGORITHMS[method],
            polach_mae,
            bounds,
            key,
            pop_size,
            max_iter,
            target if use_target else None,
            args=data,
            ftol=None if use_target else STALL_FTOL,
        )
        theta, iterations, evaluations = out.best_x, out.iterations, out.n_evals
    r = polach_residual(theta, data)
    mae = dataset_mae(r, data)
    reached = (mae <= target) if use_target else jnp.zeros((), bool)
    return PolachFit(theta, mae, jnp.sum(r * r), iterations, evaluations, reached, out.status, scale)


_STATIC = ("method", "pop_size", "max_iter", "use_target")
_fit_one = jax.jit(_fit, static_argnames=_STATIC)


@functools.partial(jax.jit, static_argnames=_STATIC)
def _fit_many(method, pop_size, max_iter, use_target, data, keys, target):
    if method == "lm" and data.adhesion.shape[-1] > SEED_SAMPLES:
        return _global_lm_many(data, keys, target, use_target)
    return jax.vmap(lambda d, k, t: _fit(method, pop_size, max_iter, use_target, d, k, t))(data, keys, target)


def _global_lm_many(data, keys, target, use_target):
    """Global LM on a stack of N datasets, both stages (module docstring), each as two work queues
    (:func:`_queued_lm`). Results equal :func:`fit_polach`'s per dataset."""
    polish, scale, steps, evaluations = _two_stages(_queued_lm, with_node_slips(data), keys)
    r = jax.vmap(polach_residual)(polish.params, data)
    mae = mean_abs(r) if data.weight is None else jax.vmap(dataset_mae)(r, data)
    reached = (mae <= target) if use_target else jnp.zeros(mae.shape, bool)
    return PolachFit(
        polish.params,
        mae,
        jnp.sum(r * r, axis=-1),
        steps,
        evaluations,
        reached,
        polish.status,
        scale,
    )


def _queued_lm(data, keys, polish=True, start=None):
    """One global-LM stage on a stack of datasets as two work queues (:func:`.lm.box_lm_queue`):
    the seeding searches are vmapped, then all N × ``LM_STARTS`` subsample LM runs share one queue
    and the N full-data polishes another, so the batch costs the total of its LM steps rather than
    the slowest run's steps times the batch (a vmapped while loop's price). Returns the polishes'
    :class:`.lm.LMResult` (without ``polish``: the subsample's best) and the seeding evaluations
    per dataset. ``start`` (N, 5): one more start per dataset, as :func:`.global_lm.global_lm`'s."""
    bounds = _box(data.adhesion.dtype)
    seed_data = jax.vmap(subsample)(data)
    starts, n_pop = jax.vmap(
        lambda d, k: seed_starts(
            LM_RESIDUAL, bounds, k, d, n_starts=LM_STARTS, pop_size=LM_POP, search_iter=LM_SEARCH_ITER
        )
    )(seed_data, keys)
    if start is not None:
        starts = with_start(starts, start)
    n = starts.shape[0]
    repeated = jax.tree.map(lambda a: jnp.repeat(a, LM_STARTS, axis=0), seed_data)
    seeded = box_lm_queue(
        LM_RESIDUAL,
        starts.reshape(n * LM_STARTS, -1),
        repeated,
        bounds,
        max_steps=LM_MAX_STEPS,
        lanes=SEED_LANES,
    )
    seeded = jax.vmap(lambda r: best_of(r, converged_first=False))(
        jax.tree.map(lambda a: a.reshape((n, LM_STARTS) + a.shape[1:]), seeded)
    )

    def polished():
        final = box_lm_queue(
            LM_RESIDUAL, seeded.params, data, bounds, max_steps=LM_POLISH_STEPS, block_rows=LM_BLOCK_ROWS
        )
        return final._replace(steps=seeded.steps + final.steps)

    return jax.lax.cond(polish, polished, lambda: seeded), n_pop


#: Fewest samples a Polach fit accepts: twice the five parameters (fewer cannot identify the
#: model; the fit would interpolate noise and report a meaningless tiny MAE).
MIN_SAMPLES = 10
#: Below this many samples a fit runs but warns ``few_samples``: the covariance of a
#: five-parameter curve from coloured noise is unreliable with fewer.
RECOMMENDED_SAMPLES = 100


def check_float64(name, *arrays):
    """Raise :class:`InputError` unless every array is float64 (JAX's x64 mode off would make the
    fit run silently in float32: enable it with ``jax.config.update("jax_enable_x64", True)``)."""
    for a in jax.tree.leaves(arrays):
        if jnp.issubdtype(jnp.asarray(a).dtype, jnp.floating) and jnp.asarray(a).dtype != jnp.float64:
            raise InputError(
                f"{name}: float64 input required, got {jnp.asarray(a).dtype} "
                "(enable JAX's x64 mode: jax.config.update('jax_enable_x64', True))"
            )


def require_samples(dataset: PolachDataset, source: str = "dataset") -> None:
    """Raise :class:`InputError` naming ``source`` when ``dataset`` has fewer than
    :data:`MIN_SAMPLES` samples."""
    n = dataset.adhesion.shape[-1]
    if n < MIN_SAMPLES:
        raise InputError(
            f"{source}: {n} samples cannot identify Polach's 5 parameters "
            f"(at least {MIN_SAMPLES} needed, {RECOMMENDED_SAMPLES} recommended)"
        )


def _check(method, dataset, pop_size, max_iter, target):
    if method not in METHODS:
        raise InputError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    check_float64("fit_polach", dataset.creep, dataset.slip, dataset.adhesion)
    require_samples(dataset, "fit_polach")
    if pop_size < 2:
        raise InputError(f"fit_polach: pop_size must be >= 2, got {pop_size}")
    if max_iter < 1:
        raise InputError(f"fit_polach: max_iter must be >= 1, got {max_iter}")
    if target is not None and not np.all(np.asarray(target) >= 0):
        raise InputError(f"fit_polach: target MAE must be >= 0, got {target}")


def fit_polach(
    dataset: PolachDataset,
    method: str,
    key,
    *,
    pop_size: int = 50,
    max_iter: int = 300,
    target: Optional[float] = None,
    pad: bool = True,
) -> PolachFit:
    """Identify Polach's parameters from one dataset.

    ``method``: ``"itlbo"`` (improved TLBO, paper §3.2), ``"tlbo"``, ``"pso"`` or ``"lm"``. With a
    ``target`` MAE a population method stops as soon as it is reached (bounded while loop,
    ``iterations`` = iterations used; the stall test is off so Table 2 counts iterations to the
    target); without one it stops when the stall test of :mod:`.driver` passes (best MAE improved
    by < :data:`.driver.STALL_FTOL` relative over :data:`.driver.STALL_WINDOW` iterations),
    ``max_iter`` being only a cap. ``status`` says which. Refuses float32 data and fewer than
    :data:`MIN_SAMPLES` samples (:class:`jadhesion.errors.InputError`). ``pop_size``/``max_iter``
    do not apply to LM (see :data:`LM_POP`: the best 8 of 64 random points, scored on at most 128
    samples, seed projected LM there; the best is polished on all samples).

    ``pad``: fit the dataset padded to its length bucket (:func:`.batch_fit.bucketed`; as it is
    when it has a ``weight`` already): the same problem, the same answer (population methods bit for bit,
    LM to round-off), and one compiled program for every length of a bucket, so a loop over
    recordings of many lengths compiles a few programs instead of one per length (each holds about
    a thousand of the process's memory maps; tens of thousands exhaust Linux's default limit and
    abort the process). ``pad=False`` fits the samples as given.
    """
    _check(method, dataset, pop_size, max_iter, target)
    if pad:
        dataset = bucketed(dataset)
    target_ = jnp.asarray(0.0 if target is None else target, dataset.adhesion.dtype)
    return _fit_one(method, pop_size, max_iter, target is not None, dataset, key, target_)


def fit_polach_batch(
    datasets: PolachDataset,
    method: str,
    keys,
    *,
    pop_size: int = 50,
    max_iter: int = 300,
    target: Optional[float] = None,
) -> PolachFit:
    """:func:`fit_polach` vmapped over a leading axis of stacked ``datasets`` and ``keys``;
    ``target`` is a scalar or one MAE per dataset.

    Stack datasets with ``jax.tree.map(lambda *a: jnp.stack(a), *datasets)`` (equal lengths).
    A batched population fit with a ``target`` (a vmapped while loop) runs until its slowest member
    stops; batched LM polishes through a work queue and costs the batch's total LM steps.
    """
    _check(method, datasets, pop_size, max_iter, target)
    target_ = jnp.broadcast_to(
        jnp.asarray(0.0 if target is None else target, datasets.adhesion.dtype), datasets.adhesion.shape[:1]
    )
    return _fit_many(method, pop_size, max_iter, target is not None, datasets, keys, target_)
