"""Kiencke's model fitted offline: ``(p1, p2, a_s)`` from a :class:`PolachDataset` (creep λ, μ̂).

Model (paper 000, eq 1): ``μ(λ) = a_s λ / (1 + p1|λ| + p2 λ²)`` (odd in λ, so braking samples with
λ < 0, μ̂ < 0 fit the same curve).

**Search coordinates.** The optimisers work in the box :data:`SEARCH_BOUNDS` of
``z = (log10 a_s, log10 λ_m, μ_m)`` — initial slope [-], optimum creep [-], peak adhesion [-] — and
report ``p2 = λ_m⁻²``, ``p1 = a_s/μ_m − 2/λ_m`` (from ``λ_m = 1/√p2``, ``μ_m = a_s/(p1 + 2√p2)``).
The box is therefore the documented parameter bound: ``a_s ∈ [1, 10⁴]``, ``λ_m ∈ [10⁻⁴, 1]``
(``p2 ∈ [1, 10⁸]``), ``μ_m ∈ [0.01, 1.5]`` (``p1 ∈ (−2√p2, a_s/0.01 − 2√p2]``). Every point of it is a
curve with one positive peak and a denominator ``> 0`` for all λ (``p1 > −2√p2``): no pole, no NaN;
logarithmic coordinates give a uniform random search equal weight to every decade of slope and
optimum creep.

**Samples.** Only informative samples count (:func:`informative`): finite, ``|v| ≥``
:data:`MIN_SPEED` (creep is undefined at standstill) and ``|μ̂| ≥`` :data:`MIN_ADHESION` (coasting
carries no information about the curve), and not padding. The others get weight 0, so shapes stay
static and fits vmap; ``jadhesion fit --model kiencke`` pads each dataset to its length bucket
(:func:`.batch_fit.fit_datasets`), one compiled program per method and bucket.

**Methods.** ``lm``: global LM — :data:`LM_POP` uniform random points in the box seed
:data:`LM_STARTS` projected-LM runs (:func:`.lm.global_lm`, :func:`.lm.box_lm`) on the weighted
sum of squares; ``itlbo``, ``tlbo``, ``pso``: the population optimisers through
:func:`.driver.run` (fixed budget) on the weighted mean absolute error. Status (:class:`Status`):
LM ``converged`` when its MINPACK-style test passed, ``nonfinite`` for a non-finite result, else
``max_steps``; a population run ``converged`` when its best MAE changed by at most
:data:`STALL_RTOL` (relative) over its last :data:`STALL_FRACTION` of iterations, else
``max_steps``; ``not_run`` with fewer than :data:`MIN_SAMPLES` informative samples.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..data.dataset import PolachDataset
from ..models.kiencke import kiencke_adhesion, kiencke_optimum
from ..status import Status
from .driver import run
from .global_lm import global_lm
from .pso import PSO
from .tlbo import ITLBO, TLBO

PARAM_NAMES = ("p1", "p2", "a_s")
ALGORITHMS = {"itlbo": ITLBO, "tlbo": TLBO, "pso": PSO}
METHODS = (*ALGORITHMS, "lm")
#: Box of the search coordinates ``(log10 a_s, log10 λ_m, μ_m)`` (module docstring).
SEARCH_BOUNDS = ((0.0, -4.0, 0.01), (4.0, 0.0, 1.5))
#: log10 bounds of the initial slope a_s [-] (the box's first coordinate; a given a_s is checked
#: against them).
A_S_LOG10_BOUNDS = (SEARCH_BOUNDS[0][0], SEARCH_BOUNDS[1][0])
#: Informative samples: ``|v| ≥ MIN_SPEED`` [m/s] and ``|μ̂| ≥ MIN_ADHESION`` [-].
MIN_SPEED = 0.1
MIN_ADHESION = 0.02
#: Fewest informative samples for a fit (three parameters and a noise level).
MIN_SAMPLES = 10
#: Global LM: random points, LM starts, steps per LM run.
LM_POP, LM_STARTS, LM_MAX_STEPS = 64, 4, 200
#: Population stall test: relative best-MAE change over the last fraction of the iterations.
STALL_RTOL, STALL_FRACTION = 1e-6, 0.1


class KienckeFit(NamedTuple):
    """``params`` (3,) ``[p1, p2, a_s]``; weighted ``mae`` and ``sse`` over the informative samples
    at them; the optimum ``creep_opt = λ_m`` [-] and ``mu_max = μ_m`` [-]; ``iterations`` (LM:
    steps), ``evaluations``; ``n_used`` informative samples; ``status`` (int32 :class:`Status`)."""

    params: jax.Array
    mae: jax.Array
    sse: jax.Array
    creep_opt: jax.Array
    mu_max: jax.Array
    iterations: jax.Array
    evaluations: jax.Array
    n_used: jax.Array
    status: jax.Array


def to_params(z):
    """``[p1, p2, a_s]`` of search coordinates ``z = (log10 a_s, log10 λ_m, μ_m)``."""
    a_s, lam_m, mu_m = 10.0 ** z[..., 0], 10.0 ** z[..., 1], z[..., 2]
    return jnp.stack([a_s / mu_m - 2.0 / lam_m, lam_m**-2.0, a_s], axis=-1)


def to_search(params):
    """Inverse of :func:`to_params` (``p2 > 0``, ``p1 + 2√p2 > 0``)."""
    p1, p2, a_s = params[..., 0], params[..., 1], params[..., 2]
    root = jnp.sqrt(p2)
    return jnp.stack([jnp.log10(a_s), -jnp.log10(root), a_s / (p1 + 2.0 * root)], axis=-1)


def informative(data: PolachDataset):
    """Weights (n,) 1.0/0.0: finite creep and μ̂, ``|v| ≥ MIN_SPEED``, ``|μ̂| ≥ MIN_ADHESION``,
    and not padding (``data.weight``, :func:`.batch_fit.pad_dataset`: one program per length
    bucket)."""
    ok = (
        jnp.isfinite(data.creep)
        & jnp.isfinite(data.adhesion)
        & (jnp.abs(data.vehicle_speed) >= MIN_SPEED)
        & (jnp.abs(data.adhesion) >= MIN_ADHESION)
    )
    ok = ok.astype(data.adhesion.dtype)
    return ok if data.weight is None else ok * data.weight


def kiencke_residual(z, data: PolachDataset):
    """``(μ_Kiencke(λ; z) − μ̂) · weight`` per sample (n,); 0 on non-informative samples."""
    p1, p2, a_s = to_params(z)
    m = informative(data)
    creep = jnp.where(m > 0, data.creep, 0.0)
    mu = jnp.where(m > 0, data.adhesion, 0.0)
    return (kiencke_adhesion(creep, p1, p2, a_s) - mu) * m


def kiencke_mae(z, data: PolachDataset):
    """Mean absolute error over the informative samples."""
    m = informative(data)
    return jnp.sum(jnp.abs(kiencke_residual(z, data))) / jnp.maximum(jnp.sum(m), 1.0)


def _bounds(dtype):
    lo, hi = SEARCH_BOUNDS
    return jnp.asarray(lo, dtype), jnp.asarray(hi, dtype)


@functools.partial(jax.jit, static_argnames=("method", "pop_size", "max_iter"))
def _fit(method, pop_size, max_iter, data, key):
    bounds = _bounds(data.adhesion.dtype)
    if method == "lm":
        out, n_pop = global_lm(
            kiencke_residual,
            bounds,
            key,
            data,
            n_starts=LM_STARTS,
            pop_size=LM_POP,
            search_iter=0,
            max_steps=LM_MAX_STEPS,
        )
        z, iterations, evaluations = out.params, out.steps, n_pop + out.steps
        status = jnp.where(out.success, Status.CONVERGED, Status.MAX_STEPS)
    else:
        out = run(ALGORITHMS[method], kiencke_mae, bounds, key, pop_size, max_iter, args=data)
        z, iterations, evaluations = out.best_x, out.iterations, out.n_evals
        best = out.history.best_f
        back = best[max(0, max_iter - 1 - max(1, int(STALL_FRACTION * max_iter)))]
        stalled = (back - best[-1]) <= STALL_RTOL * jnp.abs(best[-1])
        status = jnp.where(stalled, Status.CONVERGED, Status.MAX_STEPS)
    params = to_params(z)
    r = kiencke_residual(z, data)
    n_used = jnp.sum(informative(data))
    mae = jnp.sum(jnp.abs(r)) / jnp.maximum(n_used, 1.0)
    creep_opt, mu_max = kiencke_optimum(params[0], params[1], params[2])
    finite = jnp.all(jnp.isfinite(params)) & jnp.isfinite(mae)
    status = jnp.where(finite, status, Status.NONFINITE)
    status = jnp.where(n_used < MIN_SAMPLES, Status.NOT_RUN, status).astype(jnp.int32)
    return KienckeFit(
        params,
        mae,
        jnp.sum(r * r),
        creep_opt,
        mu_max,
        iterations,
        evaluations,
        n_used.astype(jnp.int32),
        status,
    )


def fit_kiencke(
    dataset: PolachDataset, method: str = "lm", key=None, *, pop_size: int = 50, max_iter: int = 300
) -> KienckeFit:
    """Fit ``[p1, p2, a_s]`` of Kiencke's model to one dataset (module docstring).

    ``method``: ``"lm"`` (default; deterministic given ``key``), ``"itlbo"``, ``"tlbo"`` or
    ``"pso"`` (``pop_size``, ``max_iter`` apply to these). ``key`` defaults to ``key(0)``.
    Pure and jitted (one program per method, sizes and dataset shape); vmap it over stacked
    datasets and keys.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    key = jax.random.key(0) if key is None else key
    return _fit(method, pop_size, max_iter, dataset, key)


def fit_document(fit: KienckeFit) -> dict:
    """The JSON keys of ``fit --model kiencke`` for one fit: ``model``, ``params`` {p1, p2, a_s},
    ``mae``, ``mu_max``, ``creep_opt``, ``iterations``, ``evaluations``, ``n_used``, ``status``,
    ``converged`` (plain Python values; non-finite numbers become ``None``)."""
    status = Status(int(fit.status))

    def num(v):
        v = float(v)
        return v if math.isfinite(v) else None

    return {
        "model": "kiencke",
        "params": dict(zip(PARAM_NAMES, map(num, fit.params), strict=True)),
        "mae": num(fit.mae),
        "mu_max": num(fit.mu_max),
        "creep_opt": num(fit.creep_opt),
        "iterations": int(fit.iterations),
        "evaluations": int(fit.evaluations),
        "n_used": int(fit.n_used),
        "status": status.label,
        "converged": status.converged,
    }
