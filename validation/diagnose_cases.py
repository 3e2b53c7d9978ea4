"""Simulated cases for calibration and the blind benchmark, and the null calibration itself.

Test- and benchmark-only (the library never imports it). ``python -m validation.diagnose_cases
[--n N]`` diagnoses N clean simulated recordings (random
scenario, seed and vehicle) and prints the 95th percentiles of the largest round-1 held-out gain and
of the generic term's gain: the values behind :data:`.select.GAIN_THRESHOLD` and
:data:`.select.GENERIC_THRESHOLD`.

Every case goes through a CSV and its sidecar (vehicle keys only — nothing of the truth), read back
by the CLI's own loader, so the diagnoser sees exactly what a user's file would give it.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from jadhesion.cli.common import Progress
from jadhesion.cli.diagnose_run import diagnose_file
from jadhesion.config import enable_compilation_cache, enable_x64
from jadhesion.data.recording import save_recording
from jadhesion.data.scenarios import get_scenario
from jadhesion.data.simulator import simulate
from jadhesion.data.vehicle import LOCO_22E
from jadhesion.models.effects import EFFECTS

#: Log-uniform magnitude ranges |m| per effect for random cases (simulator units), and the effects
#: whose sign is drawn at random: both from the effect registry (:mod:`jadhesion.models.effects`).
MAGNITUDE_RANGE = {name: spec.typical for name, spec in EFFECTS.items()}
SIGNED = {name for name, spec in EFFECTS.items() if spec.signed}
SCENARIOS = ("dry", "wet", "sand")


#: Samples per recording of a varied driving profile (the default profile has the simulator's
#: default, 2000 = 40 s).
VARIED_SAMPLES = (1500, 2000, 2500, 3000)


def random_vehicle(rng, p_varied: float = 0.5):
    """The 22E, or (with probability ``p_varied``) a variant: worn wheel radius 0.57–0.61 m,
    inertia ±25 %, axle load 18–23 t (locomotive mass six axle loads)."""
    if rng.random() >= p_varied:
        return LOCO_22E, False
    axle = float(rng.uniform(18000.0, 23000.0))
    return LOCO_22E.replace(
        wheel_radius_m=float(rng.uniform(0.57, 0.61)),
        wheelset_inertia_kgm2=float(rng.uniform(2250, 3750)),
        axle_load_kg=axle,
        locomotive_mass_kg=6.0 * axle,
    ), True


def random_profile(rng, name: str, p_varied: float = 0.0):
    """``(scenario, n_samples, varied)``: the named test as published, or (with probability
    ``p_varied``) a different driving profile and friction condition — mean speed ×0.6–1.8, speed
    ramp 0.2–0.8, creep level ×0.6–1.6, wander 0.1–0.4, 0–3 minor excursions, each Polach
    parameter ×0.8–1.2 (clipped to the box), 1500–3000 samples."""
    base = get_scenario(name)
    if rng.random() >= p_varied:
        return base, None, False
    params = tuple(float(np.clip(p * rng.uniform(0.8, 1.2), 0.0, 1.0)) for p in base.params)
    scenario = base.replace(
        params=params,
        mean_speed_kmh=base.mean_speed_kmh * float(rng.uniform(0.6, 1.8)),
        speed_ramp=float(rng.uniform(0.2, 0.8)),
        creep_base=base.creep_base * float(rng.uniform(0.6, 1.6)),
        wander=float(rng.uniform(0.1, 0.4)),
        minor_excursions=int(rng.integers(0, 4)),
    )
    return scenario, int(rng.choice(VARIED_SAMPLES)), True


def random_effects(rng, names, upper=None) -> list:
    """``[(name, magnitude)]`` with log-uniform magnitudes from :data:`MAGNITUDE_RANGE`, or with
    ``upper = (f, g)`` from ``[f, g]`` × the top of that range."""
    out = []
    for name in names:
        lo, hi = MAGNITUDE_RANGE[name]
        if upper is not None:
            lo, hi = upper[0] * hi, upper[1] * hi
        m = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        out.append((name, m * (rng.choice([-1.0, 1.0]) if name in SIGNED else 1.0)))
    return out


def run_case(
    effects,
    rng,
    directory,
    n_samples=None,
    p_varied_profile: float = 0.0,
    p_varied_vehicle: float = 0.5,
    coast_s: float = 0.0,
) -> dict:
    """Simulate one recording (with a coasting gap of ``coast_s`` [s], :attr:`Scenario.coast_s`;
    no random draw of its own, so a seed gives the same cases either way), write CSV + sidecar into
    ``directory``, diagnose it through the CLI code path; returns the truth and the diagnosis
    (without its arrays)."""
    name = str(rng.choice(SCENARIOS))
    seed = int(rng.integers(0, 2**31 - 1))
    vehicle, varied = random_vehicle(rng, p_varied_vehicle)
    scenario, n_varied, profile_varied = random_profile(rng, name, p_varied_profile)
    n = n_varied if profile_varied else n_samples
    sim = simulate(scenario.replace(coast_s=coast_s), seed, effects, n, vehicle=vehicle)
    raw = {k: sim.columns[k] for k in ("time", "vehicle_speed", "wheel_speed", "traction_torque")}
    path = save_recording(raw, sim.vehicle, Path(directory) / f"case_{seed}.csv")
    start = time.perf_counter()
    result, _ = diagnose_file(path)
    result["seconds"] = time.perf_counter() - start
    result.pop("_series")
    return {
        "scenario": name,
        "seed": seed,
        "vehicle_varied": varied,
        "profile_varied": profile_varied,
        "n_samples": int(raw["time"].size),
        "true_params": sim.truth["params"],
        "effects": [list(e) for e in effects],
        "truth": sim.truth["effects"],
        "diagnosis": result,
    }


def null_statistics(n: int, seed: int = 0, n_samples=None, progress=None) -> dict:
    """Largest round-1 gain (among ΔBIC < 0) and generic gain on ``n`` clean recordings."""
    rng = np.random.default_rng(seed)
    gains, generic = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(n):
            d = run_case([], rng, tmp, n_samples)["diagnosis"]
            gains.append(max([c["gain"] for c in d["candidates"] if c["delta_bic"] < 0] + [0.0]))
            generic.append(d["generic"]["gain"])
            if progress:
                progress.update()
    return {
        "max_gain": gains,
        "generic_gain": generic,
        "gain_q95": float(np.quantile(gains, 0.95)),
        "generic_q95": float(np.quantile(generic, 0.95)),
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=60)
    parser.add_argument("--seed", type=int, default=12345)
    parser.add_argument("--samples", type=int, default=None, help="samples per recording")
    args = parser.parse_args(argv)
    enable_x64()
    enable_compilation_cache()
    stats = null_statistics(args.n, args.seed, args.samples, progress=Progress(args.n, "null recordings"))
    print(json.dumps(stats))


if __name__ == "__main__":
    main()
