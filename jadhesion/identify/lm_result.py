"""Least-squares results shared by every LM in jadhesion: :class:`LMResult`, its status code,
the best of a batch, and the sum-of-squares objective of a residual."""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..status import Status


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
    return jnp.where(
        ~finite,
        int(Status.NONFINITE),
        jnp.where(
            converged, int(Status.CONVERGED), jnp.where(stalled, int(Status.STALLED), int(Status.MAX_STEPS))
        ),
    ).astype(jnp.int32)


def best_of(results: LMResult, converged_first: bool = True) -> LMResult:
    """The lowest-SSE converged member of a batch of :class:`LMResult` (leading axis), or the
    lowest-SSE member when none converged; steps are summed. ``converged_first=False``: the
    lowest-SSE member, converged or not — for runs that only seed a further LM, where a run still
    crawling along a flat valley at a far lower cost is the better seed."""
    sse = jnp.where(jnp.isnan(results.sse), jnp.inf, results.sse)
    if converged_first:
        sse = jnp.where(jnp.any(results.success) & ~results.success, jnp.inf, sse)
    i = jnp.argmin(sse)
    pick = jax.tree_util.tree_map(lambda a: a[i], results)
    return pick._replace(steps=jnp.sum(results.steps))


@functools.cache
def sse_objective(residual):
    """``p, args -> ‖residual(p, args)‖²`` (cached per residual, so jit caches stay warm)."""

    def sse(p, args):
        r = residual(p, args)
        return jnp.sum(r * r)

    return sse
