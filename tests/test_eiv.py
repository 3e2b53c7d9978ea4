"""Errors in variables in LM: the expected-curve residual undoes the slope attenuation that a
scattered slip causes, and vanishes without (or with negligible) slip uncertainty."""

import jax
import jax.numpy as jnp
import numpy as np

from jadhesion.data.dataset import PolachDataset
from jadhesion.data.scenarios import SCENARIOS
from jadhesion.data.vehicle import LOCO_22E
from jadhesion.identify.batch_fit import pad_dataset
from jadhesion.identify.box_lm import box_lm
from jadhesion.identify.laplace import lm_optimum
from jadhesion.identify.likelihood import curve_moments, with_node_slips
from jadhesion.identify.polach_fit import fit_polach
from jadhesion.identify.polach_residuals import polach_eiv_residual, polach_residual
from jadhesion.identify.slip_law import GH_NODES
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


def test_stored_node_slips_change_no_number():
    """The slip law's nodes stored once (``with_node_slips``, as every fit and sampler does) give
    the same expectation bit for bit as nodes evaluated on each call; they pad and split into LM's
    row blocks with the other per-sample fields."""
    data = _dataset(0.004, n=1000)
    stored = with_node_slips(data)
    assert stored.node_slips.shape == (1000, GH_NODES) and with_node_slips(stored) is stored
    for a, b in zip(curve_moments(TRUTH, data), curve_moments(TRUTH, stored), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    padded = pad_dataset(stored, 1100)
    np.testing.assert_array_equal(
        np.asarray(padded.node_slips), np.asarray(with_node_slips(pad_dataset(data, 1100)).node_slips)
    )
    bounds = (jnp.zeros(5), jnp.ones(5))
    whole = box_lm(polach_eiv_residual, TRUTH * 0.9, stored, bounds)
    blocks = box_lm(polach_eiv_residual, TRUTH * 0.9, stored, bounds, block_rows=300)
    np.testing.assert_allclose(np.asarray(blocks.params), np.asarray(whole.params), rtol=0, atol=1e-10)
