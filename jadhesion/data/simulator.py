"""Simulator of the 22E traction tests: wheelset + locomotive dynamics, slip controller, sensors.

**Plant** (state ``y = [ω, v, z, P_th]``; wheel angular speed [rad/s], vehicle speed [m/s], PI
integral [N·m], thermal state [W]). With true rolling radius ``r``, slip ``w = ω r − v``, creepage
``s = w / max(v, floor)`` and the Polach curve ``mu(s, w)`` (effects applied,
:mod:`..models.effects`):

    J ω̇   = T − mu N1 r                     (wheelset; N1 = leading-axle weight [N])
    M v̇   = n mu N − F_res(v) − F_load(t, v)  (all n axles see the measured axle's mu)
    τ Ṗ_th = mu N1 |w| − P_th               (only used by thermal_softening)

``F_res = M g c0 + c2 v²`` (Davis, :data:`ROLLING_RESISTANCE`, :data:`AERO_DRAG`). **Test load** (a
choice, the paper does not describe it; it keeps the speed at walking pace like the paper's tests):
a speed-regulated load (dynamometer car / load locomotive in dynamic brake) whose drawbar force is
the planned pull with a proportional speed droop ``δ`` = :data:`LOAD_DROOP`:
``F_load = F_plan(t) (1 + sgn(F_plan) (v − v_ref)/(δ v_ref))`` (in a braking test the load pushes,
``F_plan < 0``, and must still pull back when the speed rises),
``F_plan = n N mu_plan − F_res(v_ref) − M a_ref``,
``mu_plan`` the effect-free curve along the creep reference. Without effects ``v = v_ref``; an
effect that changes the tractive effort by a fraction f shifts the speed by about ``δ f v_ref``.

**Slip controller** (the TCU; acts on noise-free signals at the nominal radius ``r0``): slip
velocity reference ``w_ref = s_ref(t) v``, feed-forward of the effect-free adhesion torque and of
the wheel's inertia along the planned profile, plus PI on the slip velocity:

    T = N r0 mu_nom(s_ref, s_ref v_ref) + (J/r0)(a_ref (1 + s_ref) + v_ref ṡ_ref) + Kp e + z,
    ż = Ki e,   e = w_ref − (ω r0 − v)

**Integrator.** The wheel equation is stiff at small creep (eigenvalue ≈ slope·r²·N/(J v), 10³–10⁴
s⁻¹ at walking speed), so an L-stable linearly implicit 2-stage Rosenbrock method (ROS2, Verwer et
al. 1999, ``γ = 1 + 1/√2``, Jacobian by forward mode, ``jax.linearize``) runs at a fixed internal
step :data:`INTERNAL_STEP` inside ``lax.scan`` and is sampled at :data:`SAMPLE_PERIOD` (against a
0.25 ms step the true adhesion differs by < 1e-4 in 90 % of the samples and by at most ~0.003, at
the onset of the fast slip excursions). Not diffrax: a 4-state system at a fixed step matching the
controller's rate needs no adaptivity, and this avoids a dependency and its compile cost. Time
enters only through the smooth reference (W-method: the ``∂f/∂t`` term is dropped).

**Sensors.** :mod:`.sensors`: white + AR(1) noise and quantisation on both speeds, white noise
(the scenario's ``torque_noise``) and quantisation on torque — ``sensors="realistic"`` (default) or
``"clean"`` (the historical 5e-5 m/s white speed noise), scaled by ``sensor_noise``; then the
observer (:mod:`.observer`, paper variant) gives
``mu_hat``. Recorded ``creepage``/``slip_velocity`` come from the noisy recorded speeds.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from ..models import effects as fx
from ..models.kinematics import creepage
from ..models.polach import PARAM_NAMES, polach_adhesion
from .dataset import PolachDataset
from .observer import observer_core
from .recording import vehicle_sidecar
from .scenarios import envelope, get_scenario
from .sensors import measure, sensor_model
from .vehicle import GRAVITY, LOCO_22E, Vehicle

#: Recording sample period [s] (50 Hz) and ROS2 steps per sample (internal step 2 ms).
SAMPLE_PERIOD = 0.02
SUBSTEPS = 10
INTERNAL_STEP = SAMPLE_PERIOD / SUBSTEPS
DEFAULT_SAMPLES = 2000
#: Slip-velocity PI gains Kp [N·m·s/m], Ki [N·m/m]: critically damped, ω_n ≈ 20 rad/s past the peak.
KP = 2.0e5
KI = 2.0e6
#: Speed droop of the speed-regulated test load [-]; Davis resistance c0 [-], c2 [N·s²/m²].
LOAD_DROOP = 0.1
ROLLING_RESISTANCE = 1.5e-3
AERO_DRAG = 6.0
#: Number of random sinusoids in the creep wander and their frequency band [Hz].
N_WANDER = 4
WANDER_BAND = (0.05, 0.5)
#: Slots for minor slip excursions (``Scenario.minor_excursions`` of them are used).
MAX_MINOR = 3
_GAMMA = 1.0 + 1.0 / math.sqrt(2.0)


@dataclasses.dataclass(frozen=True)
class SimulationResult:
    """A simulated recording.

    Attributes:
        columns: numpy arrays in the recording format (``time``, ``vehicle_speed``, ``wheel_speed``,
            ``traction_torque``) plus ``creepage``, ``slip_velocity``, ``adhesion`` (= ``mu_hat``).
        vehicle: the :class:`Vehicle` (nominal radius).
        truth: JSON-ready metadata: scenario, seed, true parameters, effects, noise, envelope.
        latent: noise-free true signals (``creepage``, ``slip_velocity``, ``adhesion``, ``torque``).
    """

    columns: dict
    vehicle: Vehicle
    truth: dict
    latent: dict


def _constants(
    scenario,
    vehicle: Vehicle,
    mags,
    n_samples: int,
    sensors,
    period: float = SAMPLE_PERIOD,
    braking: bool = False,
) -> dict:
    duration = (n_samples - 1) * period
    v_exc = scenario.max_slip / scenario.max_creep
    at = 0.5 + (v_exc / scenario.mean_speed - 1.0) / scenario.speed_ramp
    t_main = duration * float(np.clip(at, 0.1, 0.9))
    c = dict(
        theta=np.asarray(scenario.params, dtype=float),
        k_eps=vehicle.k_eps(),
        inertia=vehicle.wheelset_inertia_kgm2,
        radius=vehicle.wheel_radius_m,
        axle_load=vehicle.axle_load_kg,
        weight=vehicle.axle_weight_n,
        mass=vehicle.locomotive_mass_kg,
        n_axles=float(vehicle.n_axles),
        t0=vehicle.observer_time_constant_s,
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
        sensors=sensors,
        mags=mags,
        period=period,
        sign=-1.0 if braking else 1.0,
    )
    return jax.tree_util.tree_map(jnp.asarray, c)


def _profile(key, c):
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


def _creep_ref(t, c, prof):
    """Creep reference ``s_ref(t)`` [-]: smoothstep ramp-in, log-normal wander, cos² excursions;
    negated for a braking test (``c["sign"] = −1``: negative creep, adhesion and torque)."""
    x = jnp.clip(t / c["ramp_time"], 0.0, 1.0)
    ramp = x * x * (3.0 - 2.0 * x)
    base = c["creep_start"] + (c["creep_base"] - c["creep_start"]) * ramp
    waves = jnp.sin(2 * jnp.pi * prof["freqs"] * t + prof["phases"])
    wander = math.sqrt(2.0 / N_WANDER) * jnp.sum(waves)
    u = (t - prof["exc_times"]) / c["exc_width"]
    bumps = jnp.where(jnp.abs(u) < 1.0, jnp.cos(0.5 * jnp.pi * u) ** 2, 0.0)
    heights = jnp.maximum(prof["exc_peaks"] - c["creep_base"], 0.0)
    return c["sign"] * (base * jnp.exp(c["wander"] * ramp * wander) + jnp.sum(heights * bumps))


def _speed_ref(t, c):
    """Speed reference ``v_ref(t)`` [m/s] and slope ``a_ref`` [m/s²] (linear ramp about v_mean)."""
    a_ref = c["v_mean"] * c["speed_ramp"] / c["duration"]
    return c["v_mean"] + a_ref * (t - 0.5 * c["duration"]), a_ref


def _resistance(v, c):
    return c["mass"] * GRAVITY * ROLLING_RESISTANCE + AERO_DRAG * v * v


def _reference(t, c, prof):
    """Everything that depends on time only (hoisted out of the integrator): creep and speed
    references, the controller's feed-forward torque [N·m], the load's planned pull [N], and the
    rail-change factor."""
    s_ref, ds_ref = jax.jvp(lambda tt: _creep_ref(tt, c, prof), (t,), (jnp.ones_like(t),))
    v_ref, a_ref = _speed_ref(t, c)
    mu_plan = polach_adhesion(c["theta"], s_ref, s_ref * v_ref, c["k_eps"])
    t_ff = c["weight"] * c["radius"] * mu_plan + c["inertia"] / c["radius"] * (
        a_ref * (1.0 + s_ref) + v_ref * ds_ref
    )
    f_plan = c["n_axles"] * c["weight"] * mu_plan - _resistance(v_ref, c) - c["mass"] * a_ref
    rail = fx.rail_factor(c["mags"][fx.INDEX["rail_change"]], t, fx.RAIL_CHANGE_AT * c["duration"])
    return dict(s_ref=s_ref, v_ref=v_ref, t_ff=t_ff, f_plan=f_plan, rail=rail)


def _controller(y, ref, c):
    """Traction torque [N·m] and slip error [m/s] of the TCU's slip-velocity controller."""
    omega, v, z, _ = y
    error = ref["s_ref"] * v - (omega * c["radius"] - v)
    return ref["t_ff"] + KP * error + z, error


def _contact(y, ref, torque, c):
    """True slip [m/s], creepage [-], adhesion [-], leading-axle weight [N], radius [m]."""
    omega, v, _, heat = y
    m = c["mags"]
    radius = c["radius"] * (1.0 + m[fx.INDEX["wheel_radius_error"]])
    ratio = c["n_axles"] * torque / (radius * c["mass"] * GRAVITY)
    n1 = c["weight"] * fx.load_factor(m[fx.INDEX["load_transfer"]], ratio)
    k_eps = c["k_eps"] * (n1 / c["weight"]) ** (-1.0 / 3.0)
    scale = (
        ref["rail"]
        * fx.speed_factor(m[fx.INDEX["speed_dependence"]], v, c["v_mean"])
        * fx.thermal_factor(m[fx.INDEX["thermal_softening"]], heat)
    )
    theta = jnp.where(jnp.arange(5) == 2, c["theta"] * scale, c["theta"])
    slip = omega * radius - v
    s = creepage(slip, v)
    return slip, s, polach_adhesion(theta, s, slip, k_eps), n1, radius


def _rhs(y, ref, c):
    torque, error = _controller(y, ref, c)
    slip, _, mu, n1, radius = _contact(y, ref, torque, c)
    droop = jnp.sign(ref["f_plan"]) * (y[1] - ref["v_ref"]) / (LOAD_DROOP * ref["v_ref"])
    f_load = ref["f_plan"] * (1.0 + droop)  # a pushing load (braking, F_plan < 0) droops too
    return jnp.stack(
        [
            (torque - mu * n1 * radius) / c["inertia"],
            (c["n_axles"] * mu * c["weight"] - _resistance(y[1], c) - f_load) / c["mass"],
            KI * error,
            (mu * n1 * jnp.abs(slip) - y[3]) / fx.THERMAL_TIME_CONSTANT,
        ]
    )


def _lu(a):
    """Doolittle LU of a small matrix without pivoting (unrolled): ``W = I − γ h J`` is the identity
    plus O(h) except on the stiff diagonal, where it is large, so its pivots stay ≥ ~0.9."""
    n = a.shape[0]
    for k in range(n - 1):
        factors = a[k + 1 :, k] / a[k, k]
        a = a.at[k + 1 :, k + 1 :].add(-factors[:, None] * a[k, k + 1 :][None, :])
        a = a.at[k + 1 :, k].set(factors)
    return a


def _lu_solve(lu, b):
    n = b.shape[0]
    y = []
    for i in range(n):
        y.append(b[i] - sum(lu[i, j] * y[j] for j in range(i)))
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum(lu[i, j] * x[j] for j in range(i + 1, n))) / lu[i, i]
    return jnp.stack(x)


def _ros2_step(y, ref0, ref1, h, c):
    """One L-stable ROS2 step, ``W = I − γ h J``: ``W k1 = f(t, y)``,
    ``W k2 = f(t+h, y+h k1) − 2 k1``, ``y⁺ = y + h (3 k1 + k2)/2``."""
    f0, linear = jax.linearize(lambda yy: _rhs(yy, ref0, c), y)
    eye = jnp.eye(y.shape[0], dtype=y.dtype)
    lu = _lu(eye - _GAMMA * h * jax.vmap(linear, out_axes=1)(eye))
    k1 = _lu_solve(lu, f0)
    k2 = _lu_solve(lu, _rhs(y + h * k1, ref1, c) - 2.0 * k1)
    return y + h * (1.5 * k1 + 0.5 * k2)


def _simulate_core(key, c, n_samples: int, substeps: int = SUBSTEPS):
    """Pure simulation: key and constants → recorded columns and latent signals (jnp arrays)."""
    k_prof, k_noise = jax.random.split(key)
    prof = _profile(k_prof, c)
    h = c["period"] / substeps
    t_fine = h * jnp.arange((n_samples - 1) * substeps + 1, dtype=c["duration"].dtype)
    ref = jax.vmap(lambda t: _reference(t, c, prof))(t_fine)
    v0, _ = _speed_ref(t_fine[0], c)
    y0 = jnp.stack([v0 * (1.0 + ref["s_ref"][0]) / c["radius"], v0, 0.0 * v0, 0.0 * v0])

    def step(y, refs):
        y_next = _ros2_step(y, *refs, h, c)
        return y_next, y_next

    head = jax.tree_util.tree_map(lambda a: a[:-1], ref)
    tail = jax.tree_util.tree_map(lambda a: a[1:], ref)
    _, ys = jax.lax.scan(step, y0, (head, tail))
    ys = jnp.concatenate([y0[None], ys])[::substeps]
    ref = jax.tree_util.tree_map(lambda a: a[::substeps], ref)
    time = t_fine[::substeps]

    def latent(y, r):
        torque, _ = _controller(y, r, c)
        slip, s, mu, _, _ = _contact(y, r, torque, c)
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


#: One compiled program per (n_samples, substeps): a batch of seeds; single runs are batches of one.
_simulate_jit = jax.jit(jax.vmap(_simulate_core, in_axes=(0, None, None, None)), static_argnums=(2, 3))


def _run(
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
    scenario = get_scenario(scenario)
    model = sensor_model(sensors, scenario.torque_noise, sensor_noise * float(noise))
    n = DEFAULT_SAMPLES if n_samples is None else int(n_samples)
    if n < 100:
        raise ValueError(f"n_samples must be at least 100, got {n}")
    mags = fx.magnitudes(effects)
    c = _constants(scenario, vehicle, mags, n, model, period, braking)
    keys = jax.vmap(jax.random.PRNGKey)(jnp.asarray(seeds))
    columns, latent = _simulate_jit(keys, c, n, substeps_for(period))
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
        "vehicle": vehicle_sidecar(vehicle),
    }


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
    """:func:`simulate` for several seeds in one vmapped call; a list of results."""
    scenario, mags, c, columns, latent, model = _run(
        scenario, seeds, effects, n_samples, vehicle, noise, sensors, sensor_noise, sample_period, braking
    )
    results = []
    for i, seed in enumerate(seeds):
        result = SimulationResult(
            columns={k: np.asarray(v[i]) for k, v in columns.items()},
            vehicle=vehicle,
            truth=_truth(scenario, seed, mags, vehicle, float(c["duration"]), model, sample_period, braking),
            latent={k: np.asarray(v[i]) for k, v in latent.items()},
        )
        result.truth["envelope"] = envelope(result)
        results.append(result)
    return results


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


def _dataset(columns, k_eps) -> PolachDataset:
    return PolachDataset(
        creep=columns["creepage"],
        slip=columns["slip_velocity"],
        adhesion=columns["adhesion"],
        vehicle_speed=columns["vehicle_speed"],
        k_eps=k_eps,
    )


def result_dataset(result: SimulationResult) -> PolachDataset:
    """The fitting dataset of a simulated recording (recorded creep, slip, speed, observer output)."""
    return _dataset(
        {k: jnp.asarray(v) for k, v in result.columns.items()}, jnp.asarray(result.truth["k_eps"])
    )


def stack_datasets(results: Sequence[SimulationResult]) -> PolachDataset:
    """:func:`result_dataset` of several recordings of one length, stacked on a leading axis."""
    return jax.tree_util.tree_map(lambda *a: jnp.stack(a), *map(result_dataset, results))


def simulate_dataset(
    scenario,
    seed: int = 0,
    effects=(),
    n_samples=None,
    *,
    vehicle: Vehicle = LOCO_22E,
    sensors="realistic",
    sensor_noise: float = 1.0,
) -> PolachDataset:
    """The fitting dataset (recorded creep, slip, speed and observer output) of one recording."""
    data = simulate_batch(
        scenario, [seed], effects, n_samples, vehicle=vehicle, sensors=sensors, sensor_noise=sensor_noise
    )
    return jax.tree_util.tree_map(lambda a: a[0], data)


def simulate_batch(
    scenario,
    seeds: Sequence[int],
    effects=(),
    n_samples=None,
    *,
    vehicle: Vehicle = LOCO_22E,
    sensors="realistic",
    sensor_noise: float = 1.0,
) -> PolachDataset:
    """Datasets for many seeds in one vmapped, jitted call: every field gains a leading seed axis
    (``k_eps`` too, shape (n_seeds,)), so the result vmaps straight into a fit. Creep and slip are
    the raw differences of the recorded speeds (:func:`.dataset.to_dataset` smooths them)."""
    _, _, c, columns, _, _ = _run(scenario, seeds, effects, n_samples, vehicle, True, sensors, sensor_noise)
    return _dataset(columns, jnp.full((len(seeds),), c["k_eps"]))
