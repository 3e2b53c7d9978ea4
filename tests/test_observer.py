"""Adhesion observer (paper 001 eqs 16–19): exact FOH filter, recovery, variants, edge cases."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.data.observer import lowpass_foh, observe_adhesion, observer_core
from jadhesion.data.scenarios import SCENARIOS
from jadhesion.data.simulator import simulate
from jadhesion.data.vehicle import LOCO_22E

T0 = 0.05


def _uneven_time(n=300, seed=0):
    steps = np.random.default_rng(seed).uniform(0.002, 0.03, n - 1)
    return jnp.asarray(np.concatenate([[0.0], np.cumsum(steps)]))


def test_lowpass_is_exact_for_a_ramp_at_variable_spacing():
    t = _uneven_time()
    a, b = 1.3, -2.7
    x = lowpass_foh(t, a + b * t, T0)
    exact = a + b * t - b * T0 * (1.0 - jnp.exp(-t / T0))  # ẋ = (u − x)/T0, x(0) = u(0)
    np.testing.assert_allclose(x, exact, atol=1e-12)


def test_lowpass_of_a_sine_within_the_interpolation_bound():
    t = jnp.arange(0.0, 2.0, 0.005)
    w = 2 * jnp.pi * 2.0
    x = lowpass_foh(t, jnp.sin(w * t), T0)
    wt = w * T0
    exact = (jnp.sin(w * t) - wt * jnp.cos(w * t) + wt * jnp.exp(-t / T0)) / (1 + wt**2)
    bound = 0.005**2 * w**2 / 8  # max error of linear interpolation, not amplified by a low-pass
    assert float(jnp.max(jnp.abs(x - exact))) < bound


def test_lowpass_matches_fine_forward_euler():
    t = np.asarray(_uneven_time(60, seed=1))
    u = np.cos(7.0 * t) + 0.5 * t
    h = 2e-6
    fine = np.arange(0.0, t[-1] + h / 2, h)
    uf = np.interp(fine, t, u)
    xs = np.empty_like(fine)
    xs[0] = u[0]
    decay = 1.0 - h / T0
    for i in range(len(fine) - 1):  # the reference: forward Euler at a ~8000× finer step
        xs[i + 1] = xs[i] * decay + (h / T0) * uf[i]
    x = np.asarray(lowpass_foh(jnp.asarray(t), jnp.asarray(u), T0))
    np.testing.assert_allclose(x, np.interp(t, fine, xs), atol=1e-4)  # FE error ~ h/T0 · |u − x|


def _smooth_recording():
    """Noise-free dry test without slip excursions (the observer lag is small there)."""
    smooth = SCENARIOS["dry"].replace(max_creep=SCENARIOS["dry"].creep_base, minor_excursions=0)
    return simulate(smooth, seed=3, noise=False)


def test_recovers_true_adhesion_on_a_noise_free_recording():
    rec = _smooth_recording()
    cols, true_mu = rec.columns, rec.latent["adhesion"]
    settled = cols["time"] > 5 * LOCO_22E.observer_time_constant_s
    mu_hat = observe_adhesion(
        jnp.asarray(cols["time"]),
        jnp.asarray(cols["wheel_speed"]),
        jnp.asarray(cols["traction_torque"]),
        LOCO_22E,
    )
    np.testing.assert_allclose(mu_hat, cols["adhesion"], atol=1e-12)
    assert np.max(np.abs(np.asarray(mu_hat) - true_mu)[settled]) < 0.002


def test_filtered_torque_variant_is_the_lowpassed_true_adhesion():
    rec = _smooth_recording()
    cols = {k: jnp.asarray(v) for k, v in rec.columns.items()}
    mu_f = observe_adhesion(
        cols["time"], cols["wheel_speed"], cols["traction_torque"], LOCO_22E, variant="filtered_torque"
    )
    lagged = lowpass_foh(cols["time"], jnp.asarray(rec.latent["adhesion"]), T0)
    settled = np.asarray(cols["time"]) > 5 * T0
    assert np.max(np.abs(np.asarray(mu_f - lagged))[settled]) < 0.002


def test_filtered_torque_variant_removes_torque_noise():
    t = jnp.arange(0.0, 20.0, 0.02)
    noise = 1000.0 * jax.random.normal(jax.random.PRNGKey(0), t.shape)
    wheel = jnp.full_like(t, 1.0)
    std = {
        v: float(jnp.std(observe_adhesion(t, wheel, 40e3 + noise, LOCO_22E, v)[50:]))
        for v in ("paper", "filtered_torque")
    }
    expected = 1000.0 / (LOCO_22E.axle_weight_n * LOCO_22E.wheel_radius_m)
    assert std["paper"] == pytest.approx(expected, rel=0.1)
    assert std["filtered_torque"] < 0.5 * std["paper"]


def test_finite_at_standstill_and_repeated_times():
    t = jnp.array([0.0, 0.01, 0.01, 0.02, 0.5])  # a zero step must not produce 0/0
    mu = observe_adhesion(t, jnp.zeros(5), jnp.zeros(5), LOCO_22E)
    assert np.all(np.isfinite(mu)) and np.all(np.asarray(mu) == 0.0)


def test_jit_and_vmap_over_signals_and_constants():
    t = jnp.arange(0.0, 1.0, 0.02)
    wheel = jnp.stack([1.0 + 0.1 * t, 1.0 - 0.2 * t])
    torque = jnp.full_like(wheel, 4e4)
    batched = jax.jit(jax.vmap(lambda w, q: observe_adhesion(t, w, q, LOCO_22E)))(wheel, torque)
    single = observe_adhesion(t, wheel[1], torque[1], LOCO_22E)
    np.testing.assert_allclose(batched[1], single, rtol=1e-12)
    core = jax.vmap(observer_core, in_axes=(None, None, None, 0, None, None, None))
    two = core(t, wheel[0], torque[0], jnp.array([3000.0, 0.0]), 0.61, 21500.0, T0)
    np.testing.assert_allclose(two[1], 4e4 / (21500.0 * 9.81 * 0.61))


def test_unknown_variant_is_rejected():
    with pytest.raises(ValueError, match="variant"):
        observe_adhesion(jnp.arange(3.0), jnp.ones(3), jnp.ones(3), LOCO_22E, variant="nope")
