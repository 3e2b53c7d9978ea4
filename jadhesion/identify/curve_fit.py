"""``curve_fit``: scipy's familiar least-squares entry point, for LM and the population optimisers.

Minimises ``SSE = Σ (f(x, p) − y)²`` over a 1-D parameter vector ``p``. The covariance follows
scipy: with the Jacobian ``J = ∂f/∂p`` at the optimum, ``cov = s² (JᵀJ)⁺``, ``s² = SSE/(n − d)``,
the pseudo-inverse taken through the SVD of ``J`` with singular values below
``eps · max(n, d) · σ_max`` dropped (a singular direction gets no variance instead of an inf/NaN);
``s² = inf`` when ``n ≤ d``.
"""

from __future__ import annotations

import functools
import time
from typing import NamedTuple

import jax
import jax.numpy as jnp

from .driver import run, run_until
from .lm import lm_solve, sse_objective
from .pso import PSO
from .tlbo import ITLBO, TLBO

POPULATION = {"itlbo": ITLBO, "tlbo": TLBO, "pso": PSO}
METHODS = ("lm", *POPULATION)


class CurveFitResult(NamedTuple):
    """``params`` (d,), ``covariance`` (d, d), ``sse``, ``mae`` (mean |residual|), ``iterations``
    (LM steps or optimiser iterations), ``evaluations`` (objective/residual evaluations, see
    :mod:`.lm` and the optimisers), ``seconds`` (wall clock of the call, compilation included on a
    first call), ``success``."""

    params: jax.Array
    covariance: jax.Array
    sse: jax.Array
    mae: jax.Array
    iterations: jax.Array
    evaluations: jax.Array
    seconds: float
    success: jax.Array


def covariance(f, x, y, p):
    """``s² (JᵀJ)⁺`` at ``p`` (see the module docstring)."""
    jac = jax.jacfwd(lambda q: f(x, q))(p).reshape(-1, p.shape[0])
    r = f(x, p) - y
    n, d = jac.shape
    _, sv, vt = jnp.linalg.svd(jac, full_matrices=False)
    keep = sv > jnp.finfo(sv.dtype).eps * max(n, d) * sv[0]
    inv2 = jnp.where(keep, 1.0 / jnp.where(keep, sv, 1.0) ** 2, 0.0)
    s2 = jnp.sum(r * r) / (n - d) if n > d else jnp.inf
    return s2 * (vt.T * inv2[None]) @ vt


@functools.cache
def _residual(f):
    def residual(p, data):
        x, y = data
        return (f(x, p) - y).ravel()
    return residual


@functools.partial(jax.jit, static_argnames=("f", "method", "pop_size", "max_iter", "use_target",
                                             "max_steps"))
def _fit(f, method, pop_size, max_iter, use_target, max_steps, x, y, p0, bounds, key, target,
         rtol, atol):
    residual = _residual(f)
    if method == "lm":
        out = lm_solve(residual, p0, (x, y), bounds, rtol=rtol, atol=atol, max_steps=max_steps)
        p, iterations, evaluations, ok = out.params, out.steps, out.steps + 1, out.success
    else:
        driver = run_until if use_target else run
        out = driver(POPULATION[method], sse_objective(residual), bounds, key, pop_size, max_iter,
                     target, args=(x, y))
        p, iterations, evaluations = out.best_x, out.iterations, out.n_evals
        ok = jnp.isfinite(out.best_f) & ((out.hit_iteration >= 0) if use_target else True)
    r = residual(p, (x, y))
    return (p, covariance(f, x, y, p), jnp.sum(r * r), jnp.mean(jnp.abs(r)), iterations,
            evaluations, ok)


def curve_fit(f, x, y, p0, *, bounds=None, method="lm", key=None, pop_size=50, max_iter=500,
              target=None, rtol=1e-12, atol=1e-12, max_steps=2000) -> CurveFitResult:
    """Fit ``f(x, params) -> y`` (JAX-traceable, ``params`` 1-D) by least squares.

    Args:
        f, x, y: model, predictor(s), observations (``f(x, p)`` has ``y``'s shape).
        p0: starting point (LM), shape (d,); population methods only use its shape and dtype.
        bounds: ``(lower, upper)`` of shape (d,) each; required by the population methods.
        method: ``"lm"`` (Levenberg–Marquardt, :mod:`.lm`), ``"itlbo"``, ``"tlbo"`` or ``"pso"``.
        key: PRNG key of a population method (default ``jax.random.key(0)``).
        pop_size, max_iter, target: population size, iteration budget, and an optional SSE
            target at which a population method stops early.
        rtol, atol, max_steps: LM tolerances (optimistix Cauchy criterion) and step budget.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    p0 = jnp.asarray(p0)
    if p0.ndim != 1:
        raise ValueError(f"p0 must be a 1-D parameter vector, got shape {p0.shape}")
    if bounds is None and method != "lm":
        raise ValueError(f"method {method!r} searches a box: pass bounds=(lower, upper)")
    if bounds is not None:
        bounds = tuple(jnp.broadcast_to(jnp.asarray(b, p0.dtype), p0.shape) for b in bounds)
        if not bool(jnp.all(bounds[0] < bounds[1])):
            raise ValueError("bounds must satisfy lower < upper in every component")
    key = jax.random.key(0) if key is None else key
    target = jnp.asarray(jnp.nan if target is None else target, p0.dtype)
    start = time.perf_counter()
    out = _fit(f, method, pop_size, max_iter, not bool(jnp.isnan(target)), max_steps,
               jnp.asarray(x), jnp.asarray(y), p0, bounds, key, target, rtol, atol)
    jax.block_until_ready(out)
    return CurveFitResult(*out[:6], time.perf_counter() - start, out[6])
