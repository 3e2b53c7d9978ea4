"""Kiencke's model fitted offline: recovery of known (p1, p2, a_s) within the noise's standard errors."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.data.dataset import PolachDataset
from jadhesion.identify import kiencke_fit as kf
from jadhesion.identify.batch_fit import pad_dataset
from jadhesion.models.kiencke import kiencke_adhesion

TRUE = np.array([80.0, 100.0, 35.0])  # the paper's "normal" rail, a_s = 35
SIGMA = 0.002
N = 300


def _dataset(n=N, sigma=SIGMA, seed=1, speed=2.0):
    lam = jnp.linspace(0.005, 0.25, n)  # both sides of λ_m = 0.1
    mu = kiencke_adhesion(lam, *TRUE) + sigma * jax.random.normal(jax.random.key(seed), (n,))
    v = jnp.full(n, speed)
    return PolachDataset(lam, lam * v, mu, v, jnp.asarray(130.0))


@pytest.fixture(scope="module")
def stderr():
    """Gauss–Newton standard errors of (p1, p2, a_s) at the truth for σ = SIGMA."""
    lam = jnp.linspace(0.005, 0.25, N)
    jac = jax.jacfwd(lambda p: kiencke_adhesion(lam, *p))(jnp.asarray(TRUE))
    return SIGMA * np.sqrt(np.diag(np.linalg.inv(np.asarray(jac.T @ jac))))


def test_search_coordinates_round_trip():
    z = kf.to_search(jnp.asarray(TRUE))
    np.testing.assert_allclose(z, [np.log10(35.0), -1.0, 35.0 / 100.0], rtol=1e-12)
    np.testing.assert_allclose(kf.to_params(z), TRUE, rtol=1e-12)


@pytest.mark.parametrize("method", kf.METHODS)
def test_recovers_known_parameters_within_noise(method, stderr):
    assert np.all(stderr / TRUE < 0.05)  # the test has power: errors of a few %
    fit = kf.fit_kiencke(_dataset(), method, jax.random.key(0), pop_size=30, max_iter=200)
    # LM is the least-squares estimate (z-score ~ N(0,1)); the population methods minimise the
    # MAE, whose estimate is ~√(π/2) noisier: 5 standard errors covers both.
    assert np.all(np.abs(np.asarray(fit.params) - TRUE) < 5.0 * stderr), (fit.params, stderr)
    assert fit.status == 0  # converged
    assert SIGMA * 0.6 < float(fit.mae) < SIGMA * 1.0  # MAE of N(0, σ) noise is 0.80 σ
    np.testing.assert_allclose([fit.creep_opt, fit.mu_max], [0.1, 0.35], rtol=0.03)


def test_wrong_slope_is_rejected(stderr):
    """Power: a_s = 38 (8.6 % off) lies many standard errors from the fitted value."""
    fit = kf.fit_kiencke(_dataset(), "lm", jax.random.key(0))
    assert abs(float(fit.params[2]) - 38.0) > 5.0 * stderr[2]


def test_standstill_and_coasting_samples_are_ignored():
    clean = _dataset()
    bad = clean._replace(
        creep=clean.creep.at[:40].set(1e3).at[40:60].set(jnp.nan),
        adhesion=clean.adhesion.at[60:80].set(0.0),
        vehicle_speed=clean.vehicle_speed.at[:40].set(0.0),
    )
    ref = kf.fit_kiencke(
        clean._replace(
            creep=clean.creep[80:],
            slip=clean.slip[80:],
            adhesion=clean.adhesion[80:],
            vehicle_speed=clean.vehicle_speed[80:],
        ),
        "lm",
    )
    fit = kf.fit_kiencke(bad, "lm")
    assert int(fit.n_used) == N - 80
    np.testing.assert_allclose(fit.params, ref.params, rtol=1e-6)
    assert np.all(np.isfinite(np.asarray(fit.params)))


def test_too_few_samples_is_not_run_and_finite():
    data = _dataset()._replace(vehicle_speed=jnp.zeros(N))
    fit = kf.fit_kiencke(data, "lm")
    assert int(fit.status) == 5 and np.all(np.isfinite(np.asarray(fit.params)))


def test_vmap_over_datasets_matches_single_fits():
    data = [_dataset(seed=s) for s in (2, 3)]
    stacked = jax.tree.map(lambda *a: jnp.stack(a), *data)
    keys = jax.random.split(jax.random.key(0), 2)
    batch = jax.vmap(lambda d, k: kf.fit_kiencke(d, "lm", k))(stacked, keys)
    for i, d in enumerate(data):
        np.testing.assert_allclose(batch.params[i], kf.fit_kiencke(d, "lm", keys[i]).params, rtol=1e-9)


@pytest.mark.parametrize("method", ["lm", "itlbo"])
def test_padded_fit_equals_unpadded(method):
    """``fit --model kiencke`` pads to length buckets: the padding carries no weight, so the
    population method gives the same parameters bit for bit and LM to round-off."""
    data = _dataset(n=250, seed=4)
    options = {"pop_size": 10, "max_iter": 40}
    a = kf.fit_kiencke(data, method, jax.random.key(2), **options)
    b = kf.fit_kiencke(pad_dataset(data), method, jax.random.key(2), **options)
    assert int(b.n_used) == int(a.n_used) == 250
    if method == "lm":
        np.testing.assert_allclose(b.params, a.params, rtol=1e-9)
    else:
        np.testing.assert_array_equal(b.params, a.params)
    assert float(b.mae) == pytest.approx(float(a.mae), rel=1e-12)


def test_unknown_method():
    with pytest.raises(ValueError, match="unknown method"):
        kf.fit_kiencke(_dataset(), "nelder")


def test_fit_document_contract():
    doc = kf.fit_document(kf.fit_kiencke(_dataset(), "lm"))
    assert set(doc["params"]) == {"p1", "p2", "a_s"} and doc["status"] == "converged"
    assert {"mae", "mu_max", "creep_opt", "iterations", "evaluations", "converged"} <= set(doc)
    assert doc["creep_opt"] == pytest.approx(doc["params"]["p2"] ** -0.5)
