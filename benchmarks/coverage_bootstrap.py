"""Experiment (negative result): intervals by re-synthesising the recording in hand from its fit.

    python -m benchmarks.coverage_bootstrap --scenario sand --n 6 --replicas 40

A candidate remedy of issue 18, measured and *not* adopted: on realistic sensors its bias
correction points the wrong way (results in ``benchmarks/results/coverage_bootstrap.json``). The
estimate's bias depends strongly on where the parameters are (sand: at the truth B = 0.155 the fit
jumps to B = 1 and μ0 up; replicas drawn at the fit, B = 1, pull μ0 *down*), so the bootstrap
principle "bias at θ̂ ≈ bias at θ" fails, and the replicas' spread alone is narrower than the
HAC interval. Kept here so the measurement can be rerun.

Why: on realistic speed sensors the LM estimate is *biased* — the observer's derivative lags in
short slip excursions (y errors) and the smoothed slip misses part of the coloured speed noise (x
errors, correlated with the y errors through the wheel speed) — and a local covariance (HAC
sandwich) can only describe the spread, not the bias. Replicas that pass through the very same
sensor → observer → smoother → LM path carry the same mechanisms, so their spread and their bias
calibrate the fit on this recording, without constants tuned to any simulator.

**Re-synthesis** (:func:`replicas`). The latent motion is the smoother's (:mod:`..data.creep_state`):
vehicle speed ``v̂``, slip ``ŵ``, wheel acceleration ``a + ẇ``. The replica's adhesion is the fitted
curve ``μ = μ_adh(θ̂; ŵ/|v̂|, ŵ)``; its torque follows the wheelset balance
``T = μ m g r + J (a + ẇ)/r``. Sensor noise is re-drawn from a model estimated on the recording
(:func:`noise_model`): each speed channel gets white noise plus AR(1) noise plus quantisation,
the torque white noise plus quantisation. Then the replica goes through the observer, the smoother
(noise levels re-estimated) and LM exactly as the recording did.

**Speed noise from the recording.** The vehicle is heavy, so the vehicle-speed residual
``e = y_v − v̂`` is nearly all sensor noise; its autocovariances ``γ₀, γ₁, γ₂`` give a white + AR(1)
mixture (``ρ = γ₂/γ₁``, ``σ_c² = γ₁²/γ₂``, ``σ_w² = γ₀ − σ_c² − q²/12``; no colour when ``γ₁`` or
``γ₂ ≤ 0``). The wheel channel is assumed to be the same kind of sensor, its levels scaled by the
ratio of the two channels' third-difference noise (:func:`..data.creep_state.difference_sd`) —
the wheel's own residual cannot be used, the smoother tracks part of it as slip. A channel's
quantum ``q`` is its smallest step when at least :data:`GRID_SHARE` of the samples lie on that
grid (else 0). Torque: white ``σ_T`` from the third difference, quantum likewise.

**Intervals** (:func:`bootstrap_intervals`). With replica estimates ``θ*_r`` (and the derived
``μ_max``, ``creep_opt`` at the median speed): bias ``b = mean(θ*) − θ̂``, corrected estimate
``θ̃ = θ̂ − b``, standard error ``sd(θ*)``, interval ``θ̃ ± z·sd`` clipped to the box (a parameter
whose replicas all sit on one bound reports the bound). Cost: ``R`` smoother runs and ``R`` LM fits
(one vmapped, jitted batch), about ``R`` times the fit.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from scipy import stats

jax.config.update("jax_enable_x64", True)

from benchmarks.provenance import commit  # noqa: E402
from jadhesion.data.creep_state import difference_sd, smooth_creep  # noqa: E402
from jadhesion.data.dataset import PolachDataset, to_dataset  # noqa: E402
from jadhesion.data.observer import observer_core  # noqa: E402
from jadhesion.data.scenarios import get_scenario  # noqa: E402
from jadhesion.data.sensors import ar1_noise, quantise  # noqa: E402
from jadhesion.data.simulator import simulate_many  # noqa: E402
from jadhesion.data.vehicle import GRAVITY  # noqa: E402
from jadhesion.identify.polach_fit import fit_polach, fit_polach_batch  # noqa: E402
from jadhesion.identify.trust import fit_report  # noqa: E402
from jadhesion.models.polach import PARAM_NAMES, adhesion_peak, polach_adhesion  # noqa: E402

#: Replicas per recording (the interval's sd has a relative error of about 1/√(2R) ≈ 11 %).
N_REPLICAS = 40
#: Share of samples that must lie on a grid for the channel to count as quantised.
GRID_SHARE = 0.9
QUANTITIES = PARAM_NAMES + ("mu_max", "creep_opt")


class NoiseModel(NamedTuple):
    """Sensor noise of a recording: per speed channel (wheel, vehicle) white sd [m/s], AR(1) sd
    [m/s], AR(1) lag-1 coefficient [-] and quantum [m/s]; torque white sd and quantum [N·m]."""

    speed_white: np.ndarray
    speed_colour: np.ndarray
    speed_rho: float
    speed_quantum: np.ndarray
    torque_white: float
    torque_quantum: float


def grid_step(x) -> float:
    """Quantum of ``x``: its smallest positive step when ≥ :data:`GRID_SHARE` of the samples lie on
    that grid (to 1e-3 of a step), else 0."""
    x = np.asarray(x, float)
    steps = np.abs(np.diff(x))
    steps = steps[steps > 1e-12 * max(np.max(np.abs(x)), 1e-300)]
    if steps.size == 0:
        return 0.0
    q = float(np.quantile(steps, 0.01))
    share = np.mean(np.abs(x / q - np.round(x / q)) < 1e-3)
    return q if share >= GRID_SHARE else 0.0


def noise_model(wheel_speed, vehicle_speed, torque, vehicle_speed_smoothed) -> NoiseModel:
    """:class:`NoiseModel` of a recording (module docstring)."""
    e = np.asarray(vehicle_speed, float) - np.asarray(vehicle_speed_smoothed, float)
    e = e - e.mean()
    g0, g1, g2 = (float(np.mean(e[k:] * e[: e.size - k])) for k in (0, 1, 2))
    q_v, q_w = grid_step(vehicle_speed), grid_step(wheel_speed)
    if g1 > 0 and g2 > 0 and g2 < g1:
        rho, colour2 = g2 / g1, min(g1 * g1 / g2, g0)
    else:
        rho, colour2 = 0.0, 0.0
    white_v = np.sqrt(max(g0 - colour2 - q_v**2 / 12.0, 0.0))
    ratio = float(
        difference_sd(jnp.asarray(wheel_speed, float)) / difference_sd(jnp.asarray(vehicle_speed, float))
    )
    ratio = ratio if np.isfinite(ratio) and ratio > 0 else 1.0
    return NoiseModel(
        np.array([white_v * ratio, white_v]),
        np.array([np.sqrt(colour2) * ratio, np.sqrt(colour2)]),
        rho,
        np.array([q_w, q_v]),
        float(difference_sd(jnp.asarray(torque, float))),
        grid_step(torque),
    )


def _replica(key, latent, noise, consts):
    """One re-synthesised dataset (a :class:`PolachDataset`) from the latent signals."""
    time, v, w, wdot_wheel, torque = latent
    inertia, radius, axle_load, t0, k_eps = consts
    kw, kv, kt = jax.random.split(key, 3)
    dt = jnp.median(jnp.diff(time))
    rho = jnp.maximum(noise.speed_rho, 1e-6)
    tau = -dt / jnp.log(rho)

    def channel(k, x, i):
        k1, k2 = jax.random.split(k)
        y = x + noise.speed_white[i] * jax.random.normal(k1, x.shape)
        y = y + ar1_noise(k2, x.shape[0], noise.speed_colour[i], tau, dt)
        return quantise(y, noise.speed_quantum[i])

    yw, yv = channel(kw, v + w, 0), channel(kv, v, 1)
    tq = quantise(torque + noise.torque_white * jax.random.normal(kt, torque.shape), noise.torque_quantum)
    est = smooth_creep(time, yw, yv, tq, inertia, radius, axle_load)
    mu_hat = observer_core(time, yw, tq, inertia, radius, axle_load, t0)
    return PolachDataset(
        creep=est.creep,
        slip=est.slip,
        adhesion=mu_hat,
        vehicle_speed=est.vehicle_speed,
        k_eps=k_eps,
        slip_sd=est.slip_sd,
        creep_sd=est.creep_sd,
    )


_replicas = jax.jit(jax.vmap(_replica, in_axes=(0, None, None, None)))


def replicas(key, theta, columns: dict, vehicle, n_replicas: int = N_REPLICAS):
    """``(datasets, noise)``: ``n_replicas`` re-syntheses of a recording (its four raw ``columns``
    and ``vehicle``) from the fit ``theta``, stacked on a leading axis, and the
    :class:`NoiseModel` they were drawn with."""
    time, yw, yv, tq = (
        jnp.asarray(columns[c], float) for c in ("time", "wheel_speed", "vehicle_speed", "traction_torque")
    )
    inertia, radius, load = vehicle.wheelset_inertia_kgm2, vehicle.wheel_radius_m, vehicle.axle_load_kg
    est = smooth_creep(time, yw, yv, tq, inertia, radius, load)
    k_eps = jnp.asarray(vehicle.k_eps(), float)
    mu = polach_adhesion(jnp.asarray(theta, float), est.creep, est.slip, k_eps)
    accel = est.acceleration + est.slip_rate
    torque = mu * load * GRAVITY * radius + inertia * accel / radius
    noise = noise_model(yw, yv, tq, est.vehicle_speed)
    latent = (time, est.vehicle_speed, est.slip, accel, torque)
    consts = (inertia, radius, load, vehicle.observer_time_constant_s, k_eps)
    noise_j = NoiseModel(*(jnp.asarray(a, float) for a in noise))
    keys = jax.random.split(key, n_replicas)
    return _replicas(keys, latent, noise_j, consts), noise


def _quantities(theta, k_eps, speed):
    mu_max, creep_opt = adhesion_peak(theta, k_eps, speed)
    return jnp.concatenate([theta, jnp.stack([mu_max, creep_opt])])


def bootstrap_intervals(
    key, theta, columns: dict, vehicle, level: float = 0.95, n_replicas: int = N_REPLICAS
):
    """Bias-corrected intervals of :data:`QUANTITIES` from ``n_replicas`` re-syntheses of the
    recording (module docstring). Returns a dict: ``estimate`` (θ̂ and derived), ``bias``,
    ``stderr``, ``corrected``, ``interval`` ({name: [lo, hi]} at ``level``), ``n_replicas``,
    ``noise`` (the estimated :class:`NoiseModel`, JSON-ready), ``speed`` (median [m/s])."""
    k_syn, k_fit = jax.random.split(key)
    data, noise = replicas(k_syn, theta, columns, vehicle, n_replicas)
    fits = fit_polach_batch(data, "lm", jax.random.split(k_fit, n_replicas))
    speed = float(np.median(np.abs(np.asarray(columns["vehicle_speed"], float))))
    k_eps = jnp.asarray(vehicle.k_eps(), float)
    est = np.asarray(_quantities(jnp.asarray(theta, float), k_eps, speed))
    reps = np.asarray(jax.vmap(lambda t: _quantities(t, k_eps, speed))(fits.params))
    bias = reps.mean(axis=0) - est
    sd = reps.std(axis=0, ddof=1)
    corrected = est - bias
    z = stats.norm.ppf(0.5 + level / 2)
    lo, hi = corrected - z * sd, corrected + z * sd
    lo[:5], hi[:5] = np.clip(lo[:5], 0.0, 1.0), np.clip(hi[:5], 0.0, 1.0)
    lo[5:] = np.maximum(lo[5:], 0.0)
    return {
        "estimate": dict(zip(QUANTITIES, est.tolist(), strict=True)),
        "bias": dict(zip(QUANTITIES, bias.tolist(), strict=True)),
        "stderr": dict(zip(QUANTITIES, sd.tolist(), strict=True)),
        "corrected": dict(zip(QUANTITIES, corrected.tolist(), strict=True)),
        "interval": {q: [float(a), float(b)] for q, a, b in zip(QUANTITIES, lo, hi, strict=True)},
        "level": level,
        "n_replicas": n_replicas,
        "noise": {k: np.asarray(v).tolist() for k, v in noise._asdict().items()},
        "speed": speed,
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="sand")
    p.add_argument("--n", type=int, default=6)
    p.add_argument("--points", type=int, default=1000)
    p.add_argument("--replicas", type=int, default=N_REPLICAS)
    p.add_argument("--save", default=str(Path(__file__).parent / "results" / "coverage_bootstrap.json"))
    args = p.parse_args(argv)
    theta = np.asarray(get_scenario(args.scenario).params)
    rows, start = [], time.perf_counter()
    for i, rec in enumerate(
        simulate_many(args.scenario, list(range(100, 100 + args.n)), n_samples=args.points)
    ):
        data = to_dataset(rec)
        fit = fit_polach(data, "lm", jax.random.key(0))
        hac = fit_report(data, fit)["uncertainty"]
        t0 = time.perf_counter()
        boot = bootstrap_intervals(
            jax.random.key(i), fit.params, rec.columns, rec.vehicle, 0.9, args.replicas
        )
        speed = boot["speed"]
        truth = np.asarray(_quantities(jnp.asarray(theta), jnp.asarray(rec.vehicle.k_eps()), speed))
        boot["truth"] = dict(zip(QUANTITIES, truth.tolist(), strict=True))
        boot["seconds"] = time.perf_counter() - t0
        boot["hit90"] = {
            q: bool(boot["interval"][q][0] <= t <= boot["interval"][q][1])
            for q, t in zip(QUANTITIES, truth, strict=True)
        }
        boot["hac_stderr"] = {q: hac[q]["stderr"] for q in PARAM_NAMES}
        rows.append(boot)
        print(i, {q: round(boot["bias"][q], 3) for q in ("kS", "mu0")}, boot["hit90"], flush=True)
    doc = {
        "commit": commit(),
        "settings": {**vars(args), "sensors": "realistic", "level": 0.9},
        "coverage90": {q: float(np.mean([r["hit90"][q] for r in rows])) for q in QUANTITIES},
        "true_error": {
            q: [r["estimate"][q] - r["truth"][q] for r in rows] for q in ("kS", "mu0", "mu_max", "creep_opt")
        },
        "bootstrap_bias": {q: [r["bias"][q] for r in rows] for q in ("kS", "mu0", "mu_max", "creep_opt")},
        "rows": rows,
        "wall_seconds": time.perf_counter() - start,
        "loadavg": os.getloadavg(),
    }
    Path(args.save).write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc["coverage90"]))


if __name__ == "__main__":
    main()
