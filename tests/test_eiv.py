"""Errors in variables in LM: the expected-curve residual undoes the slope attenuation that a
scattered slip causes, and vanishes without (or with negligible) slip uncertainty."""

import jax
import jax.numpy as jnp
import numpy as np

from jadhesion.data.dataset import PolachDataset
from jadhesion.data.scenarios import SCENARIOS
from jadhesion.data.vehicle import LOCO_22E
from jadhesion.identify.laplace import lm_optimum
from jadhesion.identify.polach_fit import fit_polach
from jadhesion.identify.polach_residuals import polach_eiv_residual, polach_residual
from jadhesion.models.polach import polach_adhesion

TRUTH = jnp.asarray(SCENARIOS["dry"].params)
SPEED = 2.2


def _dataset(sd, n=400, seed=0):
    """Slips known to ``sd`` (the smoother's posterior: true slip ~ N(slip, sd²) given the data),
    mu_hat the curve at the true slip plus 0.003 noise."""
    rng = np.random.default_rng(seed)
    slip = np.linspace(0.0, 0.06, n) * SPEED / 2
    true = slip + sd * rng.standard_normal(n)
    v = np.full(n, SPEED)
    k_eps = LOCO_22E.k_eps()
    mu = np.asarray(polach_adhesion(TRUTH, jnp.asarray(true / v), jnp.asarray(true), k_eps))
    mu = mu + 0.003 * rng.standard_normal(n)
    return PolachDataset(
        creep=jnp.asarray(slip / v),
        slip=jnp.asarray(slip),
        adhesion=jnp.asarray(mu),
        vehicle_speed=jnp.asarray(v),
        k_eps=jnp.asarray(k_eps),
        slip_sd=jnp.full(n, sd),
        creep_sd=jnp.full(n, sd / SPEED),
    )


def _slope(theta):
    return float(theta[0] + theta[1]) / 2


def test_eiv_fit_recovers_the_slope_the_plain_fit_attenuates():
    data = _dataset(sd=8e-3)
    true_slope = _slope(TRUTH)
    eiv = fit_polach(data, "lm", jax.random.key(0)).params
    plain = lm_optimum(data._replace(slip_sd=None, creep_sd=None))  # least squares at the slips
    assert _slope(plain) < 0.75 * true_slope, _slope(plain)  # measured −33 %
    assert abs(_slope(eiv) / true_slope - 1) < 0.2, _slope(eiv)  # measured +5 %


def test_eiv_residual_vanishes_without_slip_uncertainty():
    data = _dataset(sd=1e-7)
    np.testing.assert_allclose(polach_eiv_residual(TRUTH, data), polach_residual(TRUTH, data), atol=1e-9)
    raw = data._replace(slip_sd=None, creep_sd=None)
    np.testing.assert_array_equal(polach_eiv_residual(TRUTH, raw), polach_residual(TRUTH, raw))
