"""Sensor model of the foreign generator (its own, unlike jadhesion's simulator).

Each of the three measured channels gets ``white`` Gaussian noise plus a stationary AR(1)
(coloured) component of standard deviation ``ar`` and correlation time ``ar_tau_s``
(``x_k = φ x_{k−1} + sqrt(1−φ²)·ar·e_k``, ``φ = exp(−Δt/ar_tau_s)``), then quantisation to
multiples of ``quantum`` (rounding; adds ``quantum²/12`` of variance). Units: m/s for the speeds,
N·m for the torque. The sampling instants jitter by ``jitter_s`` (Gaussian, clipped to ±0.3 Δt);
the logged time is the true instant rounded to ``time_quantum_s`` (the fourth noisy signal).

Presets: ``"clean"`` (nothing), ``"mild"`` (fixed, small), ``"realistic"`` (default; every level
drawn log-uniformly from :data:`REALISTIC`, walking-pace speed sensors 1e-3–1e-2 m/s).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

CHANNELS = ("vehicle_speed", "wheel_speed", "traction_torque")

MILD = {
    "vehicle_speed": {"white": 1e-3, "ar": 1e-3, "ar_tau_s": 0.5, "quantum": 1e-3},
    "wheel_speed": {"white": 1e-3, "ar": 5e-4, "ar_tau_s": 0.2, "quantum": 1e-3},
    "traction_torque": {"white": 40.0, "ar": 20.0, "ar_tau_s": 0.3, "quantum": 10.0},
    "jitter_s": 0.0,
    "time_quantum_s": 1e-4,
}

#: Ranges (low, high) of the realistic preset, drawn log-uniformly (jitter: fraction of Δt).
REALISTIC = {
    "vehicle_speed": {
        "white": (1e-3, 6e-3),
        "ar": (5e-4, 5e-3),
        "ar_tau_s": (0.2, 2.0),
        "quantum": (1e-3, 5e-3),
    },
    "wheel_speed": {
        "white": (1e-3, 6e-3),
        "ar": (3e-4, 3e-3),
        "ar_tau_s": (0.1, 1.0),
        "quantum": (1e-3, 5e-3),
    },
    "traction_torque": {
        "white": (20.0, 150.0),
        "ar": (10.0, 100.0),
        "ar_tau_s": (0.1, 1.0),
        "quantum": (10.0, 100.0),
    },
    "jitter_fraction": (1e-3, 0.05),
}


def settings(spec, rng: np.random.Generator, rate_hz: float) -> dict:
    """Resolve ``spec`` (a preset name, a full settings dict, or None → realistic) to settings."""
    if isinstance(spec, dict):
        return {**MILD, **spec}
    if spec in (None, "realistic"):
        out = {
            ch: {
                k: float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
                for k, (lo, hi) in REALISTIC[ch].items()
            }
            for ch in CHANNELS
        }
        frac = REALISTIC["jitter_fraction"]
        out["jitter_s"] = float(math.exp(rng.uniform(*np.log(frac)))) / rate_hz
        out["time_quantum_s"] = 1e-4
        return out
    if spec == "mild":
        return {k: (dict(v) if isinstance(v, dict) else v) for k, v in MILD.items()}
    if spec == "clean":
        zero = {"white": 0.0, "ar": 0.0, "ar_tau_s": 1.0, "quantum": 0.0}
        return {**{ch: dict(zero) for ch in CHANNELS}, "jitter_s": 0.0, "time_quantum_s": 0.0}
    raise ValueError(f"unknown sensor preset {spec!r}; expected clean, mild, realistic or a dict")


def sample_times(duration: float, rate_hz: float, jitter_s: float, rng) -> np.ndarray:
    """True sampling instants [s]: a uniform clock at ``rate_hz`` with clipped Gaussian jitter."""
    dt = 1.0 / rate_hz
    nominal = np.arange(int(duration * rate_hz) + 1) * dt
    jitter = np.clip(rng.normal(0.0, 1.0, nominal.size) * jitter_s, -0.3 * dt, 0.3 * dt)
    jitter[0] = max(jitter[0], 0.0)
    times = nominal + jitter
    return times[times <= duration]


def quantise(x: np.ndarray, quantum: float) -> np.ndarray:
    """Round to multiples of ``quantum`` (identity for quantum 0)."""
    return np.round(x / quantum) * quantum if quantum > 0 else x


def measure(truth: np.ndarray, channel: dict, rate_hz: float, rng) -> np.ndarray:
    """One channel as logged: truth + white + AR(1) noise, quantised (see the module docstring)."""
    n = truth.size
    phi = math.exp(-1.0 / (rate_hz * channel["ar_tau_s"]))
    drive = rng.normal(0.0, 1.0, n) * channel["ar"]
    scale = math.sqrt(1.0 - phi * phi)  # stationary start: coloured[0] = drive[0]
    coloured, _ = lfilter([scale], [1.0, -phi], drive, zi=[drive[0] * (1.0 - scale)])
    noisy = truth + rng.normal(0.0, 1.0, n) * channel["white"] + coloured
    return quantise(noisy, channel["quantum"])
