"""Adhesion observer of paper 001 (eqs 16–19), discretised exactly for sampled signals.

The wheelset balance ``J ω̇ = T − μ m g r`` (eq 16) gives, with the wheel speed's derivative taken
through the first-order low-pass of eq 18,

    mu_hat = (T − J · d) / (m g r),        d = [s / (1 + s T0)] (v_w / r)           (eq 19)

with ``m`` the axle load [kg], ``r`` the nominal wheel radius [m], ``J`` [kg·m²], ``T`` [N·m].

**Discretisation.** The filter state ``x`` obeys ``ẋ = (u − x)/T0`` with ``u = v_w / r``; then
``d = (u − x)/T0`` exactly. For an input that is piecewise linear between samples (first-order hold)
the update over a step ``Δt`` is exact:

    α = exp(−Δt/T0),   x⁺ = α x + (1 − α) u_k + (u_{k+1} − u_k) (1 − (T0/Δt)(1 − α))

so the observer is exact for any (also variable) sample spacing, not a forward-Euler approximation.

**Variants.** ``"paper"`` (default) filters only the derivative term, as eq 19 does: the torque goes
through unfiltered, so its noise reaches ``mu_hat`` in full, and during fast transients the torque
and the derivative term are out of phase by the filter lag (about ``T0``). ``"filtered_torque"``
also passes ``T`` through ``1/(1 + s T0)``: ``mu_hat`` is then exactly the low-passed true adhesion
(``(T − J ω̇)`` filtered as one signal), with less noise but a lag ``T0`` on the whole estimate.

**Initial state.** The filters start at rest relative to the first sample (``x_0 = u_0``, filtered
torque ``= T_0``): the derivative estimate starts at 0 and settles within a few ``T0``.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from .vehicle import GRAVITY, LOCO_22E, Vehicle

VARIANTS = ("paper", "filtered_torque")


def foh_coefficients(dt, t0):
    """``α = exp(−Δt/T0)`` and ``β = 1 − (T0/Δt)(1 − α)`` (series for ``Δt ≪ T0``, no 0/0)."""
    x = dt / t0
    one_minus_alpha = -jnp.expm1(-x)
    safe_x = jnp.where(x > 1e-4, x, 1.0)
    beta = jnp.where(x > 1e-4, 1.0 - one_minus_alpha / safe_x, x / 2.0 - x * x / 6.0)
    return 1.0 - one_minus_alpha, one_minus_alpha, beta


@jax.jit
def lowpass_foh(time, signal, t0):
    """First-order low-pass ``1/(1 + s T0)`` of a piecewise-linear signal, exact at the samples.

    Args:
        time: sample times [s], shape (n,), strictly increasing (any spacing).
        signal: samples, shape (n,).
        t0: time constant T0 [s].

    Returns:
        The filter state at each sample, shape (n,), starting at rest (``x_0 = signal[0]``).
        Jitted: called on its own (the diagnosis's heat, per replica) op-by-op dispatch cost
        ~70 ms at 3 000 samples against 0.1 ms compiled.
    """
    alpha, one_minus_alpha, beta = foh_coefficients(jnp.diff(time), t0)

    def step(x, inputs):
        a, oma, b, u0, u1 = inputs
        x_next = a * x + oma * u0 + (u1 - u0) * b
        return x_next, x_next

    _, rest = jax.lax.scan(step, signal[0], (alpha, one_minus_alpha, beta, signal[:-1], signal[1:]))
    return jnp.concatenate([signal[:1], rest])


@functools.partial(jax.jit, static_argnames="variant")
def observer_core(
    time, wheel_speed, torque, inertia, wheel_radius, axle_load, t0, variant="paper", gravity=GRAVITY
):
    """Observed adhesion coefficient ``mu_hat`` [-] (paper eq 19) from plain numbers; pure, jitted
    (one compiled program rather than a dozen eager operations) and vmap-able (also over the
    constants).

    Args:
        time: [s], shape (n,). wheel_speed: circumferential speed at the nominal radius [m/s].
        torque: traction torque at the wheelset [N·m].
        inertia: J [kg·m²]. wheel_radius: nominal r [m]. axle_load: m [kg]. t0: T0 [s].
        variant: ``"paper"`` or ``"filtered_torque"`` (see the module docstring).
        gravity: g [m/s²].
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown observer variant {variant!r}; expected one of {VARIANTS}")
    omega = wheel_speed / wheel_radius
    derivative = (omega - lowpass_foh(time, omega, t0)) / t0
    if variant == "filtered_torque":
        torque = lowpass_foh(time, torque, t0)
    return (torque - inertia * derivative) / (axle_load * gravity * wheel_radius)


def observe_adhesion(time, wheel_speed, torque, vehicle: Vehicle = LOCO_22E, variant="paper"):
    """Observed adhesion ``mu_hat`` [-] with the constants (J, r, axle load, T0) of ``vehicle``.

    The vehicle's numbers enter as Python floats, so this is pure and jit/vmap-able in the signals
    (close over the vehicle, or call :func:`observer_core` to trace the constants too).
    """
    return observer_core(
        time,
        wheel_speed,
        torque,
        vehicle.wheelset_inertia_kgm2,
        vehicle.wheel_radius_m,
        vehicle.axle_load_kg,
        vehicle.observer_time_constant_s,
        variant,
    )
