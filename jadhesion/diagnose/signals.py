"""The raw signals a diagnosis works on, split so each candidate effect can act where it enters.

The observer (paper 001, eq 19, :mod:`jadhesion.data.observer`) is linear in the torque, so

    mu_hat = T/(m g r) − J d/(m g r) = torque_mu − deriv_mu

with ``d`` the low-passed derivative of ``ω = v_w / r``. Keeping the two terms apart lets an
observation-side effect (torque delay, torque bias, radius error) correct the torque term without
re-running the filter on the wheel speed, which none of them changes.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..data.observer import lowpass_foh, observer_core
from ..data.vehicle import GRAVITY, Vehicle
from ..errors import InputError
from ..models import kinematics

#: Default thermal lag τ_th [s] of :attr:`Signals.heat`.
THERMAL_LAG_S = 2.0
#: Half-width [s] of the centred moving average used for the derivatives of v and of torque_mu.
SMOOTH_HALF_WIDTH_S = 0.25


class Signals(NamedTuple):
    """One recording, float arrays of shape (n,) unless marked (); a pytree, so it vmaps.

    time [s]; speed ``v`` [m/s]; wheel_speed ``v_w`` [m/s, at the nominal radius]; torque_mu
    ``T/(m g r)`` [-]; deriv_mu ``J d/(m g r)`` [-]; adhesion ``mu_hat = torque_mu − deriv_mu`` [-];
    accel ``dv/dt`` [m/s²]; torque_rate ``d torque_mu/dt`` [1/s]; power ``|mu_obs m g w|`` [W]
    (frictional power of the axle, ``mu_obs`` the observer's low-passed estimate even where the
    target uses the latent acceleration: with the latter the thermal fit of a clean recording
    stalled); heat: power through ``1/(1 + s τ_th)`` [W] (the exact
    first-order-hold filter :func:`~jadhesion.data.observer.lowpass_foh`; τ_th =
    :data:`THERMAL_LAG_S` until :func:`jadhesion.diagnose.features.pick_thermal_lag` sets it);
    traction_ratio ``F_t/(M g) = n T/(r M g)`` [-] from the smoothed torque; slip_sd [m/s] the
    regressor slip's standard deviation (the smoother's; 0 for measured speeds); weight [-] > 0 on
    the samples the fits use (1, or the diagnosis's errors-in-variables weights), 0 on those
    excluded (``--phase``: standstill, coasting, …) and on padding; dt () [s];
    speed_ref () mean speed [m/s];
    duration () [s]; k_eps () Polach gradient constant [-].
    """

    time: jax.Array
    speed: jax.Array
    wheel_speed: jax.Array
    torque_mu: jax.Array
    deriv_mu: jax.Array
    adhesion: jax.Array
    accel: jax.Array
    torque_rate: jax.Array
    power: jax.Array
    heat: jax.Array
    traction_ratio: jax.Array
    slip_sd: jax.Array
    weight: jax.Array
    dt: jax.Array
    speed_ref: jax.Array
    duration: jax.Array
    k_eps: jax.Array


def smooth(x: np.ndarray, dt: float) -> np.ndarray:
    """Centred moving average over ±:data:`SMOOTH_HALF_WIDTH_S` (edges padded)."""
    half = max(1, int(round(SMOOTH_HALF_WIDTH_S / dt)))
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    return np.convolve(np.pad(x, half, mode="edge"), kernel, mode="valid")


def smooth_derivative(time: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``dx/dt`` by central differences, then :func:`smooth` (noise of a sample stays out of the
    regressor at that sample up to 1/(2·half + 1))."""
    return smooth(np.gradient(x, time), float(np.median(np.diff(time))))


def from_columns(
    columns: dict, vehicle: Vehicle, name: str = "recording", mask=None, regressors=None
) -> Signals:
    """Build :class:`Signals` from raw recording columns (time, vehicle_speed, wheel_speed,
    traction_torque) and the vehicle's constants; ``mask`` (n,) bool marks the samples the fits use
    (default all; the diagnosis passes its errors-in-variables weights instead, zero where
    excluded); ``regressors = (v, v_w, slip_sd)`` [m/s] replace the measured speeds as the models'
    inputs (speed, wheel speed, slip, power, acceleration) and give the slip's standard deviation
    (the diagnosis passes the smoother's latent speeds, :func:`jadhesion.diagnose.null.
    latent_speeds`). The target's wheel-acceleration term ``J ω̇`` is then the derivative of the
    latent wheel speed, without the observer's low-pass: torque and acceleration at the same
    instant as the regressors' slip (the observer's lag on ``J ω̇`` alone left ``μ̂`` off by
    ``J τ ω̈`` at every slip-up, which a fitted −τ torque delay took up on clean recordings of
    the independent generator). Without regressors the target is the observer's (measured wheel
    speed, time constant from the vehicle). Raises :class:`InputError` if columns are missing."""
    return torque_builder(columns, vehicle, name, mask, regressors)(columns["traction_torque"])


def torque_builder(columns: dict, vehicle: Vehicle, name: str = "recording", mask=None, regressors=None):
    """``build(torque [N·m], thermal_lag=THERMAL_LAG_S) -> Signals``: :func:`from_columns` with
    everything the speeds determine (observer derivative, slip, acceleration, weights, ``k_eps``)
    computed once, so recordings that differ only in their torque (the null's replicas) pay only
    for the torque's terms; ``thermal_lag`` [s] sets :attr:`Signals.heat`'s lag."""
    missing = [c for c in ("time", "vehicle_speed", "wheel_speed", "traction_torque") if c not in columns]
    if missing:
        raise InputError(f"{name}: diagnosis needs the raw signals; missing column(s) {', '.join(missing)}")
    t = np.asarray(columns["time"], float)
    if t.size < 50:
        raise InputError(f"{name}: diagnosis needs at least 50 samples, got {t.size}")
    v = np.asarray(columns["vehicle_speed"], float)
    vw = np.asarray(columns["wheel_speed"], float)
    scale = vehicle.axle_load_kg * GRAVITY * vehicle.wheel_radius_m
    observer_deriv = -np.asarray(
        observer_core(
            jnp.asarray(t),
            jnp.asarray(vw),
            jnp.zeros_like(jnp.asarray(vw)),
            vehicle.wheelset_inertia_kgm2,
            vehicle.wheel_radius_m,
            vehicle.axle_load_kg,
            vehicle.observer_time_constant_s,
        )
    )
    deriv_mu, slip_sd = observer_deriv, np.zeros(t.size)
    if regressors is not None:
        v, vw, slip_sd = (np.asarray(x, float) for x in regressors)
        deriv_mu = vehicle.wheelset_inertia_kgm2 * np.gradient(vw, t) / (vehicle.wheel_radius_m * scale)
    slip = np.abs(np.asarray(kinematics.slip_velocity(vw, v)))
    dt = float(np.median(np.diff(t)))
    f = jnp.asarray
    fixed = dict(
        time=f(t),
        speed=f(v),
        wheel_speed=f(vw),
        deriv_mu=f(deriv_mu),
        accel=f(smooth_derivative(t, v)),
        slip_sd=f(slip_sd),
        weight=f(np.ones(t.size) if mask is None else np.asarray(mask, float)),
        dt=f(dt),
        speed_ref=f(np.mean(v) if mask is None else np.mean(v[np.asarray(mask, bool)])),
        duration=f(t[-1] - t[0]),
        k_eps=f(vehicle.k_eps()),
    )
    traction_scale = vehicle.wheel_radius_m * vehicle.locomotive_mass_kg * GRAVITY

    def build(torque, thermal_lag: float = THERMAL_LAG_S) -> Signals:
        torque = np.asarray(torque, float)
        torque_mu = torque / scale
        power = f(np.abs(torque_mu - observer_deriv) * slip * vehicle.axle_weight_n)
        return Signals(
            **fixed,
            torque_mu=f(torque_mu),
            adhesion=f(torque_mu - deriv_mu),
            torque_rate=f(smooth_derivative(t, torque_mu)),
            power=power,
            heat=lowpass_foh(fixed["time"], power, thermal_lag),
            traction_ratio=f(vehicle.n_axles * smooth(torque, dt) / traction_scale),
        )

    return build
