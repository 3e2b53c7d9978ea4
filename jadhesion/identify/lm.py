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

:func:`box_lm` is a separate, small projected LM for box-constrained problems whose optimum sits on
a bound or in a long, weakly identified valley (Polach: ``B = 1`` or ``kS = 1``, the ``A``–``B``
valley). The sine map's derivative vanishes at a bound, so optimistix converges there only
linearly (~250 steps on a 1000-point Polach fit against ~20 for scipy's TRF). :func:`box_lm` works
in ``u = (p − lo)/(hi − lo) ∈ [0, 1]ᵈ``: with ``g = Jᵀr``, ``H = JᵀJ`` and the active set
``𝒜 = {i: u_i = 0, g_i > 0} ∪ {i: u_i = 1, g_i < 0}`` it solves
``(H + λ D) δ = −g`` on the free variables (``δ_𝒜 = 0``; ``D`` the running maximum of ``diag H``,
Marquardt/MINPACK scaling) and projects, ``u' = clip(u + δ, 0, 1)``. The step is accepted when the
gain ratio ``ρ = (C − C')/(−gᵀs − ½ sᵀHs) > 10⁻⁴`` (``s = u' − u``, ``C = ½‖r‖²``); ``λ`` follows
Nielsen's rule. It stops after an accepted step with ``C − C' ≤ ftol·C`` and
``‖s‖∞ ≤ xtol (xtol + ‖u‖∞)``; after any step whose predicted and actual decreases are both at most
``ftol·C`` (MINPACK's test); when the projected gradient ``‖clip(u − g) − u‖∞ ≤ gtol`` (any of these three at a
point where variables sit on a face with vanishing Jacobian columns — a plateau, e.g. ``μ0 = 0`` —
is not a minimum when moving them :data:`PROBE` inwards lowers the cost: the run continues from
there); and a stop whose undamped Gauss–Newton step still promises more than :data:`GN_GAIN`·C
is ``STALLED`` (the damping, not the problem, made the model flat); when
``λ > 10¹⁶`` (no decrease is representable: status ``STALLED``); or at ``max_steps`` (status
``MAX_STEPS``). Only the three tests give ``CONVERGED`` (``success`` true).
:func:`box_lm_queue` runs many such problems as a work queue over a few vmapped lanes, so a batch
costs its total number of steps rather than (batch size × the slowest member's steps).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import optimistix as optx

from ..status import Status
from .driver import run
from .population import evaluate, uniform_population
from .tlbo import ITLBO


class LMResult(NamedTuple):
    """``params`` (d,), ``sse = ‖r‖²``, total ``steps``, ``success`` (converged and finite) and
    ``status`` (int32 :class:`jadhesion.status.Status` code: converged, max_steps, stalled,
    nonfinite)."""

    params: jax.Array
    sse: jax.Array
    steps: jax.Array
    success: jax.Array
    status: jax.Array


def status_code(converged, stalled, finite):
    """The int32 :class:`Status` code of a solver that stopped: ``NONFINITE`` before
    ``CONVERGED`` before ``STALLED`` before ``MAX_STEPS``."""
    return jnp.where(~finite, int(Status.NONFINITE), jnp.where(
        converged, int(Status.CONVERGED),
        jnp.where(stalled, int(Status.STALLED), int(Status.MAX_STEPS)))).astype(jnp.int32)


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
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    sol = optx.least_squares(fn, solver, y0, args, max_steps=max_steps, throw=False)
    return sol.value, sol.stats["num_steps"], _optx_status(sol.result)


def _optx_status(result):
    """optimistix's result as a :class:`Status` code (finiteness is checked by the caller)."""
    return jnp.where(result == optx.RESULTS.successful, int(Status.CONVERGED), jnp.where(
        result == optx.RESULTS.max_steps_reached, int(Status.MAX_STEPS),
        jnp.where(result == optx.RESULTS.nonfinite, int(Status.NONFINITE),
                  int(Status.STALLED)))).astype(jnp.int32)


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
    return LMResult(p, jnp.where(jnp.isfinite(sse), sse, jnp.inf), steps,
                    code == int(Status.CONVERGED), code)


def best_of(results: LMResult) -> LMResult:
    """The lowest-SSE converged member of a batch of :class:`LMResult` (leading axis), or the
    lowest-SSE member when none converged; steps are summed."""
    sse = jnp.where(jnp.isnan(results.sse), jnp.inf, results.sse)
    i = jnp.argmin(jnp.where(jnp.any(results.success) & ~results.success, jnp.inf, sse))
    pick = jax.tree_util.tree_map(lambda a: a[i], results)
    return pick._replace(steps=jnp.sum(results.steps))


def multistart(residual, starts, args=None, bounds=None, **options):
    """LM from each row of ``starts`` (k, d), vmapped; the best result (steps summed)."""
    solve = lambda p: lm_solve(residual, p, args, bounds, **options)  # noqa: E731
    return best_of(jax.vmap(solve)(starts))


#: Inward probe (box-scaled) of variables on a face with a vanishing Jacobian column.
PROBE = 0.01
#: A stop counts as converged only if the undamped Gauss–Newton step would lower the cost by less
#: than this share (a 1-σ parameter change moves the cost by ~1/n of it: far above this).
GN_GAIN = 1e-8


class BoxLMOptions(NamedTuple):
    """Coefficients of :func:`box_lm` (data, so a study may vmap over them)."""

    ftol: float = 1e-10
    xtol: float = 1e-8
    gtol: float = 1e-12


class _BoxState(NamedTuple):
    """Iterate ``u`` (box-scaled); at ``u``: cost ``½‖r‖²``, gradient ``g = Jᵀr``, Gauss–Newton
    matrix ``H = JᵀJ`` and ``max |r|``; running ``max diag H``, damping ``λ`` and its growth factor
    ``ν``, steps, done (converged or stalled), and ``fresh`` (not yet linearised: the first
    iteration only evaluates at ``u``). Only these reductions are carried, never ``r`` or ``J``, so
    a step's Jacobian is reduced where it is made and a lane's state is a few dozen numbers."""

    u: jax.Array
    cost: jax.Array
    g: jax.Array
    h: jax.Array
    rmax: jax.Array
    dmax: jax.Array
    lam: jax.Array
    nu: jax.Array
    steps: jax.Array
    done: jax.Array
    converged: jax.Array
    fresh: jax.Array


def _box_lm_stepper(residual, bounds, options):
    """``(init, step)`` of the projected LM: ``init(p0)`` is a fresh state (no evaluation, so
    restarting a lane is free), ``step(state, args)`` one iteration (one residual and Jacobian)."""
    res = safe_residual(residual)
    lo, hi = bounds
    width = hi - lo
    d = lo.shape[0]

    def linearise(u, args):
        """``½‖r‖²``, ``Jᵀr``, ``JᵀJ`` and ``max |r|`` at ``u``."""
        def f(v):
            r = res(lo + width * v, args)
            return r, r
        jac, r = jax.jacfwd(f, has_aux=True)(u)
        return 0.5 * jnp.sum(r * r), jac.T @ r, jac.T @ jac, jnp.max(jnp.abs(r))

    def init(p0):
        dtype = p0.dtype
        scalar = lambda v: jnp.asarray(v, dtype)  # noqa: E731
        return _BoxState(jnp.clip((p0 - lo) / width, 0.0, 1.0), scalar(jnp.inf), jnp.zeros(d, dtype),
                         jnp.zeros((d, d), dtype), scalar(0.0), jnp.zeros(d, dtype), scalar(1e-3),
                         scalar(2.0), jnp.asarray(0), jnp.asarray(False), jnp.asarray(False),
                         jnp.asarray(True))

    def step(st, args):
        u, g, h, c, fresh = st.u, st.g, st.h, st.cost, st.fresh
        active = ((u <= 0.0) & (g > 0.0)) | ((u >= 1.0) & (g < 0.0))
        free = (~active).astype(u.dtype)
        dmax = jnp.maximum(st.dmax, jnp.diag(h))
        damp = jnp.maximum(dmax, 1e-12 * jnp.max(dmax) + jnp.finfo(u.dtype).tiny)
        a = h * free[:, None] * free[None, :] + jnp.diag(jnp.where(active, 1.0, st.lam * damp))
        u_new = jnp.where(fresh, u, jnp.clip(u + jnp.linalg.solve(a, -g * free), 0.0, 1.0))
        s = u_new - u
        c_new, g_new, h_new, rmax_new = linearise(u_new, args)
        predicted = -(g @ s) - 0.5 * (s @ (h @ s))
        rho = (c - c_new) / jnp.where(predicted > 0, predicted, jnp.inf)
        accept = fresh | ((rho > 1e-4) & jnp.isfinite(c_new))
        small = ((c - c_new <= options.ftol * c)
                 & (jnp.max(jnp.abs(s)) <= options.xtol * (options.xtol + jnp.max(jnp.abs(u)))))
        pick = lambda new, old: jnp.where(accept, new, old)  # noqa: E731
        u, g, h, c, rmax = (pick(u_new, u), pick(g_new, g), pick(h_new, h), pick(c_new, c),
                            pick(rmax_new, st.rmax))
        stationary = jnp.max(jnp.abs(jnp.clip(u - g, 0.0, 1.0) - u)) <= options.gtol
        lam = jnp.where(fresh, st.lam, jnp.where(
            accept, st.lam * jnp.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3), st.lam * st.nu))
        nu = jnp.where(accept, 2.0, 2.0 * st.nu)
        # MINPACK's ftol test: neither the model nor the trial can lower the cost by more than
        # ftol·C, so the iterate is a minimum to that precision even if the trial was rejected
        # (without it, a converged run spends ~10 steps raising λ until it overflows the test).
        flat = (predicted <= options.ftol * c) & (jnp.abs(c - c_new) <= options.ftol * c)
        stopped = (~fresh & ((accept & small) | flat)) | stationary
        # Variables on a face of the box whose Jacobian columns vanish (μ0 = 0 switches the whole
        # curve off; A = 1 with B = 0 makes both invisible) pass every test on a plateau. Probe:
        # move them jointly PROBE inwards; if that lowers the cost the point is no minimum, and
        # the run continues from the probe (a descent step the linear model cannot see).
        flat_face = (((u <= 0.0) | (u >= 1.0))
                     & (jnp.diag(h) <= jnp.finfo(u.dtype).eps * jnp.max(jnp.diag(h))))
        u_probe = jnp.where(flat_face, jnp.abs(u - PROBE), u)
        c_p, g_p, h_p, rmax_p = jax.lax.cond(stopped & jnp.any(flat_face),
                                             lambda: linearise(u_probe, args),
                                             lambda: (c, g, h, rmax))
        escape = stopped & (c_p < c)
        pick = lambda new, old: jnp.where(escape, new, old)  # noqa: E731
        u, g, h, c, rmax = (pick(u_probe, u), pick(g_p, g), pick(h_p, h), pick(c_p, c),
                            pick(rmax_p, rmax))
        stopped = stopped & ~escape
        # A test may pass only because heavy damping (λ·D, D a running maximum of diag H) made
        # the model flat: it is a minimum only if even the undamped Gauss–Newton step promises
        # less than GN_GAIN·C; otherwise the run stopped stalled.
        free_g = (~(((u <= 0.0) & (g > 0.0)) | ((u >= 1.0) & (g < 0.0)))).astype(u.dtype)
        a_gn = h * free_g[:, None] * free_g[None, :] + jnp.diag(
            jnp.where(free_g > 0, 1e-12 * jnp.max(jnp.diag(h)) + jnp.finfo(u.dtype).tiny, 1.0))
        gn_gain = 0.5 * (g * free_g) @ jnp.linalg.solve(a_gn, g * free_g)
        converged = stopped & (stationary | (gn_gain <= GN_GAIN * c))
        done = stopped | (lam > 1e16)
        steps = st.steps + jnp.where(fresh, 0, 1)
        return _BoxState(u, c, g, h, rmax, dmax, lam, nu, steps, done, converged,
                         jnp.asarray(False))

    def result(st):
        p = lo + width * st.u
        finite = (st.rmax < jnp.finfo(st.rmax.dtype).max ** 0.25) & jnp.isfinite(st.cost)
        code = status_code(st.converged, st.done & ~st.converged,
                           finite & jnp.all(jnp.isfinite(p)))
        return LMResult(p, jnp.where(finite, 2.0 * st.cost, jnp.inf), st.steps,
                        code == int(Status.CONVERGED), code)

    return init, step, result


def _prepare(p0, bounds, options):
    p0 = jnp.asarray(p0)
    bounds = tuple(jnp.asarray(b, p0.dtype) for b in bounds)
    return p0, bounds, BoxLMOptions(*(jnp.asarray(o, p0.dtype) for o in options))


@functools.partial(jax.jit, static_argnames=("residual", "max_steps"))
def box_lm(residual, p0, args, bounds, options=BoxLMOptions(), *, max_steps=100):
    """Projected LM on the box ``bounds = (lo, hi)`` from ``p0`` (see the module docstring).
    ``steps`` counts iterations; each costs one residual and one forward Jacobian."""
    p0, bounds, options = _prepare(p0, bounds, options)
    init, step, result = _box_lm_stepper(residual, bounds, options)
    final = jax.lax.while_loop(lambda st: ~st.done & (st.steps < max_steps),
                               lambda st: step(st, args), init(p0))
    return result(final)


@functools.partial(jax.jit, static_argnames=("residual", "max_steps", "lanes"))
def box_lm_queue(residual, starts, args, bounds, options=BoxLMOptions(), *, max_steps=100,
                 lanes=8):
    """:func:`box_lm` on many problems — row ``i`` of ``starts`` (N, d) with the ``i``-th slice of
    the stacked pytree ``args`` — as a work queue: ``lanes`` problems iterate side by side (one
    vmapped step) and a lane that converges takes the next waiting problem at once. A plain
    ``vmap`` of :func:`box_lm` runs every member for as many steps as the slowest; the queue's
    cost follows the *total* steps instead. Returns a stacked :class:`LMResult` in input order."""
    starts, bounds, options = _prepare(starts, bounds, options)
    n_problems = starts.shape[0]
    lanes = min(lanes, n_problems)
    take = lambda i: jax.tree.map(lambda a: a[i], args)  # noqa: E731
    init, step, result = _box_lm_stepper(residual, bounds, options)
    finished = lambda st: st.done | (st.steps >= max_steps)  # noqa: E731
    out0 = jax.vmap(lambda p: result(init(p)))(starts)

    def body(carry):
        states, index, next_index, out = carry
        live = index < n_problems
        lane_args = take(jnp.minimum(index, n_problems - 1))
        stepped = jax.vmap(step)(states, lane_args)
        states = jax.tree.map(lambda new, old: jnp.where(
            live.reshape((-1,) + (1,) * (new.ndim - 1)), new, old), stepped, states)
        ending = live & jax.vmap(finished)(states)
        out = jax.tree.map(lambda o, v: o.at[jnp.where(ending, index, n_problems)].set(v, mode="drop"),
                           out, jax.vmap(result)(states))
        new_index = next_index + jnp.cumsum(ending) - 1
        index = jnp.where(ending, jnp.where(new_index < n_problems, new_index, n_problems), index)
        fresh = jax.vmap(init)(starts[jnp.minimum(index, n_problems - 1)])
        states = jax.tree.map(lambda f, s: jnp.where(
            ending.reshape((-1,) + (1,) * (f.ndim - 1)), f, s), fresh, states)
        return states, index, next_index + jnp.sum(ending), out

    first = jnp.arange(lanes)
    carry = (jax.vmap(init)(starts[first]), first, jnp.asarray(lanes), out0)
    _, _, _, out = jax.lax.while_loop(lambda c: jnp.any(c[1] < n_problems), body, carry)
    return out


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


def global_lm(residual, bounds, key, args=None, *, n_starts=4, pop_size=20, search_iter=5,
              search_args=None, max_steps=100, options=BoxLMOptions()):
    """"Global LM": :func:`seed_starts` (a search on ``‖r‖²``) seeds ``n_starts`` :func:`box_lm`
    runs from its best members; the lowest-SSE answer is returned.

    With ``search_args`` (e.g. a subsample of the data) the search *and* the multi-start LM use
    it, and only the best of them is polished by one :func:`box_lm` on ``args``: the expensive
    full-data Jacobians are then paid once, not ``n_starts`` times. Returns ``(LMResult,
    population evaluations)``; ``steps`` sums every LM run's steps."""
    sub = args if search_args is None else search_args
    starts, n_evals = seed_starts(residual, bounds, key, sub, n_starts=n_starts,
                                  pop_size=pop_size, search_iter=search_iter)
    solve = lambda p, a: box_lm(residual, p, a, bounds, options, max_steps=max_steps)  # noqa: E731
    out = best_of(jax.vmap(solve, in_axes=(0, None))(starts, sub))
    if search_args is not None:
        polish = solve(out.params, args)
        out = polish._replace(steps=polish.steps + out.steps)
    return out, n_evals


@functools.cache
def sse_objective(residual):
    """``p, args -> ‖residual(p, args)‖²`` (cached per residual, so jit caches stay warm)."""
    def sse(p, args):
        r = residual(p, args)
        return jnp.sum(r * r)
    return sse
