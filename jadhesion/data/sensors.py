"""Sensor model of the simulator: what the wheel-speed, vehicle-speed and torque channels add.

Each recorded speed channel ``y`` [m/s] is the true signal ``x`` plus white and coloured noise,
then quantised to the channel's resolution ``q``:

    y_k = q · round((x_k + σ_w e_k + c_k) / q),      c_k = ρ c_{k−1} + σ_c √(1 − ρ²) e'_k,

with ``e, e'`` independent standard normals, ``ρ = exp(−Δt/τ_c)`` (an AR(1) process, the sampled
Ornstein–Uhlenbeck process of stationary standard deviation ``σ_c`` and correlation time ``τ_c``),
``c_0`` drawn from the stationary law. Torque [N·m] gets white noise ``σ_T`` and resolution ``q_T``.
``q = 0`` means no quantisation. Wheel and vehicle speed have independent noise of the same model.

**Realistic defaults** (:data:`REALISTIC`; the issue's survey: wheel/vehicle speed sensors at
walking pace deliver 1e-3–1e-2 m/s plus quantisation): white ``σ_w = 1e-3`` m/s, coloured
``σ_c = 5e-4`` m/s with ``τ_c = 0.1`` s (pulse-timing jitter and tooth-pitch error are correlated
over a few samples), resolution ``q = 1e-3`` m/s (a speed word of 1 mm/s); torque resolution 10 N·m.
The torque's white noise is the scenario's calibrated ``torque_noise`` (it sets the paper's model
error). Sampling is the simulator's :data:`jadhesion.data.simulator.SAMPLE_PERIOD` (50 Hz).
``"clean"`` (:data:`CLEAN`) is the historical model: white speed noise 5e-5 m/s, no colour, no
quantisation — the one the Table 2 calibration was made on. ``sensor_noise`` scales every noise
level and resolution of the chosen model (0: noise-free sensors).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp


class SensorModel(NamedTuple):
    """Noise of the recorded channels (a pytree: the simulator traces it). Units in the names."""

    speed_white_mps: float
    speed_colour_mps: float
    speed_colour_time_s: float
    speed_quantum_mps: float
    torque_white_nm: float
    torque_quantum_nm: float

    def scaled(self, factor: float) -> "SensorModel":
        """Every noise level and resolution times ``factor`` (the correlation time kept)."""
        return self._replace(
            speed_white_mps=self.speed_white_mps * factor,
            speed_colour_mps=self.speed_colour_mps * factor,
            speed_quantum_mps=self.speed_quantum_mps * factor,
            torque_white_nm=self.torque_white_nm * factor,
            torque_quantum_nm=self.torque_quantum_nm * factor,
        )

    def speed_sd(self) -> float:
        """Total standard deviation of one speed channel [m/s] (white, colour, ``q/√12``)."""
        return math.sqrt(
            self.speed_white_mps**2 + self.speed_colour_mps**2 + self.speed_quantum_mps**2 / 12.0
        )

    def as_dict(self) -> dict:
        """JSON-ready fields."""
        return {k: float(v) for k, v in self._asdict().items()}


#: Realistic speed sensors (torque white noise filled in from the scenario).
REALISTIC = SensorModel(1e-3, 5e-4, 0.1, 1e-3, 0.0, 10.0)
#: The historical white-noise model (Table 2 calibration).
CLEAN = SensorModel(5e-5, 0.0, 0.1, 0.0, 0.0, 0.0)
PRESETS = {"realistic": REALISTIC, "clean": CLEAN}


def sensor_model(preset, torque_noise_nm: float, sensor_noise: float = 1.0) -> SensorModel:
    """The :class:`SensorModel` of a preset name (or a model) with the scenario's torque noise
    [N·m] (used when the model's is 0), scaled by ``sensor_noise`` (≥ 0)."""
    if isinstance(preset, str):
        if preset not in PRESETS:
            raise ValueError(f"unknown sensor model {preset!r}; expected one of {tuple(PRESETS)}")
        preset = PRESETS[preset]
    if not sensor_noise >= 0.0:
        raise ValueError(f"sensor_noise must be >= 0, got {sensor_noise}")
    if preset.torque_white_nm == 0.0:
        preset = preset._replace(torque_white_nm=float(torque_noise_nm))
    return preset.scaled(float(sensor_noise))


def quantise(x, quantum):
    """``q · round(x / q)``, or ``x`` where ``q = 0``."""
    safe = jnp.where(quantum > 0, quantum, 1.0)
    return jnp.where(quantum > 0, safe * jnp.round(x / safe), x)


def ar1_noise(key, n: int, sd, time_s, dt):
    """Stationary AR(1) noise (n,) of standard deviation ``sd`` and correlation time ``time_s`` [s]
    at sample period ``dt`` [s]."""
    return ar1_path(jax.random.normal(key, (n,)), jnp.exp(-dt / time_s), sd)


def ar1_path(e, rho, sd):
    """Stationary AR(1) path (n,) of standard deviation ``sd`` and lag-one correlation ``rho`` from
    standard normal draws ``e`` (n,): ``c_0 = sd e_0``, ``c_k = rho c_{k−1} + sd √(1 − rho²) e_k``
    (``lax.scan``)."""
    innov = sd * jnp.sqrt(1.0 - rho * rho) * e[1:]

    def step(c, eps):
        c = rho * c + eps
        return c, c

    _, rest = jax.lax.scan(step, sd * e[0], innov)
    return jnp.concatenate([sd * e[:1], rest])


def speed_channel(key, x, model: SensorModel, dt):
    """One recorded speed channel [m/s] from the true speed ``x`` (n,)."""
    kw, kc = jax.random.split(key)
    noisy = (
        x
        + model.speed_white_mps * jax.random.normal(kw, x.shape)
        + ar1_noise(kc, x.shape[0], model.speed_colour_mps, model.speed_colour_time_s, dt)
    )
    return quantise(noisy, model.speed_quantum_mps)


def measure(key, wheel_speed, vehicle_speed, torque, model: SensorModel, dt):
    """Recorded ``(wheel_speed, vehicle_speed, torque)`` from the true signals (each (n,)); pure."""
    kw, kv, kt = jax.random.split(key, 3)
    torque = quantise(
        torque + model.torque_white_nm * jax.random.normal(kt, torque.shape), model.torque_quantum_nm
    )
    return (speed_channel(kw, wheel_speed, model, dt), speed_channel(kv, vehicle_speed, model, dt), torque)
