"""Creep as an estimated state: the RTS smoother beats the raw difference, its sd is calibrated,
noise levels come from the recording, any spacing, standstill, vmap; to_dataset integration."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.data import creep_state
from jadhesion.data.creep_state import difference_sd, smooth_creep, smooth_recording
from jadhesion.data.dataset import RAW_SIGNALS, Signals, sd_scale_summary, to_dataset
from jadhesion.data.recording import load_recording
from jadhesion.data.sensors import SensorModel
from jadhesion.data.simulator import simulate
from jadhesion.data.vehicle import LOCO_22E
from validation.foreign_generator import generate, write

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


def _textbook(y, t, r, q):
    """Dense Kalman filter (2-vector update, LAPACK solves) and Rauch–Tung–Striebel smoother in
    NumPy: log-likelihood, smoothed means (n, 4) and covariances (n, 4, 4)."""
    H, R = np.array([[1.0, 0, 1, 0], [1, 0, 0, 0]]), np.diag(r)
    x, p = np.array([y[0, 1], 0, y[0, 0] - y[0, 1], 0]), np.diag([r[1], 1, r[0] + r[1], 1])
    xs, ps, xps, pps, fs, ll = [], [], [], [], [], 0.0
    for k, dt in enumerate(np.diff(t, prepend=t[0])):
        f1, b = np.array([[1, dt], [0, 1]]), np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        F = np.kron(np.eye(2), f1)
        x, p = F @ x, F @ p @ F.T + np.kron(np.diag(q), b)
        xps.append(x), pps.append(p), fs.append(F)
        s, nu = H @ p @ H.T + R, y[k] - H @ x
        ll -= 0.5 * (np.linalg.slogdet(2 * np.pi * s)[1] + nu @ np.linalg.solve(s, nu))
        gain = np.linalg.solve(s, H @ p).T
        x, p = x + gain @ nu, p - gain @ H @ p
        p = 0.5 * (p + p.T)  # unsymmetrised, the dense update drifts at large q
        xs.append(x), ps.append(p)
    for k in range(len(t) - 2, -1, -1):
        g = np.linalg.solve(pps[k + 1], fs[k + 1] @ ps[k]).T
        xs[k] = xs[k] + g @ (xs[k + 1] - xps[k + 1])
        ps[k] = ps[k] + g @ (ps[k + 1] - pps[k + 1]) @ g.T
    return ll, np.array(xs), np.array(ps)


def test_elementwise_filter_and_backward_pass_equal_the_textbook_ones():
    """The fast filter (scalar updates, no dots) and the inverse-free backward pass give the dense
    filter's likelihood and the RTS smoother's means and covariances, on jittered time stamps and
    over the whole q grid's range (so the grid's maximum is the same)."""
    t, yw, yv, _ = (np.asarray(a) for a in _signals(200, jax.random.PRNGKey(6), jitter=True))
    y, r = np.stack([yw, yv], axis=1), np.array([1.2e-6, 0.8e-6])

    @jax.jit
    def fast(q):
        stored, ll = creep_state._filter(jnp.asarray(y), jnp.diff(t), jnp.asarray(r), q, jnp.ones(len(t)))
        return ll, creep_state._smooth(stored, jnp.diff(t))

    for q in ((1e-8, 1e-1), (1e-3, 1e-6), (10.0, 1e3)):
        ll, xs, ps = _textbook(y, t, r, np.array(q))
        ll_fast, (means, (var_v, var_w, cov)) = fast(jnp.asarray(q))
        assert float(ll_fast) == pytest.approx(ll, rel=1e-10, abs=1e-6), q
        scale = np.abs(xs).max(axis=0)  # per state: v, a, w, ẇ differ by orders of magnitude
        np.testing.assert_allclose(np.asarray(means) / scale, xs / scale, rtol=1e-8, atol=1e-10)
        for got, want in ((var_v, ps[:, 0, 0]), (var_w, ps[:, 2, 2]), (cov, ps[:, 0, 2])):
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9 * np.abs(want).max())


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


def test_end_padding_leaves_the_recorded_samples_estimates_bit_for_bit():
    """Padding after the last sample (the last row repeated, mask 0: how recordings of different
    lengths share one compiled program) changes no estimate of the recorded samples, not even in
    the last bit — noise levels, likelihood grid, filter and smoother all skip it — and the padded
    rows stay finite."""
    sig = _signals(300, jax.random.PRNGKey(7), jitter=True)
    ref = _smooth(sig)
    veh = LOCO_22E
    valid = (jnp.arange(512) < 300).astype(float)
    got = smooth_creep(
        *(jnp.pad(a, (0, 212), mode="edge") for a in sig),
        veh.wheelset_inertia_kgm2,
        veh.wheel_radius_m,
        veh.axle_load_kg,
        valid,
    )
    for name, want in ref._asdict().items():
        have = np.asarray(getattr(got, name))
        assert np.isfinite(have).all(), name
        have = have[:300] if have.shape[:1] == (512,) else have
        np.testing.assert_array_equal(have, np.asarray(want), err_msg=name)


def test_to_dataset_runs_at_its_length_bucket_with_the_same_values():
    """``to_dataset`` pads the raw signals to their length bucket and cuts the dataset back: the
    same values as unpadded, and a second length of the bucket (400 and 350 rows: 512) compiles
    no new smoother."""
    result = simulate("dry", 2, n_samples=400)
    padded, plain = to_dataset(result), to_dataset(result, pad=False)
    for name, want in plain._asdict().items():
        have = getattr(padded, name)
        assert (have is None) == (want is None), name
        if want is not None:
            np.testing.assert_array_equal(np.asarray(have), np.asarray(want), err_msg=name)
    shorter = Signals({c: np.asarray(result.columns[c])[:350] for c in RAW_SIGNALS}, result.vehicle)
    compiled = smooth_creep._cache_size()
    data = to_dataset(shorter)
    assert smooth_creep._cache_size() == compiled and data.creep.shape == (350,)
    np.testing.assert_array_equal(np.asarray(data.creep), np.asarray(to_dataset(shorter, pad=False).creep))


def test_coasting_sd_scale_measures_an_understated_sd():
    """On coasting samples the smoothed slip is its own error (after the small true slip, a line in
    mu_hat |v|, is removed): stated sd half the true one reads a scale of 2, within the median's
    sampling error at 2 000 samples; too few coasting samples, or an sd already right or wide, read 1."""
    rng = np.random.default_rng(0)
    n = 2000
    v = np.full(n, 5.0)
    mu = rng.uniform(-0.008, 0.008, n)
    true_slip = 0.03 * mu * v
    slip = true_slip + 1e-3 * rng.standard_normal(n)
    scale, count = creep_state.coasting_sd_scale(slip, np.full(n, 5e-4), mu, v)
    assert int(count) == n and abs(float(scale) - 2.0) < 0.15, float(scale)
    assert float(creep_state.coasting_sd_scale(slip, np.full(n, 2e-3), mu, v)[0]) == 1.0
    traction = mu + 0.05  # nothing coasts
    assert float(creep_state.coasting_sd_scale(slip, np.full(n, 5e-4), traction, v)[0]) == 1.0
    few = np.where(np.arange(n) < creep_state.COAST_MIN_SAMPLES - 1, mu, traction)
    assert float(creep_state.coasting_sd_scale(slip, np.full(n, 5e-4), few, v)[0]) == 1.0
    padded = np.arange(n) < n // 2  # padding takes no part
    half, count = creep_state.coasting_sd_scale(slip, np.full(n, 5e-4), mu, v, padded)
    assert int(count) == n // 2 and abs(float(half) - 2.0) < 0.2


def test_to_dataset_states_the_slip_error_of_a_coasting_recording(tmp_path):
    """The independent generator's coloured sensor noise (not in the smoother's model) makes the
    smoother's sd 2× too small on this recording; scaled by its coasting, the stated sd is within
    25 % of the slip's true error."""
    made = generate(100, effect="none", sensor="mild")
    recording = load_recording(write(made, tmp_path / "coasting.csv"))
    data = to_dataset(recording, pad=False)
    est = smooth_recording(recording)
    true = np.interp(recording.columns["time"], made.latent["time"], made.latent["slip"])
    moving = np.abs(np.asarray(data.adhesion)) >= 0.02
    ratio = lambda sd: float(np.sqrt(np.mean(((np.asarray(data.slip) - true) / sd)[moving] ** 2)))  # noqa: E731
    assert ratio(np.asarray(est.slip_sd)) > 1.6
    assert 0.8 < ratio(np.asarray(data.slip_sd)) < 1.25, ratio(np.asarray(data.slip_sd))
    # the dataset says by how much (the fit's and posterior's JSON report it: sd_scale_summary)
    np.testing.assert_allclose(
        np.asarray(data.slip_sd), np.asarray(data.slip_sd_scale) * np.asarray(est.slip_sd)
    )
    summary = sd_scale_summary(data)
    assert summary["min"] == summary["max"] > 1.6
    assert sd_scale_summary(to_dataset(recording, creep="raw")) is None
