"""The Student-t errors-in-variables likelihood, ``posterior --likelihood student`` and the tail check."""

import json
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from jadhesion.cli import main
from jadhesion.cli.posterior_run import tail_check
from jadhesion.identify.batch_fit import bucketed
from jadhesion.identify.ensemble import ChainTooShortWarning
from jadhesion.identify.laplace import colour_check, initial_spread, lm_optimum, lm_start
from jadhesion.identify.likelihood import (
    LOG_SCALE_BOUNDS,
    STUDENT_NU,
    batch_log_posterior,
    curve_moments,
    log_likelihood,
    log_posterior,
)
from jadhesion.identify.mcmc import sample_posterior
from jadhesion.status import Status
from validation.calibration import synthetic_dataset

THETA = np.array([0.5, 0.3, 0.35, 0.4, 0.6])
LO, HI = jnp.zeros(5), jnp.ones(5)


@pytest.fixture(scope="module")
def data():
    return synthetic_dataset(np.random.default_rng(0), THETA, n=300)


def test_student_log_density_is_scipys_t_with_the_effective_scale(data):
    theta, log_sigma = jnp.asarray([0.45, 0.35, 0.33, 0.5, 0.5]), np.log(0.02)
    r = np.asarray(data.adhesion) - np.asarray(curve_moments(theta, data)[0])
    expected = stats.t.logpdf(r, STUDENT_NU, scale=0.02).sum()
    got = float(log_likelihood(theta, log_sigma, data, "student"))
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    # errors in variables: sample i has the t scale sqrt(sigma² + V_i)
    eiv = data._replace(slip_sd=0.3 * jnp.abs(data.slip) + 1e-3)
    mean, var = (np.asarray(a) for a in curve_moments(theta, eiv))
    scale = np.sqrt(0.02**2 + var)
    assert np.ptp(scale) > 0.01  # heteroscedastic indeed
    expected = stats.t.logpdf(np.asarray(eiv.adhesion) - mean, STUDENT_NU, scale=scale).sum()
    np.testing.assert_allclose(float(log_likelihood(theta, log_sigma, eiv, "student")), expected, rtol=1e-12)


def test_student_is_finite_on_extreme_inputs_and_batches(data):
    rng = np.random.default_rng(1)
    inside = np.column_stack([rng.uniform(0, 1, (32, 5)), rng.uniform(*LOG_SCALE_BOUNDS, 32)])
    inside[0, :5], inside[1, :5], inside[2, 5], inside[3, 5] = 0.0, 1.0, *LOG_SCALE_BOUNDS
    outside = inside.copy()
    outside[:8, 5] = LOG_SCALE_BOUNDS[0] - 1.0
    outside[8:16, 2] = 1.5
    outside[16:24, 0] = np.nan
    outside[24:, 5] = np.inf
    wild = data._replace(adhesion=data.adhesion.at[:5].set(jnp.asarray([1e6, -1e6, 1e150, 0.0, 3.0])))
    for d in (data, wild):
        lp_in = np.asarray(batch_log_posterior(jnp.asarray(inside), d, LO, HI, 0.0, "student"))
        lp_out = np.asarray(batch_log_posterior(jnp.asarray(outside), d, LO, HI, 0.0, "student"))
        assert np.all(np.isfinite(lp_in)) and np.all(lp_out == -np.inf)
        one = [float(log_posterior(jnp.asarray(p), d, LO, HI, 0.0, "student")) for p in inside[:4]]
        np.testing.assert_allclose(lp_in[:4], one, rtol=1e-12)
        grads = jax.vmap(jax.grad(log_posterior), in_axes=(0, None, None, None, None, None))(
            jnp.asarray(inside[4:]), d, LO, HI, 0.0, "student"
        )
        assert np.all(np.isfinite(np.asarray(grads)))
    # beyond the largest double a residual's square overflows: -inf, never NaN
    huge = data._replace(adhesion=data.adhesion.at[0].set(1e300))
    assert float(log_posterior(jnp.asarray(inside[5]), huge, LO, HI, 0.0, "student")) == -np.inf


def _outliers(data, n_out=15):
    """``n_out`` gross outliers (−0.25, 19 noise sd: a slip spike's mu_hat) among the samples of
    largest creep, where the curve's level is mu0's."""
    idx = np.argsort(np.asarray(data.creep))[-3 * n_out :: 3]
    return data._replace(adhesion=data.adhesion.at[idx].add(-0.25))


def test_student_is_not_pulled_by_gross_outliers_where_the_gaussian_is(data):
    bad = _outliers(data)
    theta0 = np.asarray(lm_optimum(bad))
    med, width = {}, {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ChainTooShortWarning)
        clean = sample_posterior(data, THETA, walkers=16, steps=800, likelihood="student", seed=2)
        for lik in ("gauss", "student"):
            res = sample_posterior(bad, theta0, walkers=16, steps=800, likelihood=lik, seed=2)
            med[lik], width[lik] = (
                res.params["mu0"]["median"],
                res.params["mu0"]["q95"] - res.params["mu0"]["q05"],
            )
    sd = (clean.params["mu0"]["q95"] - clean.params["mu0"]["q05"]) / 3.29  # mu0's sd on clean data
    assert abs(clean.params["mu0"]["median"] - THETA[2]) < 3 * sd
    assert abs(med["student"] - THETA[2]) < 3 * sd
    assert abs(med["gauss"] - THETA[2]) > 5 * sd  # pulled (up here: A and B take the outliers' drop)
    assert width["gauss"] > 2 * width["student"]  # and widened by the outliers' variance


def _csv(d, path):
    rows = np.column_stack([np.asarray(d.creep), np.asarray(d.vehicle_speed), np.asarray(d.adhesion)])
    np.savetxt(path, rows, delimiter=",", header="creepage,vehicle_speed,adhesion", comments="")
    return str(path)


def _posterior(capsys, path, *extra):
    # one slip law's chains (--single-law): the likelihood is the subject here, not the slip law
    argv = ["posterior", path, "--walkers", "16", "--steps", "150", "--single-law", "--json", *extra]
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_cli_likelihood_choice_and_auto_note(tmp_path, capsys):
    d = synthetic_dataset(np.random.default_rng(5), THETA, n=300)
    gaussian, spiky = _csv(d, tmp_path / "g.csv"), _csv(_outliers(d), tmp_path / "s.csv")
    doc = _posterior(capsys, gaussian)
    temp = doc["tempering"]
    assert doc["likelihood"] == "gauss" and doc["likelihood_note"].startswith("auto: Gaussian tempered")
    assert not temp["heavy_tails"] and temp["excess_kurtosis"] < temp["kurtosis_threshold"]
    assert "tails near Gaussian" in doc["likelihood_note"] and temp["weight"] == pytest.approx(
        1 / temp["kappa"]
    )
    doc = _posterior(capsys, spiky)  # auto stays Gaussian and says the tails are heavy
    temp = doc["tempering"]
    assert doc["likelihood"] == "gauss" and "tails heavy: --likelihood student" in doc["likelihood_note"]
    assert temp["heavy_tails"] and temp["excess_kurtosis"] > 10 * temp["kurtosis_threshold"]
    doc = _posterior(capsys, spiky, "--likelihood", "student", "--plot", str(tmp_path / "fig"))
    assert doc["likelihood"] == "student" and doc["likelihood_note"] == "requested"
    assert set(doc["params"]) == {"kA", "kS", "mu0", "A", "B", "sigma"} and doc["tempering"]["weight"] == 1.0
    assert (tmp_path / "fig" / "posterior_predictive.png").exists()  # t-distributed noise band
    doc = _posterior(capsys, spiky, "--likelihood", "student", "--temper")
    assert doc["likelihood_note"].startswith("requested, tempered by 1/κ")
    assert doc["tempering"]["weight"] == pytest.approx(1 / doc["tempering"]["kappa"])


def test_posterior_checks_of_a_padded_dataset_are_its_samples_own(data):
    """``posterior`` takes its least-squares start and its checks (colour, tails, the walkers'
    Laplace spread) on the dataset padded to its length bucket, one program per bucket: the padding
    changes none of them beyond round-off. Residuals coloured as an observer's (AR(1), ρ = 0.8) and
    a slip sd, so κ, the tails and the errors-in-variables scale all have something to show."""
    rng = np.random.default_rng(3)
    e = np.zeros(300)
    for t in range(1, 300):
        e[t] = 0.8 * e[t - 1] + 0.01 * rng.standard_normal()
    ours = data._replace(adhesion=data.adhesion + e, slip_sd=0.2 * jnp.abs(data.slip) + 1e-3)
    padded = bucketed(ours)
    assert padded.adhesion.shape[0] == 512 and float(jnp.sum(padded.weight)) == 300
    start, start_padded = lm_start(ours), lm_start(padded)
    assert Status(int(start.status)).converged and int(start_padded.status) == int(start.status)
    np.testing.assert_allclose(start_padded.params, start.params, rtol=0, atol=1e-9)
    theta = start.params
    colour, colour_padded = colour_check(ours, theta), colour_check(padded, theta)
    assert colour["kappa"] > 3.0 and colour["samples"] == colour_padded["samples"] == 300
    assert colour_padded["lags"] == colour["lags"]
    for key in ("kappa", "effective_samples", "residual_rho"):
        assert colour_padded[key] == pytest.approx(colour[key], rel=1e-12), key
    tails, tails_padded = tail_check(ours, theta, colour["kappa"]), tail_check(padded, theta, colour["kappa"])
    assert tails_padded["heavy_tails"] == tails["heavy_tails"]
    for key in ("excess_kurtosis", "kurtosis_threshold"):
        assert tails_padded[key] == pytest.approx(tails[key], rel=1e-12), key
    np.testing.assert_allclose(initial_spread(theta, padded), initial_spread(theta, ours), rtol=1e-10)


def test_tail_check_threshold_is_three_standard_errors(data):
    check = tail_check(data, jnp.asarray(THETA), kappa=4.0)
    assert check["kurtosis_threshold"] == pytest.approx(3 * np.sqrt(24 * 4.0 / 300))
    assert abs(check["excess_kurtosis"]) < check["kurtosis_threshold"] and not check["heavy_tails"]
