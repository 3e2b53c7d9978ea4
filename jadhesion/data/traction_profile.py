"""The planned traction (or braking) test of the simulator: the creep reference the slip controller
follows and the speed reference the test load holds.

The creep reference ``s_ref(t)`` [-] starts at the scenario's ``creep_start``, reaches ``creep_base``
by a smoothstep ramp-in, wanders log-normally around it (a sum of :data:`N_WANDER` random sinusoids
in :data:`WANDER_BAND`) and adds cos² slip excursions: the main one peaks at ``max_creep``, up to
:data:`MAX_MINOR` minor ones at random times and heights. A scenario with ``coast_s > 0`` has it
taken to 0 over a coasting gap (:func:`coast_window`). A braking test negates it. The speed
reference is a linear ramp about the scenario's mean speed. ``c`` is the simulator's dict of traced
constants (:func:`.simulator.simulate`).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

#: Number of random sinusoids in the creep wander and their frequency band [Hz].
N_WANDER = 4
WANDER_BAND = (0.05, 0.5)
#: Slots for minor slip excursions (``Scenario.minor_excursions`` of them are used).
MAX_MINOR = 3
#: Length [s] of each cos² edge of a coasting gap (the creep reference's way down and back up).
COAST_EDGE_S = 0.5
#: Candidate centres of a coasting gap as fractions of the test: the one farther from the main
#: excursion is used.
COAST_CENTRES = (0.25, 0.75)


def profile_constants(scenario, duration: float, braking: bool) -> dict:
    """The profile's entries of the simulator's constants (``duration`` [s]): the scenario's
    profile fields, the main excursion's time ``t_main`` [s] (when the speed ramp passes
    ``max_slip / max_creep``, kept within 10–90 % of the test), the minor excursions' mask, the
    sign of the test (−1: braking) and the coasting gap (:func:`coast_window`: ``coast_on`` 0 or 1,
    its centre ``coast_mid`` [s] at the one of :data:`COAST_CENTRES` farther from ``t_main`` and
    its half-length ``coast_half`` [s])."""
    v_exc = scenario.max_slip / scenario.max_creep
    at = 0.5 + (v_exc / scenario.mean_speed - 1.0) / scenario.speed_ramp
    t_main = duration * float(np.clip(at, 0.1, 0.9))
    coast_mid = max((f * duration for f in COAST_CENTRES), key=lambda t: abs(t - t_main))
    return dict(
        duration=duration,
        v_mean=scenario.mean_speed,
        speed_ramp=scenario.speed_ramp,
        creep_base=scenario.creep_base,
        creep_start=scenario.creep_start,
        ramp_time=scenario.ramp_fraction * duration,
        wander=scenario.wander,
        exc_width=scenario.excursion_width_s,
        max_creep=scenario.max_creep,
        t_main=t_main,
        minor_peak=scenario.minor_peak,
        minor_mask=(np.arange(MAX_MINOR) < scenario.minor_excursions).astype(float),
        sign=-1.0 if braking else 1.0,
        coast_on=float(scenario.coast_s > 0),
        coast_mid=coast_mid,
        coast_half=0.5 * scenario.coast_s,
    )


def coast_window(t, c):
    """Share [0, 1] of the creep reference taken away at time ``t`` [s]: 1 over the coasting gap
    ``|t − coast_mid| ≤ coast_half``, cos² edges of :data:`COAST_EDGE_S` on either side, 0 elsewhere
    and everywhere without a gap (``coast_on`` 0)."""
    u = jnp.clip((jnp.abs(t - c["coast_mid"]) - c["coast_half"]) / COAST_EDGE_S, 0.0, 1.0)
    return c["coast_on"] * jnp.cos(0.5 * jnp.pi * u) ** 2


def random_profile(key, c):
    """Random parts of the test profile: wander sinusoids and minor excursions (times, peaks)."""
    kf, kp, kt, kh = jax.random.split(key, 4)
    lo, hi = WANDER_BAND
    freqs = jnp.exp(jax.random.uniform(kf, (N_WANDER,), minval=math.log(lo), maxval=math.log(hi)))
    phases = jax.random.uniform(kp, (N_WANDER,), maxval=2 * jnp.pi)
    minor_t = c["duration"] * jax.random.uniform(kt, (MAX_MINOR,), minval=0.15, maxval=0.95)
    minor_h = c["minor_peak"] * c["max_creep"] * jax.random.uniform(kh, (MAX_MINOR,), minval=0.5, maxval=1.0)
    times = jnp.concatenate([c["t_main"][None], minor_t])
    peaks = jnp.concatenate([c["max_creep"][None], minor_h * c["minor_mask"]])
    return dict(freqs=freqs, phases=phases, exc_times=times, exc_peaks=peaks)


def creep_ref(t, c, prof):
    """Creep reference ``s_ref(t)`` [-]: smoothstep ramp-in, log-normal wander, cos² excursions,
    none over a coasting gap (:func:`coast_window`); negated for a braking test (``c["sign"] = −1``:
    negative creep, adhesion and torque)."""
    x = jnp.clip(t / c["ramp_time"], 0.0, 1.0)
    ramp = x * x * (3.0 - 2.0 * x)
    base = c["creep_start"] + (c["creep_base"] - c["creep_start"]) * ramp
    waves = jnp.sin(2 * jnp.pi * prof["freqs"] * t + prof["phases"])
    wander = math.sqrt(2.0 / N_WANDER) * jnp.sum(waves)
    u = (t - prof["exc_times"]) / c["exc_width"]
    bumps = jnp.where(jnp.abs(u) < 1.0, jnp.cos(0.5 * jnp.pi * u) ** 2, 0.0)
    heights = jnp.maximum(prof["exc_peaks"] - c["creep_base"], 0.0)
    drive = base * jnp.exp(c["wander"] * ramp * wander) + jnp.sum(heights * bumps)
    return c["sign"] * (1.0 - coast_window(t, c)) * drive


def speed_ref(t, c):
    """Speed reference ``v_ref(t)`` [m/s] and slope ``a_ref`` [m/s²] (linear ramp about v_mean)."""
    a_ref = c["v_mean"] * c["speed_ramp"] / c["duration"]
    return c["v_mean"] + a_ref * (t - 0.5 * c["duration"]), a_ref
