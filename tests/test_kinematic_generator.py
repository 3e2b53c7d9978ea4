"""The kinematic generator (validation/kinematic_generator.py): deterministic, its logger file read
back by jadhesion in SI units to within the logger's quantisation, and its torque the wheelset
balance of the prescribed motion."""

import math

import numpy as np
import pytest

from jadhesion.data.recording import load_recording
from validation import kinematic_generator as kg
from validation.foreign import physics


def test_deterministic_per_seed():
    a, b = kg.generate(4, "braking", duration_s=5.0), kg.generate(4, "braking", duration_s=5.0)
    c = kg.generate(5, "braking", duration_s=5.0)
    assert all(np.array_equal(a.columns[k], b.columns[k]) for k in a.columns)
    assert not np.array_equal(a.columns["v_Lok"], c.columns["v_Lok"])


@pytest.mark.parametrize("kind", kg.KINDS)
def test_logger_file_reads_back_in_si_units(kind, tmp_path):
    """Noise-free: the file's km/h, rpm, kN·m and ms since the epoch come back as m/s, m/s at the
    wheel radius, N·m and s, each within half its quantisation step; the torque is the wheelset's
    balance ``μ m g r + J ω̇`` of the prescribed motion."""
    rec = kg.generate(0, kind, duration_s=10.0, rate_hz=50.0, speed_noise=0.0, torque_noise_nm=0.0)
    columns = load_recording(kg.write(rec, tmp_path / f"{kind}.csv")).columns
    veh = physics.VEHICLES["bobo_20t"]
    lat = rec.latent
    np.testing.assert_allclose(columns["time"] - columns["time"][0], lat["time"], atol=1e-6)
    np.testing.assert_allclose(columns["vehicle_speed"], lat["vehicle_speed"], atol=0.005 / 3.6 + 1e-9)
    rpm_step = 0.05 * 2.0 * math.pi / 60.0 * veh.wheel_radius_m
    np.testing.assert_allclose(columns["wheel_speed"], lat["vehicle_speed"] + lat["slip"], atol=rpm_step)
    omega = (lat["vehicle_speed"] + lat["slip"]) / veh.wheel_radius_m
    mu = (columns["traction_torque"] - veh.wheelset_inertia_kgm2 * np.gradient(omega, lat["time"])) / (
        veh.axle_weight_n * veh.wheel_radius_m
    )
    np.testing.assert_allclose(mu, lat["mu"], atol=5.0 / (veh.axle_weight_n * veh.wheel_radius_m) + 1e-9)
    assert np.all(np.sign(lat["mu"]) == np.sign(lat["creep"]))
