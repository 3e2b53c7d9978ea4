"""The law of the true slip given the smoothed one: normal, truncated to the sign of the force.

The creep smoother (:mod:`jadhesion.data.creep_state`) gives each sample a slip ``ŵ`` [m/s] and a
standard deviation ``sd`` [m/s]. Polach's law is odd in the slip, so a wheel that pulls
(``mu_hat > 0``) slips forward, and the sign of ``mu_hat`` is known far better than the slip's at
walking pace: a torque sensor resolves ~0.001 of the axle's weight, a speed sensor 1–10 mm/s, the
width of the whole micro-slip region. The true slip of a sample with ``|mu_hat| ≥``
:data:`SLIP_SIGN_MIN` is therefore taken as ``N(ŵ, sd²)`` truncated to ``sign(mu_hat)·w ≥ 0``
(below it, untruncated).

Why it matters: without the truncation a smoothed slip near 0 reads as "half the time backwards";
the expected curve then passes through 0 there while the data stay at the adhesion of a small
forward slip, and the misfit looks like a torque offset or a radius error. On the independent
generator's clean 25 Hz starts (``validation/foreign_generator.py``, seed 11058, speed sensors
1.4–2.7 mm/s white + AR): the untruncated base fit had kA 0.14 against a true 1.0 and an offset took
78 % of its sum of squares; truncated, the base sum of squares fell 3.6× and the offset took 30 %.

Two forms, one law:

* :func:`slip_nodes` — Gauss–Hermite nodes mapped onto the truncated normal, for expectations of the
  curve (LM's residual, the posterior): ``e_j = σ u_j``, ``u_j = −Φ⁻¹(Φ(−a) Φ(−z_j))`` ≥
  ``a = −σ ŵ/sd`` (``σ = sign(mu_hat)``; ``u_j = z_j`` far from the bound).
* :func:`truncated_mean` — the law's mean ``ŵ + σ sd φ(a)/Φ(−a)``, one evaluation of the curve
  instead of :data:`GH_NODES` (the diagnosis's many fits; the offset's SSE share on seeds 11058
  and 11061 was 0.32 and 0.28 with it, 0.30 and 0.34 with the 7-node expectation).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jax.scipy.special import log_ndtr, ndtr, ndtri

#: Smallest |mu_hat| [-] whose sign truncates the slip's law (the force direction is known).
SLIP_SIGN_MIN = 0.01
#: Standardised bound beyond which the tail's limit law replaces the exact inverse (Φ(−a) ~ 1e-198).
TAIL = 30.0
#: Gauss–Hermite nodes of the errors-in-variables expectation over the slip.
GH_NODES = 7
_GH_Z, _GH_W = np.polynomial.hermite_e.hermegauss(GH_NODES)
#: The quadrature weights (GH_NODES,), summing to 1.
GH_WEIGHTS = _GH_W / _GH_W.sum()


def _bound(slip, slip_sd, adhesion):
    """``(σ, a)``: the sign of the force (0: untruncated) and the standardised bound ``−σ ŵ/sd``
    (finite: ``sd`` floored at the dtype's smallest normal)."""
    sign = jnp.where(jnp.abs(adhesion) >= SLIP_SIGN_MIN, jnp.sign(adhesion), 0.0)
    tiny = jnp.finfo(slip.dtype).tiny
    a = jnp.clip(-sign * slip / jnp.maximum(slip_sd, tiny), -1.0 / tiny, 1.0 / tiny)
    return sign, a


def slip_nodes(slip, slip_sd, adhesion):
    """Standardised nodes ``e`` (GH_NODES, n): the true slip at node j is ``slip + slip_sd · e_j``,
    each with weight :data:`GH_WEIGHTS` ``[j]`` (module docstring). Inputs (n,): slip, slip_sd
    [m/s], adhesion ``mu_hat`` [-]. Beyond ``a`` = :data:`TAIL` (the smoothed slip far on the wrong
    side, where ``Φ(−a)`` underflows) the tail's limit law ``u = a + Exp(1)/a`` is used."""
    z = jnp.asarray(_GH_Z, slip.dtype)[:, None]
    sign, a = _bound(slip, slip_sd, adhesion)
    near = jnp.minimum(a, TAIL)[None, :]
    far = jnp.maximum(a, TAIL)[None, :]
    u = jnp.where(a[None, :] <= TAIL, -ndtri(ndtr(-near) * ndtr(-z)), far - log_ndtr(-z) / far)
    return jnp.where(sign[None, :] == 0, z, sign[None, :] * u)


def truncated_mean(slip, slip_sd, adhesion):
    """Mean [m/s] (n,) of the true slip's law: ``slip + σ slip_sd φ(a)/Φ(−a)`` (module docstring;
    ``slip`` where untruncated or ``slip_sd`` is 0; beyond ``a`` = :data:`TAIL` the Mills ratio's
    expansion ``φ(a)/Φ(−a) = a + 1/a − 2/a³ + …``, on the force's side for any input)."""
    sign, a = _bound(slip, slip_sd, adhesion)
    near = jnp.minimum(a, TAIL)
    far = jnp.maximum(a, TAIL)
    mills = jnp.exp(-0.5 * near * near - 0.5 * jnp.log(2.0 * jnp.pi) - log_ndtr(-near))
    beyond = sign * slip_sd * (1.0 / far - 2.0 / far**3 + 10.0 / far**5)  # = slip + σ sd mills
    mean = jnp.where(a <= TAIL, slip + sign * slip_sd * mills, beyond)
    return jnp.where((sign == 0) | (slip_sd <= 0), slip, mean)
