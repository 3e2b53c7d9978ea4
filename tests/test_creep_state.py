"""Creep as an estimated state: the RTS smoother beats the raw difference, its sd is calibrated,
noise levels come from the recording, any spacing, standstill, vmap; to_dataset integration."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.data.creep_state import difference_sd, smooth_creep, smooth_recording
from jadhesion.data.dataset import to_dataset
from jadhesion.data.sensors import SensorModel
from jadhesion.data.simulator import simulate
from jadhesion.data.vehicle import LOCO_22E

#: White speed noise only (2e-3 m/s): the smoother's model is then exact about the sensors.
WHITE = SensorModel(2e-3, 0.0, 0.1, 0.0, 0.0, 0.0)


def _errors(result):
    est = smooth_recording(result)
    true = result.latent["creepage"]
    return est, np.asarray(est.creep) - true, result.columns["creepage"] - true


def test_smoothed_creep_beats_the_raw_difference_with_calibrated_sd():
    for scenario in ("dry", "sand"):
        est, smooth_err, raw_err = _errors(simulate(scenario, 0, sensors=WHITE))
        rms = lambda e: float(np.sqrt(np.mean(e**2)))  # noqa: E731
        assert rms(smooth_err) < 0.6 * rms(raw_err), scenario
        z = smooth_err / np.asarray(est.creep_sd)
        # errors are correlated over ~10 samples: ~200 effective samples, var(z) within ±30 %
        assert 0.7 < np.var(z) < 1.3, (scenario, np.var(z))
        np.testing.assert_allclose(est.measurement_sd, 2e-3, rtol=0.1)


def test_realistic_and_clean_sensors_smoothing_does_no_harm():
    for sensors in ("realistic", "clean"):
        _, smooth_err, raw_err = _errors(simulate("wet", 1, sensors=sensors))
        assert np.sqrt(np.mean(smooth_err**2)) < np.sqrt(np.mean(raw_err**2)), sensors


def test_difference_sd_recovers_white_noise_on_a_smooth_signal():
    t = np.linspace(0.0, 100.0, 20000)
    y = np.sin(0.3 * t) + 1e-3 * np.asarray(jax.random.normal(jax.random.PRNGKey(2), t.shape))
    assert float(difference_sd(jnp.asarray(y))) == pytest.approx(1e-3, rel=0.05)


def _signals(n, key, standstill=False, jitter=False):
    k1, k2, k3 = jax.random.split(key, 3)
    dt = 0.02 * (1.0 + (0.5 if jitter else 0.0) * jax.random.uniform(k3, (n - 1,)))
    t = jnp.concatenate([jnp.zeros(1), jnp.cumsum(dt)])
    v = jnp.zeros(n) if standstill else 1.0 + 0.01 * t
    w = 0.005 + 0.002 * jnp.sin(t)
    return (
        t,
        v + w + 1e-3 * jax.random.normal(k1, (n,)),
        v + 1e-3 * jax.random.normal(k2, (n,)),
        4e4 * jnp.ones(n),
    )


def _smooth(sig):
    veh = LOCO_22E
    return smooth_creep(*sig, veh.wheelset_inertia_kgm2, veh.wheel_radius_m, veh.axle_load_kg)


def test_any_spacing_standstill_and_vmap():
    for kwargs in ({"jitter": True}, {"standstill": True}):
        est = _smooth(_signals(300, jax.random.PRNGKey(3), **kwargs))
        assert all(bool(jnp.all(jnp.isfinite(x))) for x in est), kwargs
    sigs = [_signals(300, jax.random.PRNGKey(k)) for k in (4, 5)]
    batch = jax.vmap(lambda *a: _smooth(a))(*(jnp.stack(x) for x in zip(*sigs, strict=True)))
    np.testing.assert_allclose(batch.creep[1], _smooth(sigs[1]).creep, rtol=1e-9, atol=1e-12)


def test_to_dataset_smoothed_default_and_raw_option():
    result = simulate("dry", 2, n_samples=400)
    smooth, raw = to_dataset(result), to_dataset(result, creep="raw")
    assert raw.slip_sd is None and smooth.slip_sd.shape == (400,)
    np.testing.assert_allclose(raw.creep, result.columns["creepage"])
    np.testing.assert_array_equal(smooth.adhesion, raw.adhesion)
    stacked = jax.tree_util.tree_map(lambda *a: jnp.stack(a), raw, raw)  # None fields stack/vmap
    assert stacked.slip_sd is None
    assert jax.vmap(lambda d: jnp.sum(d.creep))(stacked).shape == (2,)
    with pytest.raises(ValueError):
        to_dataset(result, creep="kalman")
