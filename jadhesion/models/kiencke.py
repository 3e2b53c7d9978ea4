"""Kiencke's adhesion–creep model (paper 000, eqs 1–2).

``mu(lam) = a_s * lam / (1 + p1 * lam + p2 * lam**2)`` with creep ratio ``lam`` [-].
The optimum creep is ``1 / sqrt(p2)`` and the peak adhesion ``a_s / (p1 + 2 sqrt(p2))``.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp

#: Initial slope a_s [-] chosen so the paper's Figure 1 curves peak below 0.6 and the "normal" set
#: peaks at 0.35, the actual maximum adhesion drawn in the paper's Figure 6 (mu_m = a_s / 100).
DEFAULT_SLOPE = 35.0


class KienckeParams(NamedTuple):
    """Kiencke parameters p1 [-], p2 [-]."""

    p1: float
    p2: float


#: Rail conditions read from the paper's Figure 1.
RAIL_SETS = {
    "dry": KienckeParams(58.0, 51.0),
    "normal": KienckeParams(80.0, 100.0),
    "wet": KienckeParams(118.0, 278.0),
}


def kiencke_adhesion(lam, p1, p2, a_s=DEFAULT_SLOPE):
    """Adhesion coefficient [-] at creep ratio ``lam`` [-]; odd in ``lam``.

    Written with ``|lam|`` in the denominator so the curve is odd and the denominator stays ≥ 1 for
    non-negative ``p1, p2`` (no pole, no NaN for any creep).
    """
    lam = jnp.asarray(lam)
    x = jnp.abs(lam)
    return a_s * lam / (1.0 + p1 * x + p2 * x * x)


def kiencke_optimum(p1, p2, a_s=DEFAULT_SLOPE):
    """Optimum creep ``1/sqrt(p2)`` [-] and peak adhesion ``a_s/(p1 + 2 sqrt(p2))`` [-]."""
    root = jnp.sqrt(p2)
    return 1.0 / root, a_s / (p1 + 2.0 * root)


def kiencke_regressors(lam, mu, a_s=DEFAULT_SLOPE):
    """Linear-in-parameters form ``Z = U @ [p1, p2]`` with ``Z = a_s lam - mu``, ``U = [lam mu, lam² mu]``."""
    lam = jnp.asarray(lam)
    mu = jnp.asarray(mu)
    x = jnp.abs(lam)
    return a_s * lam - mu, jnp.stack([x * mu, x * x * mu], axis=-1)
