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


def test_concealed_effects_are_what_they_say(tmp_path):
    """Noise-free, against the same run without the effect: a rail change leaves μ before
    ``CHANGE_AT`` and lowers it after; a radius error 1 + m divides the logged wheel speed (read at
    the sidecar's nominal radius) by 1 + m; a torque offset adds m · m_axle g r to the torque."""
    quiet = {"duration_s": 10.0, "rate_hz": 50.0, "speed_noise": 0.0, "torque_noise_nm": 0.0}
    veh = physics.VEHICLES["bobo_20t"]

    def read(effect, m):
        rec = kg.generate(0, "mainline", effect=effect, magnitude=m, **quiet)
        return rec, load_recording(kg.write(rec, tmp_path / f"{effect}.csv")).columns

    base, clean = read("none", 0.0)
    rail, _ = read("rail_change", 0.2)
    after = base.latent["time"] >= kg.CHANGE_AT * 10.0
    np.testing.assert_array_equal(rail.latent["mu"][~after], base.latent["mu"][~after])
    ratio = rail.latent["mu"][after] / base.latent["mu"][after]
    assert np.all(ratio < 1.0) and ratio.min() < 0.85  # μ0 scales the saturated part, not the slope
    assert rail.truth["change_time_s"] == pytest.approx(6.0) and rail.truth["magnitude"] == 0.2
    _, radius = read("wheel_radius_error", 0.03)
    rpm_step = 0.05 * 2.0 * math.pi / 60.0 * veh.wheel_radius_m
    np.testing.assert_allclose(radius["wheel_speed"], clean["wheel_speed"] / 1.03, atol=rpm_step)
    _, offset = read("torque_offset", 0.02)
    shift = 0.02 * veh.axle_weight_n * veh.wheel_radius_m
    np.testing.assert_allclose(offset["traction_torque"] - clean["traction_torque"], shift, atol=10.0 + 1e-9)
    with pytest.raises(ValueError, match="unknown effect"):
        kg.generate(0, effect="ice")
