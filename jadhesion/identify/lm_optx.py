"""Levenberg–Marquardt through optimistix: bounded, rescaled, NaN-safe, multi-start and global.

``residual(p, args) -> r`` (a 1-D vector); LM minimises ``½‖r‖²``, each step solving the damped
system ``(JᵀJ + λI) δ = −Jᵀr`` (optimistix's trust-region form).

* **Scaling.** Unbounded problems are solved twice from ``p0``: as given, and in ``u = p / scale``
  with ``scale = |p0|`` (1 where ``p0 = 0``); the lower-SSE answer is polished by a third solve
  rescaled at itself. Rescaling makes optimistix's identity damping act like Marquardt's
  per-parameter damping; keeping the plain solve guards starts where scaling misleads (MGH17).
* **Bounds** by the sine map (MINUIT, lmfit): ``p = lo + (hi − lo)(1 + sin z)/2``, ``z ∈ ℝ``. It
  reaches the bounds at finite ``z`` (a parameter on its bound, such as ``kS = 1``, costs nothing).
* **NaN safety.** Non-finite residual components are replaced by a huge finite value
  (``finfo.max^¼``) with zero derivative, so LM rejects the step and shrinks its trust region.
* **Evaluations** are reported as optimistix's accepted+rejected steps plus one: each costs one
  residual and one forward-mode Jacobian (``d`` JVPs).

optimistix (with equinox and lineax: a third of a second) is imported by the functions that solve,
on purpose, not at the top: the Polach fits run the projected LM of :mod:`.box_lm`, and a
``jadhesion fit`` process must not pay for a library it does not call (issue #16 item 4).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from ..status import Status
from .lm_result import LMResult, best_of


def safe_residual(residual):
    """``residual`` with non-finite components replaced by ``finfo.max^¼`` (zero derivative)."""

    def fn(p, args):
        r = residual(p, args)
        big = jnp.finfo(r.dtype).max ** 0.25
        return jnp.where(jnp.isfinite(r), r, big)

    return fn


def to_box(z, bounds):
    """Sine map ``ℝ → [lo, hi]``."""
    lo, hi = bounds
    return lo + (hi - lo) * 0.5 * (1.0 + jnp.sin(z))


def from_box(p, bounds):
    """Inverse of :func:`to_box` on ``[lo, hi]`` (``p`` clipped into the box first)."""
    lo, hi = bounds
    t = jnp.clip(2.0 * (p - lo) / (hi - lo) - 1.0, -1.0, 1.0)
    return jnp.arcsin(t)


def _solve(fn, y0, args, rtol, atol, max_steps):
    import optimistix as optx  # on purpose here: see the module docstring

    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    sol = optx.least_squares(fn, solver, y0, args, max_steps=max_steps, throw=False)
    return sol.value, sol.stats["num_steps"], _optx_status(sol.result)


def _optx_status(result):
    """optimistix's result as a :class:`Status` code (finiteness is checked by the caller)."""
    import optimistix as optx  # on purpose here: see the module docstring

    return jnp.where(
        result == optx.RESULTS.successful,
        int(Status.CONVERGED),
        jnp.where(
            result == optx.RESULTS.max_steps_reached,
            int(Status.MAX_STEPS),
            jnp.where(result == optx.RESULTS.nonfinite, int(Status.NONFINITE), int(Status.STALLED)),
        ),
    ).astype(jnp.int32)


def _solve_unbounded(res, p0, args, rtol, atol, max_steps):
    """Three passes of one (traced-once) solve in ``u = p / scale``: ``scale = 1`` and
    ``scale = |p0|`` from ``p0``, then a polish rescaled at the best so far; the lowest SSE wins."""

    def sse(p):
        r = res(p, args)
        return jnp.sum(r * r)

    def scaled(u, a):
        (a, scale) = a
        return res(u * scale, a)

    def body(carry, i):
        best, best_sse, steps = carry
        start = jnp.where(i < 2, p0, best)
        magnitude = jnp.where(start == 0, 1.0, jnp.abs(start))
        scale = jnp.where(i == 0, jnp.ones_like(p0), magnitude)
        u, n, ok = _solve(scaled, start / scale, (args, scale), rtol, atol, max_steps)
        p = u * scale
        f = sse(p)
        better = f <= best_sse
        return (jnp.where(better, p, best), jnp.where(better, f, best_sse), steps + n), ok

    init = (p0, jnp.asarray(jnp.inf, p0.dtype), jnp.asarray(0))
    (p, _, steps), ok = jax.lax.scan(body, init, jnp.arange(3))
    return p, steps, ok[-1]


@functools.partial(jax.jit, static_argnames=("residual", "max_steps"))
def lm_solve(residual, p0, args=None, bounds=None, *, rtol=1e-12, atol=1e-12, max_steps=2000):
    """Least squares from ``p0``; ``bounds=(lo, hi)`` (arrays of shape (d,)) or ``None``."""
    res = safe_residual(residual)
    p0 = jnp.asarray(p0)
    if bounds is not None:
        bounds = tuple(jnp.asarray(b, p0.dtype) for b in bounds)
        fn = lambda z, a: res(to_box(z, bounds), a)  # noqa: E731
        z, steps, ok = _solve(fn, from_box(p0, bounds), args, rtol, atol, max_steps)
        p = to_box(z, bounds)
    else:
        p, steps, ok = _solve_unbounded(res, p0, args, rtol, atol, max_steps)
    r = residual(p, args)
    sse = jnp.sum(r * r)
    finite = jnp.isfinite(sse) & jnp.all(jnp.isfinite(p))
    code = jnp.where(finite, ok, int(Status.NONFINITE)).astype(jnp.int32)
    return LMResult(p, jnp.where(jnp.isfinite(sse), sse, jnp.inf), steps, code == int(Status.CONVERGED), code)


def multistart(residual, starts, args=None, bounds=None, **options):
    """LM from each row of ``starts`` (k, d), vmapped; the best result (steps summed)."""
    solve = lambda p: lm_solve(residual, p, args, bounds, **options)  # noqa: E731
    return best_of(jax.vmap(solve)(starts))
