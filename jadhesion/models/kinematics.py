"""Wheel–rail kinematics: slip velocity and creepage with a standstill guard."""

from __future__ import annotations

import jax.numpy as jnp

#: Vehicle speed [m/s] below which creepage is computed against this floor instead (0.036 km/h):
#: creepage is undefined at standstill; the floor keeps it finite and odd in the slip velocity.
SPEED_FLOOR = 0.01


def slip_velocity(wheel_speed, vehicle_speed):
    """Slip velocity ``w = v_w − v`` [m/s] from circumferential and vehicle speeds [m/s]."""
    return jnp.asarray(wheel_speed) - jnp.asarray(vehicle_speed)


def creepage(slip, vehicle_speed, floor=SPEED_FLOOR):
    """Creepage ``s = w / max(|v|, floor)`` [-] from slip velocity ``w`` and vehicle speed [m/s]."""
    return jnp.asarray(slip) / jnp.maximum(jnp.abs(jnp.asarray(vehicle_speed)), floor)
