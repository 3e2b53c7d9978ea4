"""A third recording generator, kinematic: prescribed motion, the torque it needed, a logger's file.

``jadhesion.data.simulator`` and :mod:`validation.foreign_generator` integrate wheelset and train
dynamics under a controller at test-run speeds. This one prescribes the motion instead — the
vehicle speed and the creep as smooth functions of time — and derives the wheelset torque that
motion needed, ``T = μ(s, w) m g r + J ω̇`` (Polach's law and the vehicles of
:mod:`validation.foreign.physics`), so it reaches what the others do not: mainline speeds, long
braking, constant-speed creep sweeps. Its sensors are a logger's: white noise on both speeds and
the torque, quantised as the file writes them — vehicle speed in km/h (0.01), wheel speed in rpm
(0.05), torque in kN·m (0.01), time in ms since the Unix epoch — under German column names in a
semicolon-separated file with decimal commas; the sidecar maps the columns and holds the vehicle.

Profiles (``kind``), over ``duration_s``, ``u = t / duration_s``:

- ``"mainline"``: v = 20 → 30 m/s, creep 0.1 % + 3 % sin²(π u) (slip up to 0.9 m/s);
- ``"braking"``: v = 25 → 7 m/s, creep −(0.1 % + 2.5 % sin²(π u));
- ``"walk"``: v = 0.6 → 0.9 m/s, creep 0.05 % + 0.8 % sin²(π u) (the source papers' test pace);
- ``"sweeps"``: v = 12 m/s, creep 0.05 % + 2 % |sin(3π u)| (three sweeps, each reversing sharply
  at its low end: a step in the slip rate).

Concealed effects (``effect``, ``magnitude`` in jadhesion's catalogue units, prescribed here from
their physics, not from :mod:`jadhesion.models.effects`): ``"rail_change"`` — μ0 → μ0 (1 − m) from
:data:`CHANGE_AT` of the run on (a hard step); ``"wheel_radius_error"`` — the true rolling radius is
r (1 + m) while the sidecar states r, so the logged rpm and the torque follow the true radius;
``"torque_offset"`` — the logged torque is T + m · m_axle g r.

API: :func:`generate` → :class:`KinematicRecording`, :func:`write` (CSV, sidecar, truth).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from validation.foreign import physics

NAME, VERSION = "jadhesion-kinematic-generator", "1.1"
KINDS = ("mainline", "braking", "walk", "sweeps")
EFFECTS = ("none", "rail_change", "wheel_radius_error", "torque_offset")
#: Time of the rail change as a fraction of the run [-].
CHANGE_AT = 0.6
#: Dry rail of paper 001's 22E fit (kA, kS, μ0, A, B).
DRY = physics.CONDITIONS["dry_22e"]
#: The logger's columns: (header, unit, quantisation step in that unit).
COLUMNS = {
    "time": ("Zeit_ms", "ms", 1.0),
    "vehicle_speed": ("v_Lok", "km/h", 0.01),
    "wheel_speed": ("n_Rad", "rpm", 0.05),
    "traction_torque": ("M_Rad", "kN*m", 0.01),
}
EPOCH_MS = 1.7e12


class KinematicRecording(NamedTuple):
    """``columns``: the logger's columns by header, in its units; ``sidecar``: vehicle keys and the
    column map; ``truth``: Polach parameters, profile and sensor settings; ``latent``: time [s],
    vehicle_speed, slip [m/s], creep [-], mu [-] along the prescribed motion."""

    columns: dict
    sidecar: dict
    truth: dict
    latent: dict


def motion(kind: str, t, duration_s: float) -> tuple:
    """``(v [m/s], creep [-])`` of profile ``kind`` at times ``t`` [s] (module docstring)."""
    u = np.asarray(t, float) / duration_s
    if kind == "mainline":
        return 20.0 + 10.0 * u, 0.001 + 0.03 * np.sin(np.pi * u) ** 2
    if kind == "braking":
        return 25.0 - 18.0 * u, -(0.001 + 0.025 * np.sin(np.pi * u) ** 2)
    if kind == "walk":
        return 0.6 + 0.3 * u, 0.0005 + 0.008 * np.sin(np.pi * u) ** 2
    if kind == "sweeps":
        return np.full_like(u, 12.0), 0.0005 + 0.02 * np.abs(np.sin(3.0 * np.pi * u))
    raise ValueError(f"unknown kind {kind!r}; choose one of {', '.join(KINDS)}")


def phase(kind: str) -> str:
    """The ``--phase`` profile ``kind`` is fitted and diagnosed with: its creep's sign."""
    return "braking" if kind == "braking" else "traction"


def random_settings(rng: np.random.Generator) -> dict:
    """Keyword arguments of :func:`generate` for a random clean run, drawn from ``rng`` in this
    order: Polach parameters (``physics.random_params``), vehicle, logger rate (20, 50, 100 or
    200 Hz) and white speed noise (0.002–0.02 m/s, log-uniform)."""
    return {
        "params": tuple(physics.random_params(rng).values()),
        "vehicle": str(rng.choice(sorted(physics.VEHICLES))),
        "rate_hz": float(rng.choice([20.0, 50.0, 100.0, 200.0])),
        "speed_noise": float(np.exp(rng.uniform(np.log(0.002), np.log(0.02)))),
    }


def generate(
    seed: int,
    kind: str = "mainline",
    *,
    params=DRY,
    vehicle: str = "bobo_20t",
    rate_hz: float = 50.0,
    duration_s: float = 120.0,
    speed_noise: float = 0.01,
    torque_noise_nm: float = 300.0,
    effect: str = "none",
    magnitude: float = 0.0,
) -> KinematicRecording:
    """One recording of profile ``kind``; deterministic in ``seed``.

    Args:
        params: Polach (kA, kS, μ0, A, B); vehicle: a name in ``physics.VEHICLES``.
        rate_hz: logger rate [Hz]; duration_s [s].
        speed_noise: white noise sd of each speed sensor [m/s]; torque_noise_nm: of the torque [N·m].
        effect: one of :data:`EFFECTS`, of size ``magnitude`` (module docstring).
    """
    if effect not in EFFECTS:
        raise ValueError(f"unknown effect {effect!r}; choose one of {', '.join(EFFECTS)}")
    rng = np.random.default_rng(seed)
    veh = physics.VEHICLES[vehicle]
    r, k_eps = veh.wheel_radius_m, veh.k_eps()
    r_true = r * (1.0 + magnitude) if effect == "wheel_radius_error" else r
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    v, creep = motion(kind, t, duration_s)
    slip = v * creep
    changed = (effect == "rail_change") & (t >= CHANGE_AT * duration_s)
    mu0 = np.where(changed, params[2] * (1.0 - magnitude), params[2])
    mu = np.array(
        [
            physics.polach(c, w, params[0], params[1], m0, params[3], params[4], k_eps)
            for c, w, m0 in zip(creep, slip, mu0, strict=True)
        ]
    )
    omega = (v + slip) / r_true
    torque = mu * veh.axle_weight_n * r_true + veh.wheelset_inertia_kgm2 * np.gradient(omega, t)
    if effect == "torque_offset":
        torque = torque + magnitude * veh.axle_weight_n * r

    def logged(x, key):
        step = COLUMNS[key][2]
        return np.round(x / step) * step

    signals = {  # in the logger's units (COLUMNS)
        "time": EPOCH_MS + 1e3 * t,
        "vehicle_speed": 3.6 * (v + speed_noise * rng.standard_normal(t.size)),
        "wheel_speed": 60.0 / (2.0 * math.pi) * (omega + speed_noise / r * rng.standard_normal(t.size)),
        "traction_torque": (torque + torque_noise_nm * rng.standard_normal(t.size)) / 1e3,
    }
    columns = {COLUMNS[key][0]: logged(x, key) for key, x in signals.items()}
    sidecar = veh.sidecar() | {"columns": {k: f"{h}[{u}]" for k, (h, u, _) in COLUMNS.items()}}
    truth = {
        "generator": NAME,
        "version": VERSION,
        "seed": seed,
        "kind": kind,
        "params": dict(zip(physics.PARAM_NAMES, map(float, params), strict=True)),
        "vehicle": vehicle,
        "rate_hz": rate_hz,
        "duration_s": duration_s,
        "speed_noise_m_s": speed_noise,
        "torque_noise_nm": torque_noise_nm,
        "effect": effect,
        "magnitude": magnitude if effect != "none" else None,
        "change_time_s": CHANGE_AT * duration_s if effect == "rail_change" else None,
    }
    latent = {"time": t, "vehicle_speed": v, "slip": slip, "creep": creep, "mu": mu}
    return KinematicRecording(columns, sidecar, truth, latent)


def write(rec: KinematicRecording, path) -> Path:
    """The CSV at ``path`` (``;``-separated, decimal commas), ``<stem>.json`` (sidecar) and
    ``<stem>.truth.json``; returns the CSV's path."""
    path = Path(path)
    names = list(rec.columns)
    rows = [";".join(names)]
    for values in zip(*(rec.columns[n] for n in names), strict=True):
        time_ms, *rest = values
        rows.append(";".join([f"{int(time_ms)}", *(f"{x:.2f}".replace(".", ",") for x in rest)]))
    path.write_text("\n".join(rows) + "\n")
    path.with_suffix(".json").write_text(json.dumps(rec.sidecar, indent=1))
    path.with_name(path.stem + ".truth.json").write_text(json.dumps(rec.truth, indent=1))
    return path
