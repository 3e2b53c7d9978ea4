"""An independent recording generator: a second test bed beside ``jadhesion.data.simulator``.

Written from the physics (DESIGN §1, paper 001) without importing or reading jadhesion: its own
Polach law, Hertz/Kalker contact and vehicles (:mod:`validation.foreign.physics`), its own wheelset
and train dynamics, controller, driving profiles and concealed effects
(:mod:`validation.foreign.dynamics`) and its own sensor model (:mod:`validation.foreign.sensors`).
Output follows the recording contract (DESIGN §3): CSV ``time,vehicle_speed,wheel_speed,
traction_torque`` [s, m/s, m/s at the nominal radius, N·m at the wheelset], a sidecar
``<stem>.json`` with the vehicle and contact keys, and ``<stem>.truth.json``.

API: :func:`generate` → :class:`ForeignRecording`, :func:`write`. CLI (a blind set + answer key)::

    python -m validation.foreign_generator --n 16 --out DIR [--seed S] [--effects all|none|a,b]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from validation.foreign import dynamics, physics, sensors

NAME, VERSION = "jadhesion-foreign-generator", "1.0"
RATES_HZ = (20.0, 25.0, 50.0, 100.0, 125.0, 200.0)
EFFECT_NAMES = tuple(dynamics.EFFECTS)


class ForeignRecording(NamedTuple):
    """``columns`` (contract CSV columns), ``sidecar`` (vehicle keys), ``truth`` (JSON-ready
    description of the run) and ``latent`` (noise-free signals at the true sampling instants:
    time [s], vehicle_speed, wheel_speed (ω·r_nom), wheel_speed_true (ω·r_true), slip [m/s],
    creep [-], omega [rad/s], omega_dot [rad/s²], v_dot [m/s²], torque (applied) and
    torque_logged (delayed/offset, before noise) [N·m], force (adhesion force of one axle) and load
    (axle load) [N], mu_adh = force/load, mu_obs = force·r_true/(Q_nom·r_nom) (what an exact
    observer with the nominal constants sees), mu0_eff, heat [W], load_frac [-])."""

    columns: dict
    sidecar: dict
    truth: dict
    latent: dict


def _params(params, rng) -> dict:
    if params is None:
        return physics.random_params(rng)
    if not isinstance(params, dict):
        params = dict(zip(physics.PARAM_NAMES, params, strict=True))
    return {k: float(params[k]) for k in physics.PARAM_NAMES}


def generate(
    seed,
    *,
    params=None,
    effect="none",
    magnitude=None,
    vehicle=None,
    profile=None,
    rate_hz=None,
    duration_s=None,
    sensor=None,
) -> ForeignRecording:
    """Simulate one recording; deterministic in ``seed`` and the arguments.

    Args:
        seed: integer seed; independent streams feed parameters, profile, effect and sensors, so
            fixing one argument leaves the others' draws unchanged.
        params: Polach {kA, kS, mu0, A, B} (dict or 5-sequence); default random around a condition.
        effect: one of :data:`EFFECT_NAMES`; magnitude: its size (units in
            ``dynamics.EFFECTS``), default random in the typical range.
        vehicle: a name in ``physics.VEHICLES`` or a ``ForeignVehicle``; default random.
        profile: ``"start"``, ``"sweep"``, ``"steady"`` or a ``dynamics.Plan``; default random.
        rate_hz: logger rate [Hz], default one of :data:`RATES_HZ`; duration_s [s], default 60.
        sensor: ``"clean"``, ``"mild"``, ``"realistic"`` (default) or a settings dict.
    """
    if effect not in dynamics.EFFECTS:
        raise ValueError(f"unknown effect {effect!r}; expected one of {EFFECT_NAMES}")
    r_par, r_plan, r_eff, r_sens, r_noise, r_pick = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(6)
    )
    params = _params(params, r_par)
    if vehicle is None:
        vehicle = str(r_pick.choice(sorted(physics.VEHICLES)))
    veh = physics.VEHICLES[vehicle] if isinstance(vehicle, str) else vehicle
    duration = 60.0 if duration_s is None else float(duration_s)
    rate = float(r_pick.choice(RATES_HZ)) if rate_hz is None else float(rate_hz)
    if profile is None:
        profile = str(r_pick.choice(dynamics.PROFILES))
    plan = dynamics.make_plan(profile, r_plan, duration) if isinstance(profile, str) else profile
    if effect == "none":
        magnitude, detail = 0.0, {}
    elif magnitude is None:
        magnitude, detail = dynamics.random_effect(effect, r_eff, duration)
    else:
        magnitude = float(magnitude)
        detail = dynamics.effect_detail(effect, magnitude, r_eff, duration)
    world = dynamics.World(veh, params, plan, effect, magnitude, detail)
    fine = dynamics.simulate(world, duration)
    sens = sensors.settings(sensor, r_sens, rate)
    t = sensors.sample_times(duration, rate, sens["jitter_s"], r_noise)
    latent = {k: np.interp(t, fine["time"], val) for k, val in fine.items()}
    latent["wheel_speed"] = latent["omega"] * veh.wheel_radius_m
    latent["wheel_speed_true"] = latent["omega"] * world.r_true
    latent["mu_adh"] = latent["force"] / latent["load"]
    latent["mu_obs"] = latent["force"] * world.r_true / (veh.axle_weight_n * veh.wheel_radius_m)
    delay = magnitude if effect == "signal_delay" else 0.0
    offset = magnitude * veh.axle_weight_n * veh.wheel_radius_m if effect == "torque_offset" else 0.0
    latent["torque_logged"] = np.interp(np.maximum(t - delay, 0.0), fine["time"], fine["torque"]) + offset
    columns = {"time": sensors.quantise(t, sens["time_quantum_s"])}
    for name, truth_signal in (
        ("vehicle_speed", latent["vehicle_speed"]),
        ("wheel_speed", latent["wheel_speed"]),
        ("traction_torque", latent["torque_logged"]),
    ):
        columns[name] = sensors.measure(truth_signal, sens[name], rate, r_noise)
    vdict = {
        k: (None if isinstance(v, float) and math.isinf(v) else v) for k, v in dataclasses.asdict(veh).items()
    }
    truth = {
        "generator": NAME,
        "version": VERSION,
        "seed": seed,
        "params": params,
        "effect": effect,
        "magnitude": magnitude,
        "magnitude_unit": dynamics.EFFECTS[effect].unit,
        "effect_detail": detail,
        "effect_doc": dynamics.EFFECTS[effect].doc,
        "torque_offset_nm": offset,
        "true_wheel_radius_m": world.r_true,
        "vehicle": {
            **vdict,
            "c11": veh.c11(),
            "k_eps": veh.k_eps(),
            "contact_semi_axes_m": list(veh.semi_axes()),
        },
        "contact_note": "c11 from a coarse excerpt of Kalker's Table E.3 (steps 0.2 in a/b), "
        "linear in ln(a/b) and nu; jadhesion's finer table differs by < 1 %",
        "creep_floor_m_s": dynamics.V_FLOOR,
        "profile": {**dataclasses.asdict(plan)},
        "sensor": sens,
        "rate_hz": rate,
        "duration_s": duration,
        "n_samples": int(t.size),
    }
    return ForeignRecording(columns, veh.sidecar(), truth, latent)


def write(recording: ForeignRecording, path, *, truth: bool = True) -> Path:
    """Write ``path`` (CSV), ``<stem>.json`` (sidecar) and, with ``truth``, ``<stem>.truth.json``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = ("time", "vehicle_speed", "wheel_speed", "traction_torque")
    data = np.column_stack([recording.columns[c] for c in cols])
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
    path.with_suffix(".json").write_text(json.dumps(recording.sidecar, indent=1))
    if truth:
        path.with_suffix(".truth.json").write_text(json.dumps(recording.truth, indent=1))
    return path


def main(argv=None) -> int:
    """Write a blind set: ``rec_NNN.csv`` (+ sidecars) in shuffled effect order, and
    ``answer_key.json`` mapping each file to its truth."""
    ap = argparse.ArgumentParser(
        prog="python -m validation.foreign_generator", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--effects", default="all", help="all, none, or a comma-separated list")
    ap.add_argument("--duration", type=float, default=None, help="seconds (default 60)")
    args = ap.parse_args(argv)
    effects = EFFECT_NAMES if args.effects == "all" else tuple(args.effects.split(","))
    unknown = [e for e in effects if e not in dynamics.EFFECTS]
    if unknown:
        ap.error(f"unknown effect(s) {', '.join(unknown)}; expected {', '.join(EFFECT_NAMES)}")
    order = np.random.default_rng(args.seed).permutation([effects[i % len(effects)] for i in range(args.n)])
    out = Path(args.out)
    key = {"generator": NAME, "version": VERSION, "seed": args.seed, "files": {}}
    for i, effect in enumerate(order):
        rec = generate(args.seed * 100003 + i, effect=str(effect), duration_s=args.duration)
        name = f"rec_{i:03d}.csv"
        write(rec, out / name, truth=False)
        key["files"][name] = rec.truth
        print(f"{name}: {len(rec.columns['time'])} samples")
    (out / "answer_key.json").write_text(json.dumps(key, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
