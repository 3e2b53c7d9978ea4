"""Sensor model: quantisation, AR(1) colour, scaling, and the simulator's recorded noise levels."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.data.sensors import CLEAN, REALISTIC, SensorModel, ar1_noise, measure, quantise, sensor_model
from jadhesion.data.simulator import simulate


def test_quantise_rounds_to_the_resolution_and_zero_means_none():
    x = jnp.array([0.0014, -0.0026, 1.23456])
    np.testing.assert_allclose(quantise(x, 1e-3), [0.001, -0.003, 1.235], atol=1e-15)
    np.testing.assert_array_equal(quantise(x, 0.0), x)


def test_ar1_noise_has_its_sd_and_correlation():
    n, sd, tau, dt = 40000, 2e-3, 0.1, 0.02
    c = np.asarray(ar1_noise(jax.random.PRNGKey(0), n, sd, tau, dt))
    rho = np.exp(-dt / tau)
    ess = n * (1 - rho) / (1 + rho)  # effective samples of an AR(1) series
    assert np.std(c) == pytest.approx(sd, rel=4 / np.sqrt(2 * ess))
    assert np.corrcoef(c[1:], c[:-1])[0, 1] == pytest.approx(rho, abs=0.01)


def test_zero_noise_measures_the_truth_and_scaling():
    x = jnp.linspace(0.5, 0.7, 50)
    zero = SensorModel(0.0, 0.0, 0.1, 0.0, 0.0, 0.0)
    out = measure(jax.random.PRNGKey(1), x, x, 1e4 * x, zero, 0.02)
    for a, b in zip(out, (x, x, 1e4 * x), strict=True):
        np.testing.assert_array_equal(a, b)
    model = sensor_model("realistic", 1700.0, 2.0)
    assert model.speed_white_mps == 2 * REALISTIC.speed_white_mps and model.torque_white_nm == 3400
    assert sensor_model("clean", 1700.0).speed_white_mps == CLEAN.speed_white_mps
    with pytest.raises(ValueError):
        sensor_model("perfect", 1.0)
    with pytest.raises(ValueError):
        sensor_model("clean", 1.0, -1.0)


def test_simulated_recordings_carry_the_sensor_models_noise():
    for sensors, scale in (("realistic", 1.0), ("realistic", 3.0), ("clean", 1.0)):
        r = simulate("wet", 4, sensors=sensors, sensor_noise=scale)
        error = r.columns["slip_velocity"] - r.latent["slip_velocity"]  # two independent channels
        expected = np.sqrt(2) * sensor_model(sensors, 0.0, scale).speed_sd()
        assert np.std(error) == pytest.approx(expected, rel=0.15), (sensors, scale)
        assert r.truth["noise"]["speed_mps"] == pytest.approx(expected / np.sqrt(2))
    assert 1e-3 <= REALISTIC.speed_sd() <= 1e-2
