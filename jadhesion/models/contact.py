"""Wheel–rail contact: Hertz ellipse and Kalker's linear-theory stiffness.

Hertz (Johnson, *Contact Mechanics*, §4.2): relative curvatures ``A' = 1/(2 R_w)`` in the rolling
direction (the rail is straight) and ``B' = (1/R_rail + 1/R_profile)/2`` laterally. The ellipse of
eccentricity ``e`` (``e² = 1 − (short/long)²``) solves

    B'/A' = [E(e)/(1 − e²) − K(e)] / [K(e) − E(e)],   long³ = 3 Q (K − E) / (2 π E* e² · min(A', B'))

with complete elliptic integrals K, E of parameter ``m = e²`` and ``1/E* = 2 (1 − ν²)/E`` (same
material). The long semi-axis lies along the smaller curvature.

Polach's contact stiffness ``C = 3 G c11 / (8 a)`` [N/m³] uses Kalker's coefficient ``c11`` from his
Table E.3 (shipped as ``resources/kalker_c_table_e3.csv``), interpolated linearly in ``ln(a/b)`` and
in Poisson's ratio, with the asymptotes ``c11 = π²/(4(1−ν))`` for ``a ≪ b`` and
``c11 = 2π / (g (ln(16/g²) − 3/2 − 2ν))``, ``g = b/a``, for ``a ≫ b`` (the latter matched to the table
at g = 0.1 to within 1 %; both scaled to meet the table exactly at g = 0.1).
"""

from __future__ import annotations

import csv
from importlib import resources
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

_AGM_STEPS = 12
_BISECTION_STEPS = 80


class Contact(NamedTuple):
    """Elliptic contact patch: semi-axes ``a`` (rolling direction) and ``b`` (lateral) [m]."""

    a: jax.Array
    b: jax.Array


def elliptic_ke(m):
    """Complete elliptic integrals of the first and second kind, K(m) and E(m), for 0 ≤ m < 1.

    Arithmetic–geometric mean with a fixed number of steps (quadratic convergence; exact to
    float64 round-off for m ≤ 1 − 1e-12). Parameter convention ``m = k²`` as in scipy.
    """
    m = jnp.asarray(m)
    a = jnp.ones_like(m)
    b = jnp.sqrt(1.0 - m)
    total = m / 2.0  # 2^(n-1) c_n^2 at n = 0, with c_0^2 = m
    power = 0.5
    for _ in range(_AGM_STEPS):  # unrolled: a fixed, small count, not an iteration over data
        c = (a - b) / 2.0
        a, b = (a + b) / 2.0, jnp.sqrt(a * b)
        power = power * 2.0
        total = total + power * c * c
    k = jnp.pi / (2.0 * a)
    return k, k * (1.0 - total)


def _curvature_ratio(m):
    k, e = elliptic_ke(m)
    return (e / (1.0 - m) - k) / (k - e)


def hertz_semi_axes(
    wheel_radius,
    rail_head_radius,
    wheel_load,
    young_modulus=2.1e11,
    poisson_ratio=0.28,
    wheel_profile_radius=jnp.inf,
):
    """Hertz contact semi-axes (a along rolling, b lateral) [m].

    Args:
        wheel_radius: rolling radius R_w [m].
        rail_head_radius: rail-head crown radius [m].
        wheel_load: normal force Q [N].
        young_modulus: E [Pa] (steel 2.1e11).
        poisson_ratio: ν [-].
        wheel_profile_radius: transverse radius of the wheel profile [m] (∞ for a conical tread).
    """
    along = 0.5 / wheel_radius
    across = 0.5 * (1.0 / rail_head_radius + 1.0 / wheel_profile_radius)
    big, small = jnp.maximum(along, across), jnp.minimum(along, across)
    ratio = big / small

    # Bisection in k' = short/long on a log scale: ratio(k') decreases monotonically from ∞ to 1.
    def body(_, bracket):
        lo, hi = bracket
        mid = 0.5 * (lo + hi)
        m = 1.0 - jnp.exp(2.0 * mid)
        too_flat = _curvature_ratio(m) > ratio  # ellipse too elongated → increase k'
        return jnp.where(too_flat, mid, lo), jnp.where(too_flat, hi, mid)

    lo0 = jnp.full_like(ratio, jnp.log(1e-6))
    hi0 = jnp.full_like(ratio, -1e-9)
    lo, hi = jax.lax.fori_loop(0, _BISECTION_STEPS, body, (lo0, hi0))
    kprime = jnp.exp(0.5 * (lo + hi))
    m = jnp.maximum(1.0 - kprime**2, 1e-9)
    k, e = elliptic_ke(m)
    e_star = young_modulus / (2.0 * (1.0 - poisson_ratio**2))
    long = (3.0 * wheel_load * (k - e) / (2.0 * jnp.pi * e_star * m * small)) ** (1.0 / 3.0)
    short = long * kprime
    rolling_is_long = along <= across
    return Contact(jnp.where(rolling_is_long, long, short), jnp.where(rolling_is_long, short, long))


def _load_kalker_table():
    rows = {"a_le_b": [], "a_gt_b": []}
    with resources.files("jadhesion").joinpath("resources/kalker_c_table_e3.csv").open() as fh:
        for row in csv.DictReader(line for line in fh if not line.startswith("#")):
            rows[row["case"]].append(
                [float(row["g"]), float(row["c11_nu0"]), float(row["c11_nu025"]), float(row["c11_nu05"])]
            )
    le, gt = np.array(rows["a_le_b"]), np.array(rows["a_gt_b"])
    # One abscissa x = ln(a/b): a<=b gives x = ln g <= 0; a>b gives x = -ln g > 0.
    x = np.concatenate([np.log(le[:, 0]), -np.log(gt[::-1, 0])[1:]])
    c11 = np.concatenate([le[:, 1:], gt[::-1, 1:][1:]])
    return x, c11


_KALKER_X, _KALKER_C11 = _load_kalker_table()
_KALKER_NU = np.array([0.0, 0.25, 0.5])


def _asymptote_narrow_rolling(nu):  # a << b
    return jnp.pi**2 / (4.0 * (1.0 - nu))


def _asymptote_long_rolling(g, nu):  # a >> b, g = b/a
    return 2.0 * jnp.pi / (g * (jnp.log(16.0 / g**2) - 1.5 - 2.0 * nu))


def kalker_c11(a_over_b, poisson_ratio):
    """Kalker's longitudinal creepage coefficient c11 [-] for semi-axis ratio a/b and Poisson ratio."""
    x = jnp.log(jnp.asarray(a_over_b))
    nu = jnp.asarray(poisson_ratio)
    xt = jnp.asarray(_KALKER_X)
    g_lo = jnp.exp(jnp.minimum(x, xt[0]))  # a/b, used where a/b < 0.1
    g_hi = jnp.exp(-jnp.maximum(x, xt[-1]))  # b/a, used where b/a < 0.1
    per_nu = []
    for j, nu_j in enumerate(_KALKER_NU):
        inside = jnp.interp(x, xt, jnp.asarray(_KALKER_C11[:, j]))
        # Blend from the asymptote (exact as g -> 0) to the table value at g = 0.1.
        lim = _asymptote_narrow_rolling(nu_j)
        below = lim + (_KALKER_C11[0, j] - lim) * g_lo / 0.1
        mismatch = _KALKER_C11[-1, j] / _asymptote_long_rolling(0.1, nu_j) - 1.0
        above = _asymptote_long_rolling(g_hi, nu_j) * (1.0 + mismatch * g_hi / 0.1)
        per_nu.append(jnp.where(x < xt[0], below, jnp.where(x > xt[-1], above, inside)))
    w = jnp.clip(nu / 0.25, 0.0, 2.0)
    return jnp.where(
        w <= 1.0, per_nu[0] + w * (per_nu[1] - per_nu[0]), per_nu[1] + (w - 1.0) * (per_nu[2] - per_nu[1])
    )


def contact_stiffness(contact: Contact, shear_modulus, poisson_ratio):
    """Polach's tangential contact stiffness ``C = 3 G c11 / (8 a)`` [N/m³]."""
    return 3.0 * shear_modulus * kalker_c11(contact.a / contact.b, poisson_ratio) / (8.0 * contact.a)
