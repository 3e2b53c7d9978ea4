"""Projected Levenberg–Marquardt on a box.

:func:`box_lm` is the bounded LM of every Polach least-squares problem (fits, the Laplace start of
the posterior, Table 2's observer polish): a small projected LM for box problems whose optimum sits on
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
``ftol·C`` (MINPACK's test); when the projected gradient ``‖clip(u − g) − u‖∞ ≤ gtol`` (any of
these three at a point where variables sit on a face with vanishing Jacobian columns — a plateau,
e.g. ``μ0 = 0`` — is not a minimum when moving them :data:`PROBE` inwards lowers the cost: the run
continues from there; the probe is evaluated by the next iteration, in place of a trial, and
counts no step); and a stop where the undamped Gauss–Newton step or the Cauchy step, clipped to
the box (:func:`feasible_gain`), still promises the gain of a move longer than :data:`GN_STEP`
standard errors is ``STALLED`` (the damping, not the problem, made the model flat; unprojected, a
step past a bound the optimum sits near promised a gain no feasible point has, and converged fits
were called stalled); when
``λ > 10¹⁶`` (no decrease is representable: status ``STALLED``); or at ``max_steps`` (status
``MAX_STEPS``). Only the three tests give ``CONVERGED`` (``success`` true).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..status import Status
from .lm_optx import safe_residual
from .lm_result import LMResult, status_code
from .small_linalg import solve

#: Inward probe (box-scaled) of variables on a face with a vanishing Jacobian column.
PROBE = 0.01
#: A stop counts as converged only if the undamped Gauss–Newton step ``s`` is shorter than this
#: many standard errors (Mahalanobis, ``sᵀHs/σ̂²`` with ``σ̂² = 2C/(n − d)``): its promised gain
#: ``½sᵀHs`` is then at most ``GN_STEP²·C/(n − d)``. What is left of the step is then far inside
#: the parameters' own uncertainty; a fixed share of the cost (10⁻⁸ before) called fits stalled
#: whose remaining step was a few thousandths of a standard error (a rail change's refit, 34 steps).
GN_STEP = 0.1


def feasible_gain(u, g, h):
    """Decrease ``−gᵀs − ½ sᵀHs`` of the quadratic model promised by the better of two steps into
    the box on the free variables: the undamped Gauss–Newton step clipped to the box,
    ``clip(u − H_free⁻¹ g, 0, 1) − u``, and the Cauchy step (the model's minimum along the free
    gradient, clipped the same way). Both are feasible, so neither promises a gain no point of the
    box has; the Cauchy step because clipping can turn the Gauss–Newton step of an ill-conditioned
    valley uphill (a negative promise: a stop 4.6 standard errors from the optimum was called
    converged)."""
    free = (~(((u <= 0.0) & (g > 0.0)) | ((u >= 1.0) & (g < 0.0)))).astype(u.dtype)
    a = h * free[:, None] * free[None, :] + jnp.diag(
        jnp.where(free > 0, 1e-12 * jnp.max(jnp.diag(h)) + jnp.finfo(u.dtype).tiny, 1.0)
    )
    gf = g * free
    t = (gf @ gf) / jnp.maximum(gf @ (h @ gf), jnp.finfo(u.dtype).tiny)

    def model(step):
        s = jnp.clip(u + step, 0.0, 1.0) - u
        return -(g @ s) - 0.5 * (s @ (h @ s))

    return jnp.maximum(model(-solve(a, gf)), model(-t * gf))


class BoxLMOptions(NamedTuple):
    """Coefficients of :func:`box_lm` (data, so a study may vmap over them)."""

    ftol: float = 1e-10
    xtol: float = 1e-8
    gtol: float = 1e-12


#: The default coefficients (one shared value, so a default argument builds nothing).
DEFAULT_OPTIONS = BoxLMOptions()


class _BoxState(NamedTuple):
    """Iterate ``u`` (box-scaled); at ``u``: cost ``½‖r‖²``, gradient ``g = Jᵀr``, Gauss–Newton
    matrix ``H = JᵀJ`` and ``max |r|``; running ``max diag H``, damping ``λ`` and its growth factor
    ``ν``, steps, done (converged or stalled), ``fresh`` (not yet linearised: the first iteration
    only evaluates at ``u``) and ``probe`` (a stop on a flat face: the next iteration evaluates the
    inward probe instead of an LM trial, and counts no step). Only these reductions are carried,
    never ``r`` or ``J``, so a step's Jacobian is reduced where it is made and a lane's state is a
    few dozen numbers."""

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
    probe: jax.Array


def _reductions(res, lo, width, u, args):
    """``½‖r‖²``, ``Jᵀr``, ``JᵀJ`` and ``max |r|`` at ``u`` (one residual and forward Jacobian)."""

    def f(v):
        r = res(lo + width * v, args)
        return r, r

    jac, r = jax.jacfwd(f, has_aux=True)(u)
    return 0.5 * jnp.sum(r * r), jac.T @ r, jac.T @ jac, jnp.max(jnp.abs(r))


def _blocked_reductions(res, lo, width, u, args, n, block):
    """:func:`_reductions` of a row-wise residual of ``n`` rows, summed over blocks of ``block``
    rows (``lax.scan``, then the remainder): memory ``O(block)`` instead of ``O(n)`` for the
    Jacobian and its intermediates. ``args`` leaves of shape ``(n, …)`` are split by rows, the
    others passed whole to every block."""
    leaves, tree = jax.tree.flatten(args)
    is_row = [jnp.shape(x)[:1] == (n,) for x in leaves]
    full = (n // block) * block

    def add(acc, rows):
        it = iter(rows)
        part = jax.tree.unflatten(
            tree, [next(it) if row else x for x, row in zip(leaves, is_row, strict=True)]
        )
        c, g, h, m = _reductions(res, lo, width, u, part)
        return (acc[0] + c, acc[1] + g, acc[2] + h, jnp.maximum(acc[3], m)), None

    row_leaves = [x for x, row in zip(leaves, is_row, strict=True) if row]
    d, dtype = u.shape[0], u.dtype
    zero = (jnp.zeros((), dtype), jnp.zeros(d, dtype), jnp.zeros((d, d), dtype), jnp.zeros((), dtype))
    blocks = [x[:full].reshape((n // block, block) + x.shape[1:]) for x in row_leaves]
    acc, _ = jax.lax.scan(add, zero, blocks)
    if full < n:
        acc, _ = add(acc, [x[full:] for x in row_leaves])
    return acc


def _box_lm_stepper(residual, bounds, options, block_rows=None):
    """``(init, step)`` of the projected LM: ``init(p0)`` is a fresh state (no evaluation, so
    restarting a lane is free), ``step(state, args)`` one iteration (one residual and Jacobian;
    with ``block_rows``, see :func:`box_lm`, reduced block by block)."""
    res = safe_residual(residual)
    lo, hi = bounds
    width = hi - lo
    d = lo.shape[0]

    def rows(args):
        """Length of the residual (static)."""
        return jax.eval_shape(res, lo, args).shape[0]

    def linearise(u, args):
        """``½‖r‖²``, ``Jᵀr``, ``JᵀJ`` and ``max |r|`` at ``u``."""
        n = rows(args)
        if block_rows is None or n <= block_rows:
            return _reductions(res, lo, width, u, args)
        return _blocked_reductions(res, lo, width, u, args, n, block_rows)

    def init(p0):
        dtype = p0.dtype
        scalar = lambda v: jnp.asarray(v, dtype)  # noqa: E731
        return _BoxState(
            jnp.clip((p0 - lo) / width, 0.0, 1.0),
            scalar(jnp.inf),
            jnp.zeros(d, dtype),
            jnp.zeros((d, d), dtype),
            scalar(0.0),
            jnp.zeros(d, dtype),
            scalar(1e-3),
            scalar(2.0),
            jnp.asarray(0),
            jnp.asarray(False),
            jnp.asarray(False),
            jnp.asarray(True),
            jnp.asarray(False),
        )

    def flat_face(u, h):
        """Variables on a face of the box whose Jacobian columns vanish (μ0 = 0 switches the whole
        curve off; A = 1 with B = 0 makes both invisible): every test passes on such a plateau."""
        return ((u <= 0.0) | (u >= 1.0)) & (jnp.diag(h) <= jnp.finfo(u.dtype).eps * jnp.max(jnp.diag(h)))

    def step(st, args):
        """One iteration: an LM trial, or (``st.probe``) the flat-face probe. Either way one
        linearisation: a ``lax.cond`` for the probe would run both branches under ``vmap`` (the
        work queue), doubling a batched step's cost."""
        u, g, h, c, fresh, probing = st.u, st.g, st.h, st.cost, st.fresh, st.probe
        active = ((u <= 0.0) & (g > 0.0)) | ((u >= 1.0) & (g < 0.0))
        free = (~active).astype(u.dtype)
        dmax = jnp.where(probing, st.dmax, jnp.maximum(st.dmax, jnp.diag(h)))
        damp = jnp.maximum(dmax, 1e-12 * jnp.max(dmax) + jnp.finfo(u.dtype).tiny)
        a = h * free[:, None] * free[None, :] + jnp.diag(jnp.where(active, 1.0, st.lam * damp))
        u_new = jnp.where(fresh, u, jnp.clip(u + solve(a, -g * free), 0.0, 1.0))
        # Move the flat-face variables jointly PROBE inwards; if that lowers the cost the point is
        # no minimum, and the run continues from the probe (a descent step the linear model cannot
        # see). Requested by a stop below, evaluated by the next iteration in place of a trial.
        u_probe = jnp.where(flat_face(u, h), jnp.abs(u - PROBE), u)
        c_new, g_new, h_new, rmax_new = linearise(jnp.where(probing, u_probe, u_new), args)
        s = u_new - u
        predicted = -(g @ s) - 0.5 * (s @ (h @ s))
        rho = (c - c_new) / jnp.where(predicted > 0, predicted, jnp.inf)
        accept = ~probing & (fresh | ((rho > 1e-4) & jnp.isfinite(c_new)))
        small = (c - c_new <= options.ftol * c) & (
            jnp.max(jnp.abs(s)) <= options.xtol * (options.xtol + jnp.max(jnp.abs(u)))
        )
        escape = probing & (c_new < c)
        take = accept | escape
        pick = lambda new, old: jnp.where(take, new, old)  # noqa: E731
        u, g, h, c, rmax = (
            pick(jnp.where(probing, u_probe, u_new), u),
            pick(g_new, g),
            pick(h_new, h),
            pick(c_new, c),
            pick(rmax_new, st.rmax),
        )
        stationary = jnp.max(jnp.abs(jnp.clip(u - g, 0.0, 1.0) - u)) <= options.gtol
        lam = jnp.where(
            fresh | probing,
            st.lam,
            jnp.where(accept, st.lam * jnp.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3), st.lam * st.nu),
        )
        nu = jnp.where(probing, st.nu, jnp.where(accept, 2.0, 2.0 * st.nu))
        # MINPACK's ftol test: neither the model nor the trial can lower the cost by more than
        # ftol·C, so the iterate is a minimum to that precision even if the trial was rejected
        # (without it, a converged run spends ~10 steps raising λ until it overflows the test).
        flat = (predicted <= options.ftol * c) & (jnp.abs(c - c_new) <= options.ftol * c)
        stopped = (~fresh & ((accept & small) | flat)) | stationary
        probe_next = ~probing & stopped & jnp.any(flat_face(u, h))
        stopped = jnp.where(probing, ~escape, stopped & ~probe_next)
        # A test may pass only because heavy damping (λ·D, D a running maximum of diag H) made
        # the model flat: it is a minimum only if even the undamped Gauss–Newton step, clipped to
        # the box, is shorter than GN_STEP standard errors (nor the Cauchy step's promise larger);
        # otherwise the run stopped stalled.
        gain = feasible_gain(u, g, h)
        converged = stopped & (stationary | (gain <= GN_STEP**2 * c / max(rows(args) - d, 1)))
        done = stopped | ((lam > 1e16) & ~probe_next)
        steps = st.steps + jnp.where(fresh | probing, 0, 1)
        return _BoxState(
            u, c, g, h, rmax, dmax, lam, nu, steps, done, converged, jnp.asarray(False), probe_next
        )

    def result(st):
        p = lo + width * st.u
        finite = (st.rmax < jnp.finfo(st.rmax.dtype).max ** 0.25) & jnp.isfinite(st.cost)
        code = status_code(st.converged, st.done & ~st.converged, finite & jnp.all(jnp.isfinite(p)))
        return LMResult(
            p, jnp.where(finite, 2.0 * st.cost, jnp.inf), st.steps, code == int(Status.CONVERGED), code
        )

    return init, step, result


def _prepare(p0, bounds, options):
    p0 = jnp.asarray(p0)
    bounds = tuple(jnp.asarray(b, p0.dtype) for b in bounds)
    return p0, bounds, BoxLMOptions(*(jnp.asarray(o, p0.dtype) for o in options))


@functools.partial(jax.jit, static_argnames=("residual", "max_steps", "block_rows"))
def box_lm(residual, p0, args, bounds, options=DEFAULT_OPTIONS, *, max_steps=100, block_rows=None):
    """Projected LM on the box ``bounds = (lo, hi)`` from ``p0`` (see the module docstring).
    ``steps`` counts iterations; each costs one residual and one forward Jacobian.

    ``block_rows``: for a *row-wise* residual (row ``i`` depends only on the ``i``-th entry of
    every ``args`` leaf of shape ``(n, …)``), a residual longer than ``block_rows`` is linearised in
    blocks of that many rows (:func:`_blocked_reductions`): the same sums to rounding, with
    memory for one block's Jacobian instead of all ``n`` rows'. ``None`` (default): in one piece.
    """
    p0, bounds, options = _prepare(p0, bounds, options)
    init, step, result = _box_lm_stepper(residual, bounds, options, block_rows)
    final = jax.lax.while_loop(
        lambda st: st.probe | (~st.done & (st.steps < max_steps)), lambda st: step(st, args), init(p0)
    )
    return result(final)
