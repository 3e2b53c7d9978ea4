"""One step of the L-stable linearly implicit 2-stage Rosenbrock method ROS2 (Verwer et al. 1999,
``γ = 1 + 1/√2``) for a small stiff system, at a fixed step.

With ``W = I − γ h J`` (``J`` the Jacobian of ``f`` at ``y``, by forward mode, ``jax.linearize``):
``W k1 = f(t, y)``, ``W k2 = f(t+h, y+h k1) − 2 k1``, ``y⁺ = y + h (3 k1 + k2)/2``. A W-method: time
enters only through ``f``, the ``∂f/∂t`` term is dropped. Used by the simulator's plant
(:mod:`.traction_plant`), whose wheel equation is stiff at small creep. Not diffrax: a 4-state
system at a fixed step matching the controller's rate needs no adaptivity, and this avoids a
dependency and its compile cost.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

GAMMA = 1.0 + 1.0 / math.sqrt(2.0)


def _lu(a):
    """Doolittle LU of a small matrix without pivoting (unrolled): ``W = I − γ h J`` is the identity
    plus O(h) except on the stiff diagonal, where it is large, so its pivots stay ≥ ~0.9."""
    n = a.shape[0]
    for k in range(n - 1):
        factors = a[k + 1 :, k] / a[k, k]
        a = a.at[k + 1 :, k + 1 :].add(-factors[:, None] * a[k, k + 1 :][None, :])
        a = a.at[k + 1 :, k].set(factors)
    return a


def _lu_solve(lu, b):
    n = b.shape[0]
    y = []
    for i in range(n):
        y.append(b[i] - sum(lu[i, j] * y[j] for j in range(i)))
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum(lu[i, j] * x[j] for j in range(i + 1, n))) / lu[i, i]
    return jnp.stack(x)


def ros2_step(f_now, f_next, y, h):
    """``y`` one step ``h`` [s] on: ``f_now(y)`` and ``f_next(y)`` are the right-hand side at the
    step's start ``t`` and end ``t + h`` (time-dependent parts evaluated beforehand)."""
    f0, linear = jax.linearize(f_now, y)
    eye = jnp.eye(y.shape[0], dtype=y.dtype)
    lu = _lu(eye - GAMMA * h * jax.vmap(linear, out_axes=1)(eye))
    k1 = _lu_solve(lu, f0)
    k2 = _lu_solve(lu, f_next(y + h * k1) - 2.0 * k1)
    return y + h * (1.5 * k1 + 0.5 * k2)
