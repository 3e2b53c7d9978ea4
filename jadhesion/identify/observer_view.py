"""The adhesion observer's view of a curve: what the ``"observer"`` likelihood predicts.

The paper's observer (eq 19) low-passes the wheel-speed derivative but not the torque; from the
wheelset balance its output is ``mu_hat = LP[mu] + (T − LP[T])/(m g r) + noise``, ``LP`` the
observer's first-order low-pass ``1/(1 + s T0)`` with the exact first-order-hold discretisation of
:mod:`jadhesion.data.observer`. :class:`ObserverTerms` holds the recording's part of that
prediction (the torque term and the filter's coefficients); :func:`lowpass` applies the filter to
a predicted curve.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..data.observer import foh_coefficients, lowpass_foh
from ..data.vehicle import GRAVITY


class ObserverTerms(NamedTuple):
    """What the ``"observer"`` likelihood needs besides the dataset (a pytree, arrays float64):
    torque_term: ``(T − LP[T]) / (m g r)`` [-], shape (n,) (zeros for ``filtered_torque``).
    alpha, gain0, gain1: first-order-hold low-pass coefficients per step, shape (n − 1,):
        ``x_{k+1} = alpha x_k + gain0 u_k + gain1 u_{k+1}``, ``x_0 = u_0``.
    """

    torque_term: jax.Array
    alpha: jax.Array
    gain0: jax.Array
    gain1: jax.Array


def observer_terms(
    time,
    torque,
    axle_load_kg: float,
    wheel_radius_m: float,
    t0: float,
    variant: str = "paper",
    gravity: float = GRAVITY,
) -> ObserverTerms:
    """:class:`ObserverTerms` of a recording: ``time`` [s] (n,), recorded ``torque`` [N·m] (n,),
    the observer's axle load [kg], nominal radius [m] and time constant ``T0`` [s]."""
    time, torque = jnp.asarray(time, jnp.float64), jnp.asarray(torque, jnp.float64)
    if time.ndim != 1 or time.shape != torque.shape or time.shape[0] < 3:
        raise ValueError(
            f"time and torque must be 1-D of equal length >= 3, got {time.shape}, {torque.shape}"
        )
    if variant == "paper":
        term = (torque - lowpass_foh(time, torque, t0)) / (axle_load_kg * gravity * wheel_radius_m)
    elif variant == "filtered_torque":
        term = jnp.zeros_like(torque)
    else:
        raise ValueError(f"unknown observer variant {variant!r}")
    alpha, one_minus_alpha, beta = foh_coefficients(jnp.diff(time), t0)
    return ObserverTerms(term, alpha, one_minus_alpha - beta, beta)


def recording_observer_terms(recording, variant: str = "paper") -> ObserverTerms:
    """:func:`observer_terms` of a :class:`jadhesion.data.recording.Recording` or a simulation
    result (anything with ``columns`` and ``vehicle``; the vehicle's constants); ``ValueError``
    when it has no ``time`` or ``traction_torque`` column."""
    cols = recording.columns
    missing = [c for c in ("time", "traction_torque") if c not in cols]
    if missing:
        raise ValueError(
            f"the observer likelihood needs the column(s) {', '.join(missing)} "
            f"(a raw recording, not a creepage-only dataset)"
        )
    v = recording.vehicle
    return observer_terms(
        cols["time"],
        cols["traction_torque"],
        v.axle_load_kg,
        v.wheel_radius_m,
        v.observer_time_constant_s,
        variant,
    )


def lowpass(u, obs: ObserverTerms):
    """The observer's low-pass of a sampled signal ``u`` (n,), exact for first-order hold; a
    parallel (associative) scan of the linear recurrence, so it vectorises over walkers."""
    a = jnp.concatenate([jnp.zeros(1, u.dtype), obs.alpha])
    b = jnp.concatenate([u[:1], obs.gain0 * u[:-1] + obs.gain1 * u[1:]])

    def compose(first, second):
        a1, b1 = first
        a2, b2 = second
        return a1 * a2, a2 * b1 + b2

    return jax.lax.associative_scan(compose, (a, b))[1]
