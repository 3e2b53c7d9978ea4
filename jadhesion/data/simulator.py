"""Simulator of the 22E traction tests: one recording (or a batch of seeds) with its truth.

A scenario (:mod:`.scenarios`) and a vehicle give the planned test (:mod:`.traction_profile`); the
plant — wheelset, locomotive, test load and slip controller — is integrated by ROS2 at the internal
step :data:`INTERNAL_STEP` and sampled every :data:`SAMPLE_PERIOD` (:mod:`.traction_plant`).

**Sensors.** :mod:`.sensors`: white + AR(1) noise and quantisation on both speeds, white noise
(the scenario's ``torque_noise``) and quantisation on torque — ``sensors="realistic"`` (default) or
``"clean"`` (the historical 5e-5 m/s white speed noise), scaled by ``sensor_noise``; then the
observer (:mod:`.observer`, paper variant) gives
``mu_hat``. Recorded ``creepage``/``slip_velocity`` come from the noisy recorded speeds. The truth
(:attr:`SimulationResult.truth`, the CLI's ``*.truth.json``) records everything the run used.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from ..models import effects as fx
from ..models.kinematics import creepage
from ..models.polach import PARAM_NAMES
from .observer import observer_core
from .recording import vehicle_sidecar
from .scenarios import envelope, get_scenario
from .sensors import measure, sensor_model
from .traction_plant import KI, KP, LOAD_DROOP, contact, controller, integrate
from .traction_profile import profile_constants, random_profile
from .validate import RAW_COLUMNS
from .vehicle import LOCO_22E, Vehicle

#: Recording sample period [s] (50 Hz) and ROS2 steps per sample (internal step 2 ms).
SAMPLE_PERIOD = 0.02
SUBSTEPS = 10
INTERNAL_STEP = SAMPLE_PERIOD / SUBSTEPS
DEFAULT_SAMPLES = 2000
#: Columns of a simulated recording, in file order: the raw signals and, computed from the recorded
#: speeds and the observer, creepage [-], slip velocity [m/s] and adhesion (``mu_hat``) [-].
COLUMNS = RAW_COLUMNS + ("creepage", "slip_velocity", "adhesion")


@dataclasses.dataclass(frozen=True)
class SimulationResult:
    """A simulated recording.

    Attributes:
        columns: numpy arrays of the recording, :data:`COLUMNS` in that order (the raw signals plus
            ``creepage``, ``slip_velocity``, ``adhesion`` = ``mu_hat``).
        vehicle: the :class:`Vehicle` (nominal radius).
        truth: JSON-ready metadata: scenario, seed, true parameters, effects, noise.
        latent: noise-free true signals (``creepage``, ``slip_velocity``, ``adhesion``, ``torque``).
    """

    columns: dict
    vehicle: Vehicle
    truth: dict
    latent: dict

    @functools.cached_property
    def envelope(self) -> dict:
        """The recording's :func:`~.scenarios.envelope` (paper units), computed on first use: it
        smooths the recording, which most callers never need."""
        return envelope(self)


def _constants(
    scenario,
    vehicle: Vehicle,
    mags,
    n_samples: int,
    sensors,
    period: float = SAMPLE_PERIOD,
    braking: bool = False,
) -> dict:
    """The traced constants ``c`` of one run: vehicle, true parameters, effect magnitudes, sensors,
    sample period [s] and the planned profile's entries (:func:`.traction_profile.profile_constants`)."""
    c = dict(
        theta=np.asarray(scenario.params, dtype=float),
        k_eps=vehicle.k_eps(),
        inertia=vehicle.wheelset_inertia_kgm2,
        radius=vehicle.wheel_radius_m,
        axle_load=vehicle.axle_load_kg,
        weight=vehicle.axle_weight_n,
        mass=vehicle.locomotive_mass_kg,
        n_axles=float(vehicle.n_axles),
        height_ratio=vehicle.cog_height_m / vehicle.coupler_height_m,
        t0=vehicle.observer_time_constant_s,
        sensors=sensors,
        mags=mags,
        period=period,
        **profile_constants(scenario, (n_samples - 1) * period, braking),
    )
    return jax.tree_util.tree_map(jnp.asarray, c)


def _simulate_core(key, c, n_samples: int, substeps: int = SUBSTEPS, pitch: bool = False):
    """Pure simulation: key and constants → recorded columns and latent signals (jnp arrays);
    ``pitch``: load transfer on (:func:`.traction_plant.contact`)."""
    k_prof, k_noise = jax.random.split(key)
    time, ys, ref = integrate(c, random_profile(k_prof, c), n_samples, substeps, pitch)

    def latent(y, r):
        torque, _ = controller(y, r, c)
        slip, s, mu, _, _ = contact(y, r, c, pitch)
        return torque, slip, s, mu

    torque, slip, s, mu = jax.vmap(latent)(ys, ref)
    m = c["mags"]
    wheel_speed, vehicle_speed, recorded_torque = measure(
        k_noise,
        ys[:, 0] * c["radius"],
        ys[:, 1],
        fx.delayed(time, torque, m[fx.INDEX["signal_delay"]])
        + m[fx.INDEX["torque_offset"]] * c["weight"] * c["radius"],
        c["sensors"],
        c["period"],
    )
    mu_hat = observer_core(
        time, wheel_speed, recorded_torque, c["inertia"], c["radius"], c["axle_load"], c["t0"]
    )
    rec_slip = wheel_speed - vehicle_speed
    columns = dict(
        time=time,
        vehicle_speed=vehicle_speed,
        wheel_speed=wheel_speed,
        traction_torque=recorded_torque,
        creepage=creepage(rec_slip, vehicle_speed),
        slip_velocity=rec_slip,
        adhesion=mu_hat,
    )
    return columns, dict(creepage=s, slip_velocity=slip, adhesion=mu, torque=torque)


#: One compiled program per (number of seeds, n_samples, substeps, load transfer on). Callers whose
#: count varies pad it (:func:`padded_seeds`); a sweep passes a fixed count of its own.
_simulate_jit = jax.jit(
    jax.vmap(_simulate_core, in_axes=(0, None, None, None, None)), static_argnums=(2, 3, 4)
)
#: Fewest seeds a batch is padded to (compilation, ~4 s, costs more than simulating 8 seeds).
MIN_SEED_BATCH = 8


def seed_batch(n_seeds: int) -> int:
    """Seeds a batch of ``n_seeds`` is padded to: the next power of two, at least
    :data:`MIN_SEED_BATCH` (at most twice the work, a handful of programs for any count)."""
    return max(MIN_SEED_BATCH, 1 << (max(int(n_seeds), 1) - 1).bit_length())


def padded_seeds(seeds) -> np.ndarray:
    """``seeds`` followed by repeats of the last up to :func:`seed_batch` of their count (the
    results of the repeats are dropped by the caller)."""
    seeds = np.asarray(seeds)
    return np.concatenate([seeds, np.repeat(seeds[-1:], seed_batch(len(seeds)) - len(seeds))])


def simulate_arrays(
    scenario,
    seeds,
    effects,
    n_samples,
    vehicle,
    noise,
    sensors,
    sensor_noise,
    period=SAMPLE_PERIOD,
    braking=False,
):
    """A batch of seeds as device arrays (for :func:`simulate_many` and :mod:`.simulated_datasets`):
    the scenario, effect magnitudes, traced constants, recorded columns and latent signals (leading
    seed axis), and the sensor model. Arguments as :func:`simulate`'s; ``n_samples`` must be ≥ 100."""
    scenario = get_scenario(scenario)
    model = sensor_model(sensors, scenario.torque_noise, sensor_noise * float(noise))
    n = DEFAULT_SAMPLES if n_samples is None else int(n_samples)
    if n < 100:
        raise ValueError(f"n_samples must be at least 100, got {n}")
    mags = fx.magnitudes(effects)
    c = _constants(scenario, vehicle, mags, n, model, period, braking)
    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(seeds))
    pitch = bool(mags[fx.INDEX["load_transfer"]] != 0.0)
    columns, latent = _simulate_jit(keys, c, n, substeps_for(period), pitch)
    return scenario, mags, c, columns, latent, model


def substeps_for(period: float) -> int:
    """Integrator steps per sample: the sample period [s] over :data:`INTERNAL_STEP`, at least 1."""
    return max(1, round(period / INTERNAL_STEP))


def _truth(scenario, seed, mags, vehicle, duration, model, period=SAMPLE_PERIOD, braking=False) -> dict:
    active = {}
    for name, mag in zip(fx.EFFECT_NAMES, mags, strict=True):
        if mag != 0.0:
            spec = fx.EFFECTS[name]
            active[name] = {"magnitude": float(mag), "unit": spec.unit, "summary": spec.summary}
    if "rail_change" in active:
        active["rail_change"]["time_s"] = fx.RAIL_CHANGE_AT * duration
    if "speed_dependence" in active:
        active["speed_dependence"]["v_ref_mps"] = scenario.mean_speed
    if "thermal_softening" in active:
        active["thermal_softening"].update(
            time_constant_s=fx.THERMAL_TIME_CONSTANT, power_scale_w=fx.THERMAL_POWER_SCALE
        )
    if "load_transfer" in active:
        active["load_transfer"].update(
            coupler_height_m=vehicle.coupler_height_m,
            cog_height_m=vehicle.cog_height_m,
            body_pitch_transfer=vehicle.body_pitch_transfer,
        )
    return {
        "scenario": scenario.name,
        "seed": int(seed),
        "params": dict(zip(PARAM_NAMES, map(float, scenario.params), strict=True)),
        "k_eps": vehicle.k_eps(),
        "effects": active,
        "noise": {
            "torque_nm": model.torque_white_nm,
            "speed_mps": model.speed_sd(),
            "sensors": model.as_dict(),
        },
        "controller": {"kp": KP, "ki": KI, "load_droop": LOAD_DROOP},
        "sample_period_s": period,
        "internal_step_s": period / substeps_for(period),
        "rate_hz": 1.0 / period,
        "duration_s": duration,
        "test": "braking" if braking else "traction",
        "coasting": coasting_gap(scenario, duration, braking),
        "vehicle": vehicle_sidecar(vehicle),
    }


def coasting_gap(scenario, duration: float, braking: bool = False):
    """``{"start_s", "end_s"}`` of the coasting gap's flat part (the creep reference 0; cos² edges of
    :data:`.traction_profile.COAST_EDGE_S` on either side), or None without one."""
    if scenario.coast_s <= 0:
        return None
    c = profile_constants(scenario, duration, braking)
    return {"start_s": c["coast_mid"] - c["coast_half"], "end_s": c["coast_mid"] + c["coast_half"]}


def simulate_many(
    scenario,
    seeds: Sequence[int],
    effects=(),
    n_samples=None,
    *,
    vehicle: Vehicle = LOCO_22E,
    noise: bool = True,
    sensors="realistic",
    sensor_noise: float = 1.0,
    sample_period: float = SAMPLE_PERIOD,
    braking: bool = False,
) -> list:
    """:func:`simulate` for several seeds in one vmapped call (the batch padded to
    :func:`seed_batch` seeds); a list of results."""
    padded = padded_seeds(seeds)
    scenario, mags, c, columns, latent, model = simulate_arrays(
        scenario, padded, effects, n_samples, vehicle, noise, sensors, sensor_noise, sample_period, braking
    )
    return [
        SimulationResult(
            columns={k: np.asarray(columns[k][i]) for k in COLUMNS},
            vehicle=vehicle,
            truth=_truth(scenario, seed, mags, vehicle, float(c["duration"]), model, sample_period, braking),
            latent={k: np.asarray(v[i]) for k, v in latent.items()},
        )
        for i, seed in enumerate(seeds)
    ]


def simulate(
    scenario,
    seed: int = 0,
    effects=(),
    n_samples=None,
    *,
    vehicle: Vehicle = LOCO_22E,
    noise: bool = True,
    sensors="realistic",
    sensor_noise: float = 1.0,
    sample_period: float = SAMPLE_PERIOD,
    braking: bool = False,
) -> SimulationResult:
    """Simulate one traction test recording.

    Args:
        scenario: ``"dry"``, ``"wet"``, ``"sand"`` or a :class:`~.scenarios.Scenario`.
        seed: PRNG seed (profile wander, minor excursions, sensor noise).
        effects: ``[(name, magnitude) | name | "name=magnitude"]``, names from
            :data:`~..models.effects.EFFECTS`.
        n_samples: samples (default :data:`DEFAULT_SAMPLES`, 40 s at the default rate).
        vehicle: the locomotive (its nominal radius is the recorded one).
        noise: ``False`` gives noise-free sensors (same as ``sensor_noise=0``).
        sensors: ``"realistic"`` (default), ``"clean"`` or a :class:`~.sensors.SensorModel`.
        sensor_noise: scale of every sensor noise level and resolution (:mod:`.sensors`).
        sample_period: recording sample period [s] (default :data:`SAMPLE_PERIOD`, 50 Hz); the
            integrator keeps an internal step near :data:`INTERNAL_STEP` (:func:`substeps_for`).
        braking: a braking test: the creep reference is negated (negative creep, adhesion and
            torque; the test load pushes), everything else as in traction.

    Raises:
        InputError: unknown scenario or effect, bad magnitude.
    """
    return simulate_many(
        scenario,
        [seed],
        effects,
        n_samples,
        vehicle=vehicle,
        noise=noise,
        sensors=sensors,
        sensor_noise=sensor_noise,
        sample_period=sample_period,
        braking=braking,
    )[0]
