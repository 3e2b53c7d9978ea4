"""A work queue of projected-LM problems.

:func:`box_lm_queue` runs many such problems as a work queue over a few vmapped lanes, so a batch
costs its total number of steps rather than (batch size × the slowest member's steps).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from .box_lm import DEFAULT_OPTIONS, _box_lm_stepper, _prepare


@functools.partial(jax.jit, static_argnames=("residual", "max_steps", "lanes", "block_rows"))
def box_lm_queue(
    residual, starts, args, bounds, options=DEFAULT_OPTIONS, *, max_steps=100, lanes=8, block_rows=None
):
    """:func:`box_lm` on many problems — row ``i`` of ``starts`` (N, d) with the ``i``-th slice of
    the stacked pytree ``args`` — as a work queue: ``lanes`` problems iterate side by side (one
    vmapped step) and a lane that converges takes the next waiting problem at once. A plain
    ``vmap`` of :func:`box_lm` runs every member for as many steps as the slowest; the queue's
    cost follows the *total* steps instead. ``block_rows``: as in :func:`box_lm`. Returns a stacked
    :class:`LMResult` in input order."""
    starts, bounds, options = _prepare(starts, bounds, options)
    n_problems = starts.shape[0]
    lanes = min(lanes, n_problems)
    take = lambda i: jax.tree.map(lambda a: a[i], args)  # noqa: E731
    init, step, result = _box_lm_stepper(residual, bounds, options, block_rows)
    finished = lambda st: ~st.probe & (st.done | (st.steps >= max_steps))  # noqa: E731
    out0 = jax.vmap(lambda p: result(init(p)))(starts)

    def body(carry):
        states, index, next_index, out = carry
        live = index < n_problems
        lane_args = take(jnp.minimum(index, n_problems - 1))
        stepped = jax.vmap(step)(states, lane_args)
        states = jax.tree.map(
            lambda new, old: jnp.where(live.reshape((-1,) + (1,) * (new.ndim - 1)), new, old), stepped, states
        )
        ending = live & jax.vmap(finished)(states)
        out = jax.tree.map(
            lambda o, v: o.at[jnp.where(ending, index, n_problems)].set(v, mode="drop"),
            out,
            jax.vmap(result)(states),
        )
        new_index = next_index + jnp.cumsum(ending) - 1
        index = jnp.where(ending, jnp.where(new_index < n_problems, new_index, n_problems), index)

        def refill(states):  # a start's residual and Jacobian: only on iterations where a lane ends
            fresh = jax.vmap(init)(starts[jnp.minimum(index, n_problems - 1)])
            return jax.tree.map(
                lambda f, s: jnp.where(ending.reshape((-1,) + (1,) * (f.ndim - 1)), f, s), fresh, states
            )

        states = jax.lax.cond(jnp.any(ending), refill, lambda states: states, states)
        return states, index, next_index + jnp.sum(ending), out

    first = jnp.arange(lanes)
    carry = (jax.vmap(init)(starts[first]), first, jnp.asarray(lanes), out0)
    _, _, _, out = jax.lax.while_loop(lambda c: jnp.any(c[1] < n_problems), body, carry)
    return out
