"""``curve_fit``: scipy's familiar least-squares entry point, for LM and the population optimisers.

Minimises ``SSE = Σ (f(x, p) − y)²`` over a 1-D parameter vector ``p``. The covariance follows
scipy: with the Jacobian ``J = ∂f/∂p`` at the optimum, ``cov = s² (JᵀJ)⁺``, ``s² = SSE/(n − d)``,
computed by the one covariance routine, :func:`.uncertainty.covariance` (i.i.d. form; a parameter in
an undetermined direction gets an infinite variance, never a finite garbage one).
"""

from __future__ import annotations

import functools
import time
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..status import Status
from .driver import STALL_FTOL, run_until
from .lm import lm_solve, sse_objective
from .methods import NAMES as METHODS
from .methods import POPULATION
from .polach_fit import check_float64
from .uncertainty import covariance as param_covariance


class CurveFitResult(NamedTuple):
    """``params`` (d,), ``covariance`` (d, d), ``sse``, ``mae`` (mean |residual|), ``iterations``
    (LM steps or optimiser iterations), ``evaluations`` (objective/residual evaluations, see
    :mod:`.lm` and the optimisers), ``seconds`` (wall clock of the call, compilation included on a
    first call), ``success`` (converged) and ``status`` (:class:`jadhesion.status.Status` code:
    LM's, or the population run's, see :mod:`.driver`)."""

    params: jax.Array
    covariance: jax.Array
    sse: jax.Array
    mae: jax.Array
    iterations: jax.Array
    evaluations: jax.Array
    seconds: float
    success: jax.Array
    status: jax.Array


def covariance(f, x, y, p):
    """``s² (JᵀJ)⁺`` at ``p`` through :func:`.uncertainty.covariance` (i.i.d. form, as scipy)."""
    jac = jax.jacfwd(lambda q: f(x, q))(p).reshape(-1, p.shape[0])
    return param_covariance(jac, (f(x, p) - y).ravel(), hac=False)[0]


@functools.cache
def _residual(f):
    def residual(p, data):
        x, y = data
        return (f(x, p) - y).ravel()

    return residual


@functools.partial(
    jax.jit, static_argnames=("f", "method", "pop_size", "max_iter", "use_target", "max_steps")
)
def _fit(f, method, pop_size, max_iter, use_target, max_steps, x, y, p0, bounds, key, target, rtol, atol):
    residual = _residual(f)
    if method == "lm":
        out = lm_solve(residual, p0, (x, y), bounds, rtol=rtol, atol=atol, max_steps=max_steps)
        p, iterations, evaluations = out.params, out.steps, out.steps + 1
    else:
        out = run_until(
            POPULATION[method],
            sse_objective(residual),
            bounds,
            key,
            pop_size,
            max_iter,
            target if use_target else None,
            args=(x, y),
            ftol=None if use_target else STALL_FTOL,
        )
        p, iterations, evaluations = out.best_x, out.iterations, out.n_evals
    r = residual(p, (x, y))
    return (
        p,
        covariance(f, x, y, p),
        jnp.sum(r * r),
        jnp.mean(jnp.abs(r)),
        iterations,
        evaluations,
        out.status,
    )


def curve_fit(
    f,
    x,
    y,
    p0,
    *,
    bounds=None,
    method="lm",
    key=None,
    pop_size=50,
    max_iter=500,
    target=None,
    rtol=1e-12,
    atol=1e-12,
    max_steps=2000,
) -> CurveFitResult:
    """Fit ``f(x, params) -> y`` (JAX-traceable, ``params`` 1-D) by least squares.

    Args:
        f, x, y: model, predictor(s), observations (``f(x, p)`` has ``y``'s shape).
        p0: starting point (LM), shape (d,); population methods only use its shape and dtype.
        bounds: ``(lower, upper)`` of shape (d,) each; required by the population methods.
        method: ``"lm"`` (Levenberg–Marquardt, :mod:`.lm`), ``"itlbo"``, ``"tlbo"`` or ``"pso"``.
        key: PRNG key of a population method (default ``jax.random.key(0)``).
        pop_size, max_iter, target: population size, iteration cap, and an optional SSE
            target at which a population method stops early (without one it stops on the stall
            test of :mod:`.driver`).
        rtol, atol, max_steps: LM tolerances (optimistix Cauchy criterion) and step budget.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    check_float64("curve_fit", x, y, p0)
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
    out = _fit(
        f,
        method,
        pop_size,
        max_iter,
        not bool(jnp.isnan(target)),
        max_steps,
        jnp.asarray(x),
        jnp.asarray(y),
        p0,
        bounds,
        key,
        target,
        rtol,
        atol,
    )
    jax.block_until_ready(out)
    return CurveFitResult(*out[:6], time.perf_counter() - start, out[6] == int(Status.CONVERGED), out[6])
