"""Teaching–learning-based optimisation: classic TLBO and the improved TLBO of paper 001 (§3).

One iteration on a class ``X`` (n, d) with teacher ``T`` (best student) and mean ``M``:

* **teacher phase** (eqs 9–10): ``X_new = X + r_j ∘ (T − T_F M)``, ``r_j ~ U(0, 1)^d``: one random
  number per student *and dimension*, as in Rao's reference implementations (a single scalar per
  student moves the whole class along one direction and stalls: on a 4-D sphere it ends ~10⁸ times
  worse after 60 iterations).
  Classic: ``T_F = round(1 + rand) ∈ {1, 2}`` per student. Improved (eq 12): per dimension
  ``T_F,D = M_D / T_D``; where ``T_D = 0`` the ratio is undefined and ``T_F,D = 1`` is used (the
  teacher then pulls the class plainly towards itself, ``r (T − M)``).
* **learner phase** (eq 11): for a random partner ``k ≠ j``,
  ``X_new = X_j + r_j ∘ (X_j − X_k)`` if ``f(X_j) < f(X_k)`` else ``X_j + r_j ∘ (X_k − X_j)``.
* **remedial phase** (improved only, eqs 13–14) for the worst 20 % (:data:`REMEDIAL_FRACTION`):
  tutoring ``X̂ = X + (0.5 + rand/2)(T − X)`` (one rand per student) and self-study
  ``X̃ = X + X_lim (rand − 0.5)`` (rand per dimension), ``X_lim = upper − lower``; the best of
  ``X``, ``X̂``, ``X̃`` is kept.

After every phase the candidates are clipped to the box and selection is greedy, keeping the
*better* of old and new (the paper's sentence reads reversed). Evaluations per iteration: ``2n``
(classic), ``2n + 2m`` (improved, ``m = max(1, round(0.2 n))``); ``n`` at init. TLBO has no tunable
coefficients, so its params pytree is empty.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from .population import Algorithm, clip, evaluate, greedy, info, uniform_population


class TLBOState(NamedTuple):
    """A class of students: ``population`` (n, d), ``fitness`` (n,), best so far, evaluations."""

    population: jax.Array
    fitness: jax.Array
    best_x: jax.Array
    best_f: jax.Array
    n_evals: jax.Array


class TLBOParams(NamedTuple):
    """TLBO is parameter-free (an empty coefficient pytree, kept for a uniform interface)."""


#: Share of the class (the worst) sent to the remedial phase; it fixes shapes, so it is static.
REMEDIAL_FRACTION = 0.2


def init(key, objective, bounds, pop_size, params=TLBOParams()):
    """A uniformly drawn class and its fitness (``pop_size`` evaluations)."""
    x = uniform_population(key, bounds, pop_size)
    f = evaluate(objective, x)
    return _with_best(x, f, jnp.asarray(pop_size))


def _with_best(x, f, n_evals):
    i = jnp.argmin(f)
    return TLBOState(x, f, x[i], f[i], n_evals)


def _teacher_learner(key, state, objective, bounds, teaching_factor):
    """Teacher then learner phase; ``teaching_factor(key, teacher, mean)`` gives T_F (n, d)."""
    x, f = state.population, state.fitness
    n = x.shape[0]
    k_tf, k_r1, k_partner, k_r2 = jax.random.split(key, 4)
    teacher, mean = x[jnp.argmin(f)], jnp.mean(x, axis=0)
    r = jax.random.uniform(k_r1, x.shape, dtype=x.dtype)
    step = teacher[None] - teaching_factor(k_tf, teacher, mean) * mean[None]
    x_new = clip(x + r * step, bounds)
    x, f = greedy(x, f, x_new, evaluate(objective, x_new))

    partner = (jnp.arange(n) + jax.random.randint(k_partner, (n,), 1, n)) % n
    xk, fk = x[partner], f[partner]
    r = jax.random.uniform(k_r2, x.shape, dtype=x.dtype)
    x_new = clip(x + r * jnp.where((f < fk)[:, None], x - xk, xk - x), bounds)
    x, f = greedy(x, f, x_new, evaluate(objective, x_new))
    return x, f


def _classic_factor(n):
    def factor(key, teacher, mean):
        return jnp.round(1.0 + jax.random.uniform(key, (n, 1), dtype=mean.dtype))

    return factor


def _adaptive_factor(key, teacher, mean):
    safe = jnp.where(teacher == 0, 1.0, teacher)
    return jnp.where(teacher == 0, 1.0, mean / safe)[None]


def step(key, state, objective, bounds, params=TLBOParams()):
    """One classic TLBO iteration (teacher and learner phases; ``2n`` evaluations)."""
    n = state.population.shape[0]
    x, f = _teacher_learner(key, state, objective, bounds, _classic_factor(n))
    new = _with_best(x, f, state.n_evals + 2 * n)
    return new, info(f)


def remedial_size(pop_size):
    """Number of students in the remedial phase, ``max(1, round(0.2 n))``."""
    return max(1, int(round(REMEDIAL_FRACTION * pop_size)))


def improved_step(key, state, objective, bounds, params=TLBOParams()):
    """One improved-TLBO iteration (paper 001 §3.2; ``2n + 2m`` evaluations)."""
    n, d = state.population.shape
    m = remedial_size(n)
    k_tl, k_tutor, k_self = jax.random.split(key, 3)
    x, f = _teacher_learner(k_tl, state, objective, bounds, _adaptive_factor)

    worst = jnp.argsort(-f)[:m]
    x_old, f_old = x[worst], f[worst]
    teacher = x[jnp.argmin(f)]
    lower, upper = bounds
    tutored = x_old + (0.5 + 0.5 * jax.random.uniform(k_tutor, (m, 1), dtype=x.dtype)) * (
        teacher[None] - x_old
    )
    studied = x_old + (upper - lower)[None] * (jax.random.uniform(k_self, (m, d), dtype=x.dtype) - 0.5)
    trial = clip(jnp.concatenate([tutored, studied]), bounds)
    f_trial = evaluate(objective, trial)
    x_best, f_best = greedy(x_old, f_old, trial[:m], f_trial[:m])
    x_best, f_best = greedy(x_best, f_best, trial[m:], f_trial[m:])
    x, f = x.at[worst].set(x_best), f.at[worst].set(f_best)
    new = _with_best(x, f, state.n_evals + 2 * n + 2 * m)
    return new, info(f)


TLBO = Algorithm("tlbo", init, step, TLBOParams())
ITLBO = Algorithm("itlbo", init, improved_step, TLBOParams())
