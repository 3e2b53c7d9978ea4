"""Logger-style recordings the tests write: standstill, traction, coasting, braking and a gap,
in SI and as a logger writes them (German names, ms, km/h, rpm, kN·m)."""

import math

import numpy as np

from jadhesion.data.recording import save_recording
from jadhesion.data.vehicle import LOCO_22E

R = LOCO_22E.wheel_radius_m
SCALE = LOCO_22E.axle_weight_n * R  # N·m for mu = 1
LOGGER_MAP = [
    "time=t_ms[ms]",
    "vehicle_speed=v_Lok_kmh[km/h]",
    "wheel_speed=n_Rad[rpm]",
    "traction_torque=M_Rad_kNm[kNm]",
]
#: (label, samples, vehicle speed [m/s], creep [-], mu [-]) at 100 Hz; a 2 s gap before the last.
PIECES = [
    ("standstill", 100, 0.0, 0.0, 0.0),
    ("traction", 400, 2.0, 0.01, 0.3),
    ("coasting", 100, 2.0, 0.0, 0.0),
    ("braking", 300, 2.0, -0.01, -0.3),
    ("traction", 300, 3.0, 0.01, 0.3),
]
GAP_SAMPLES = 200


def stretches_si(seed=0):
    """SI columns of :data:`PIECES` (small white noise on speeds and torque)."""
    rng = np.random.default_rng(seed)
    t, v, s, mu, k = [], [], [], [], 0
    for i, (_, m, speed, creep, adhesion) in enumerate(PIECES):
        k += GAP_SAMPLES if i == len(PIECES) - 1 else 0
        t.append((k + np.arange(m)) * 0.01)
        k += m
        ramp = np.linspace(0.0, 1.0, m)
        v.append(np.full(m, speed) * (1.0 + 0.05 * ramp))
        s.append(np.full(m, creep) * (1.0 + ramp))
        mu.append(np.full(m, adhesion))
    t, v, s, mu = map(np.concatenate, (t, v, s, mu))
    n = t.size
    return {
        "time": t,
        "vehicle_speed": v + 1e-4 * rng.standard_normal(n) * (v != 0),
        "wheel_speed": v * (1 + s) + 1e-4 * rng.standard_normal(n) * (v != 0),
        "traction_torque": (mu + 1e-3 * rng.standard_normal(n) * (mu != 0)) * SCALE,
    }


def swapped_stretches():
    """:func:`stretches_si` with wheel and vehicle speed exchanged on both traction stretches
    (samples 100–499 and 900 on): 700 of its 1100 moving samples have the wheel slower than the
    vehicle under traction, as when a logger's two speed columns are swapped."""
    cols = stretches_si()
    index = np.arange(cols["time"].size)
    which = (index >= 100) & ((index < 500) | (index >= 900))
    cols["vehicle_speed"], cols["wheel_speed"] = (
        np.where(which, cols["wheel_speed"], cols["vehicle_speed"]),
        np.where(which, cols["vehicle_speed"], cols["wheel_speed"]),
    )
    return cols


def logger_columns(cols):
    """The same columns as a logger names and scales them."""
    return {
        "t_ms": cols["time"] * 1e3,
        "v_Lok_kmh": cols["vehicle_speed"] * 3.6,
        "n_Rad": cols["wheel_speed"] / R * 60 / (2 * math.pi),
        "M_Rad_kNm": cols["traction_torque"] / 1e3,
    }


def write_logger_file(path, seed=0):
    """A logger CSV of :func:`stretches_si` with its sidecar (22E, column map); returns the path."""
    return save_recording(
        logger_columns(stretches_si(seed)),
        LOCO_22E,
        path,
        extra_sidecar={"columns": dict(s.split("=") for s in LOGGER_MAP)},
    )
