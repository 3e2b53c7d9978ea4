"""Polach's creep-force model, longitudinal (paper 001, eqs 3, 6, 8; Polach 2005).

Parameters are the vector ``theta = [kA, kS, mu0, A, B]``:

* ``kA`` [-]: reduction factor in the adhesion area, ``kS`` [-]: in the slip area;
* ``mu0`` [-]: friction at zero slip velocity; ``A = mu_inf/mu0`` [-]; ``B`` [s/m]: decay rate.

With slip velocity ``w`` [m/s] and creepage ``s`` [-]::

    mu(w)  = mu0 ((1 − A) exp(−B |w|) + A)
    eps    = k_eps · s / mu,          k_eps = (2/3) C π a² b / Q
    mu_adh = (2 mu / π) (kA eps / (1 + (kA eps)²) + atan(kS eps))

``k_eps`` [-] is the contact's gradient constant (Hertz ellipse and Kalker stiffness; see
:mod:`jadhesion.models.contact`). The curve is odd in (s, w). Friction is floored at 1e-12 and
``eps`` clipped at ±1e8 (where the first term is below 1e-8), so no NaN or inf arises anywhere in the
domain, standstill and zero friction included.

For speed the curve is evaluated without forming ``eps``: with ``u = k_eps s`` it is
``(2/π) (kA u mu² / (mu² + (kA u)²) + mu atan(kS u / mu))``, the arctangent of a ratio taken
by :func:`atan_ratio` with a single division. Two divisions per sample instead of four make a
population evaluation 10–35 % cheaper on XLA:CPU; values and derivatives agree with the textbook
form to 1e-15.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from .contact import Contact, contact_stiffness

PARAM_NAMES = ("kA", "kS", "mu0", "A", "B")
#: Identification box of the paper: every parameter in [0, 1].
BOUNDS = (np.zeros(5), np.ones(5))

_MU_FLOOR = 1e-12
_EPS_CLIP = 1e8

# Cephes ``atan`` (S. L. Moshier): reduction to |t| ≤ 0.66 with tan(3π/8) and π/4 splits, then a
# [4/5] rational in t². Max error vs a correctly rounded arctan ≈ 1 ulp (2.2e-16 relative) on the
# whole real line, ~3x faster than XLA:CPU's float64 ``atan`` (12 → 4 ns per element). Used
# homogenised in (numerator, denominator) by :func:`atan_ratio`.
_ATAN_P = (
    -8.750608600031904122785e-1,
    -1.615753718733365076637e1,
    -7.500855792314704667340e1,
    -1.228866684490136173410e2,
    -6.485021904942025371773e1,
)
_ATAN_Q = (
    2.485846490142306297962e1,
    1.650270098316988542046e2,
    4.328810604912902668951e2,
    4.853903996359136964868e2,
    1.945506571482613964425e2,
)
_TAN_3PI_8 = 2.41421356237309504880
_PI_2_LO = 6.123233995736765886130e-17  # π/2 − fl(π/2)


@jax.custom_jvp
def atan_ratio(n, d):
    """``arctan(n / d)`` for ``d > 0`` with one division (Cephes' reduction and [4/5] rational,
    homogenised in ``(n, d)``); within ~2 ulp of ``arctan2``. Derivatives are exact:
    ``∂/∂n = d / (n² + d²)``, ``∂/∂d = −n / (n² + d²)``. Keep ``|n/d| ≤ 1e8`` (powers of ``d``
    up to the tenth are formed)."""
    an = jnp.abs(n)
    big = an > _TAN_3PI_8 * d
    mid = (an > 0.66 * d) & ~big
    # reduced argument t = tn / td, |t| ≤ 0.66
    tn = jnp.where(big, -d, jnp.where(mid, an - d, an))
    td = jnp.where(big, an, jnp.where(mid, an + d, d))
    offset = jnp.where(big, 0.5 * jnp.pi, jnp.where(mid, 0.25 * jnp.pi, 0.0))
    low = jnp.where(big, _PI_2_LO, jnp.where(mid, 0.5 * _PI_2_LO, 0.0))
    a, b = tn * tn, td * td
    b2 = b * b
    b3, b4 = b2 * b, b2 * b2
    p, q = _ATAN_P, _ATAN_Q
    # P(z)·b⁴ and Q(z)·b⁵ at z = a / b, so atan(t) = t (1 + z P/Q) = tn (Q_h + a P_h) / (td Q_h)
    p_h = (((p[0] * a + p[1] * b) * a + p[2] * b2) * a + p[3] * b3) * a + p[4] * b4
    q_h = ((((a + q[0] * b) * a + q[1] * b2) * a + q[2] * b3) * a + q[3] * b4) * a + q[4] * b4 * b
    return jnp.copysign(offset + (low + tn * ((q_h + a * p_h) / (td * q_h))), n)


@atan_ratio.defjvp
def _atan_ratio_jvp(primals, tangents):
    (n, d), (dn, dd) = primals, tangents
    return atan_ratio(n, d), (d * dn - n * dd) / (n * n + d * d)


def gradient_constant(contact: Contact, wheel_load, shear_modulus, poisson_ratio):
    """``k_eps = (2/3) C π a² b / Q`` [-] so that ``eps = k_eps · s / mu`` (paper eq 3)."""
    c = contact_stiffness(contact, shear_modulus, poisson_ratio)
    return (2.0 / 3.0) * c * jnp.pi * contact.a**2 * contact.b / wheel_load


def friction(theta, slip):
    """Slip-velocity-dependent friction coefficient ``mu(w)`` [-] (paper eq 6)."""
    mu0, a, b = theta[..., 2], theta[..., 3], theta[..., 4]
    return mu0 * ((1.0 - a) * jnp.exp(-b * jnp.abs(slip)) + a)


def polach_adhesion(theta, creep, slip, k_eps):
    """Adhesion coefficient ``mu_adh`` [-] (paper eq 8).

    Args:
        theta: ``[kA, kS, mu0, A, B]``, shape (5,) (broadcasts against ``creep``).
        creep: creepage s [-].
        slip: slip velocity w [m/s].
        k_eps: contact gradient constant [-] (:func:`gradient_constant`).
    """
    ka, ks = theta[..., 0], theta[..., 1]
    mu = jnp.maximum(friction(theta, slip), _MU_FLOOR)
    limit = _EPS_CLIP * mu
    u = jnp.clip(k_eps * creep, -limit, limit)  # u = eps · mu
    x = ka * u
    mu2 = mu * mu
    return (2.0 / jnp.pi) * (x * mu2 / (mu2 + x * x) + mu * atan_ratio(ks * u, mu))


def initial_slope(theta, k_eps):
    """``d mu_adh / ds`` at zero creep [-]: ``(2/π)(kA + kS) k_eps`` (independent of friction)."""
    return (2.0 / jnp.pi) * (theta[..., 0] + theta[..., 1]) * k_eps


@partial(jax.jit, static_argnames=("n_grid",))
def adhesion_peak(theta, k_eps, vehicle_speed, n_grid=400, s_min=1e-5, s_max=1.0):
    """Peak adhesion ``mu_max`` [-] and the creepage where it occurs [-] at a vehicle speed [m/s].

    The slip velocity along the curve is ``w = s · v``. A log-spaced grid over [s_min, s_max] is
    refined by one parabolic step on the log axis; accurate to ~1e-6 relative in ``mu_max``.
    """
    log_s = jnp.linspace(jnp.log(s_min), jnp.log(s_max), n_grid)

    def curve(ls):
        s = jnp.exp(ls)
        return polach_adhesion(theta, s, s * vehicle_speed, k_eps)

    values = jax.vmap(curve)(log_s)
    i = jnp.clip(jnp.argmax(values), 1, n_grid - 2)
    y0, y1, y2 = values[i - 1], values[i], values[i + 1]
    h = log_s[1] - log_s[0]
    denom = y0 - 2.0 * y1 + y2
    shift = jnp.where(denom < 0, 0.5 * h * (y0 - y2) / jnp.where(denom < 0, denom, -1.0), 0.0)
    ls_opt = log_s[i] + jnp.clip(shift, -h, h)
    mu_opt = curve(ls_opt)
    best_grid = jnp.max(values)
    use_grid = best_grid > mu_opt
    return jnp.where(use_grid, best_grid, mu_opt), jnp.exp(
        jnp.where(use_grid, log_s[jnp.argmax(values)], ls_opt)
    )
