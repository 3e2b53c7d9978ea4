"""Particle swarm optimisation, standard inertia-weight form (Shi & Eberhart 1998).

For particle ``i`` with personal best ``p_i`` and swarm best ``g``, per dimension::

    v ← w v + c1 r1 (p_i − x) + c2 r2 (g − x),   r1, r2 ~ U(0, 1)
    v ← clip(v, −v_max, v_max),   v_max = velocity_clamp · (upper − lower)
    x ← clip(x + v, lower, upper),   v ← 0 in a clipped component (absorbing walls)

Defaults ``w = 0.7298``, ``c1 = c2 = 1.49618`` are Clerc's constriction values (equivalent to the
constricted PSO); ``velocity_clamp = 0.2`` of the box width. Velocities start at zero. Evaluations:
``n`` at init and ``n`` per iteration.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from .population import Algorithm, clip, evaluate, info, uniform_population


class PSOState(NamedTuple):
    """Swarm: positions and velocities (n, d), fitness (n,), personal and global bests."""

    population: jax.Array
    velocity: jax.Array
    fitness: jax.Array
    personal_x: jax.Array
    personal_f: jax.Array
    best_x: jax.Array
    best_f: jax.Array
    n_evals: jax.Array


class PSOParams(NamedTuple):
    """Inertia ``w``, cognitive ``c1`` and social ``c2`` weights, velocity clamp (box fraction)."""

    inertia: float = 0.7298
    cognitive: float = 1.49618
    social: float = 1.49618
    velocity_clamp: float = 0.2


def init(key, objective, bounds, pop_size, params=PSOParams()):
    """A uniformly drawn swarm at rest (``pop_size`` evaluations)."""
    x = uniform_population(key, bounds, pop_size)
    f = evaluate(objective, x)
    i = jnp.argmin(f)
    return PSOState(x, jnp.zeros_like(x), f, x, f, x[i], f[i], jnp.asarray(pop_size))


def step(key, state, objective, bounds, params=PSOParams()):
    """One PSO iteration (``n`` evaluations)."""
    x = state.population
    k1, k2 = jax.random.split(key)
    r1 = jax.random.uniform(k1, x.shape, dtype=x.dtype)
    r2 = jax.random.uniform(k2, x.shape, dtype=x.dtype)
    v_max = (params.velocity_clamp * (bounds[1] - bounds[0]))[None]
    v = (
        params.inertia * state.velocity
        + params.cognitive * r1 * (state.personal_x - x)
        + params.social * r2 * (state.best_x[None] - x)
    )
    v = jnp.clip(v, -v_max, v_max)
    moved = x + v
    x = clip(moved, bounds)
    v = jnp.where(moved == x, v, 0.0)
    f = evaluate(objective, x)
    improved = f < state.personal_f
    px = jnp.where(improved[:, None], x, state.personal_x)
    pf = jnp.where(improved, f, state.personal_f)
    i = jnp.argmin(pf)
    new = PSOState(x, v, f, px, pf, px[i], pf[i], state.n_evals + x.shape[0])
    return new, info(pf)


PSO = Algorithm("pso", init, step, PSOParams())
