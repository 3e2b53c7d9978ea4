"""Online Kiencke identification (paper 000): exactness, tracking, robustness, transforms, experiment."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.experiments import online as ex
from jadhesion.identify import online as ol

SHORT = 60   # steps of the short records (one compiled shape shared by several tests)
RUNS = 6     # Monte Carlo runs in the experiment tests (one compiled batch shape)
ALGORITHMS = {"1": ol.algorithm1_params, "2": ol.algorithm2_params}


def _relerr(trace, truth):
    return np.abs(np.stack([trace.p1, trace.p2], -1) / np.asarray(truth) - 1.0)


@pytest.fixture(scope="module")
def clean():
    return ex.scenario(jax.random.key(0), noise=0.0)


@pytest.mark.parametrize("alg", ALGORITHMS)
def test_noise_free_recovers_parameters_exactly(alg, clean):
    err = _relerr(ol.identify(ALGORITHMS[alg](), clean.lam, clean.mu), clean.truth)
    assert err[20:ex.CHANGES[0]].max() < 1e-6


@pytest.mark.parametrize("alg", ALGORITHMS)
def test_tracks_the_first_rail_change(alg, clean):
    err = _relerr(ol.identify(ALGORITHMS[alg](), clean.lam, clean.mu), clean.truth)
    assert err[ex.CHANGES[0] - 1].max() < 1e-6           # converged on dry
    assert err[ex.CHANGES[1] - 1].max() < 1e-2           # and on normal after the change


@pytest.mark.parametrize("case", ["zero_excitation", "constant_creep", "huge_noise"])
@pytest.mark.parametrize("alg", ALGORITHMS)
def test_never_nan(alg, case):
    n = 300
    lam = {"zero_excitation": jnp.zeros(n), "constant_creep": jnp.full(n, 0.1),
           "huge_noise": jnp.linspace(0.0, 0.3, n)}[case]
    mu = 0.3 * jnp.ones(n) * (case != "zero_excitation")
    if case == "huge_noise":
        mu = mu + 10.0 * jax.random.normal(jax.random.key(1), (n,))
    trace = ol.identify(ALGORITHMS[alg](), lam, mu)
    for leaf in (trace.p1, trace.p2, trace.mu_max, trace.eta, trace.snr):
        assert not np.isnan(np.asarray(leaf)).any()
    if case == "zero_excitation":                          # no information: estimate stays at x0
        np.testing.assert_allclose(trace.p1, ol.DEFAULT_X0[0])
        np.testing.assert_allclose(trace.p2, ol.DEFAULT_X0[1])


def test_jitted_scan_matches_python_loop_of_steps():
    sc = ex.scenario(jax.random.key(2), n_steps=12, changes=(6,))
    params = ol.algorithm1_params()
    fast = ol.identify(params, sc.lam, sc.mu)
    state, infos, step = ol.init(params), [], jax.jit(ol.step)
    for obs in zip(sc.lam, sc.mu):
        state, info = step(params, state, obs)
        infos.append(info)
    slow = jax.tree.map(lambda *xs: jnp.stack(xs), *infos)
    jax.tree.map(lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9), fast, slow)


def test_vmap_over_seeds_matches_loop():
    sc = ex.scenario(jax.random.key(3), runs=3, n_steps=SHORT, changes=(SHORT // 2,))
    params = ol.algorithm1_params()
    batched = ex.run_batch(params, sc)
    for r in range(3):
        one = ol.identify(params, sc.lam, sc.mu[r])
        jax.tree.map(lambda a, b: np.testing.assert_allclose(a[r], b, rtol=1e-7), batched, one)


def test_vmap_over_params():
    sc = ex.scenario(jax.random.key(4), n_steps=SHORT, changes=(SHORT // 2,))
    configs = [ol.algorithm1_params(), ol.algorithm2_params(), ol.rls_params(0.98)]
    batched = jax.vmap(ol.identify, (0, None, None))(ol.stack_params(configs), sc.lam, sc.mu)
    for i, params in enumerate(configs):
        one = ol.identify(params, sc.lam, sc.mu)
        np.testing.assert_allclose(batched.p1[i], one.p1, rtol=1e-10)
    assert batched.eta[2].min() == batched.eta[2].max() == 0.98     # constant forgetting


def test_snr_step_applies_only_after_step_5_and_sets_eta_max():
    sc = ex.scenario(jax.random.key(5), n_steps=SHORT, changes=())
    trace = ol.identify(ol.algorithm1_params(), sc.lam, sc.mu)
    hit = np.asarray(trace.snr_hit)
    assert not hit[:5].any() and hit[5:].any()
    assert np.all(np.asarray(trace.eta)[hit] == 1.0)


def test_snr_interval_calibration_reproduces_defaults():
    lo, hi = ex.calibrate_snr(jax.random.key(6), runs=RUNS)
    np.testing.assert_allclose(lo, ol.DEFAULT_SNR_LO, rtol=0.1)
    np.testing.assert_allclose(hi, ol.DEFAULT_SNR_HI, rtol=0.1, atol=0.6)   # few runs: loose


def test_run_small_returns_contract_and_plot(tmp_path):
    result = ex.run(runs=RUNS, plot_dir=str(tmp_path), progress=False)
    keys = {"k_p1_1pct", "k_p2_1pct", "k_mumax_01pct", "k_track_after_change", "fluctuation"}
    for alg in ("1", "2"):
        m = result["algorithms"][alg]
        assert keys <= set(m) and all(k + "_iqr" in m for k in keys)
        assert 0.0 <= m["never_p2_1pct"] <= 1.0
    assert {"A2+range", "A2+weight", "A2+snr", "A1-range", "A1-weight", "A1-snr"} <= set(
        result["ablation"])
    assert {"rls_0.98", "batch_ls"} <= set(result["baselines"])
    assert result["paper"]["k_p2_1pct"] == 250
    assert (tmp_path / "online_kiencke.png").stat().st_size > 10_000
    text = ex.format_text(result)
    assert "paper" in text and ("holds" in text or "DOES NOT HOLD" in text)
