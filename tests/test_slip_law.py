"""The true slip's law given the smoothed slip: normal truncated to the sign of the force.

Against scipy's truncated normal (means, quadrature), at its limits (zero sd, no sign, far from and
beyond the bound), and the errors-in-variables effect it exists for: on data drawn from the law, the
untruncated expected curve leaves the offset that the diagnosis's torque-offset candidate took up.
"""

import jax
import jax.numpy as jnp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from jadhesion.identify.slip_law import GH_NODES, GH_WEIGHTS, SLIP_SIGN_MIN, slip_nodes, truncated_mean
from jadhesion.models.polach import polach_adhesion

RNG = np.random.default_rng(0)
SLIP = jnp.asarray(RNG.normal(0.0, 0.004, 400))  # [m/s], half of it "backwards"
SD = jnp.asarray(RNG.uniform(5e-4, 4e-3, 400))
MU = jnp.asarray(RNG.choice([-0.2, 0.005, 0.2], 400))  # braking, unknown sign, traction


def scipy_law(slip, sd, mu):
    slip, sd, mu = (np.asarray(x) for x in (slip, sd, mu))
    sign = np.where(np.abs(mu) >= SLIP_SIGN_MIN, np.sign(mu), 0.0)
    lo = np.where(sign > 0, -slip / sd, -np.inf)
    hi = np.where(sign < 0, -slip / sd, np.inf)
    return stats.truncnorm(lo, hi, loc=slip, scale=sd)


def test_mean_and_quadrature_match_scipy():
    law = scipy_law(SLIP, SD, MU)
    np.testing.assert_allclose(truncated_mean(SLIP, SD, MU), law.mean(), rtol=1e-9, atol=1e-12)
    nodes = SLIP[None, :] + SD[None, :] * slip_nodes(SLIP, SD, MU)
    quad_mean = jnp.sum(jnp.asarray(GH_WEIGHTS)[:, None] * nodes, axis=0)
    np.testing.assert_allclose(quad_mean, law.mean(), atol=0.02 * float(jnp.min(SD)))
    quad_var = jnp.sum(jnp.asarray(GH_WEIGHTS)[:, None] * (nodes - quad_mean[None, :]) ** 2, axis=0)
    np.testing.assert_allclose(quad_var, law.var(), rtol=0.1)


def test_every_node_on_the_force_side_and_untruncated_without_a_sign():
    e = slip_nodes(SLIP, SD, MU)
    sign = np.sign(np.asarray(MU))
    signed = np.abs(np.asarray(MU)) >= SLIP_SIGN_MIN
    w = np.asarray(SLIP[None, :] + SD[None, :] * e)
    assert np.all(sign[signed] * w[:, signed] >= -1e-12)
    gh = np.polynomial.hermite_e.hermegauss(GH_NODES)[0]
    np.testing.assert_array_equal(
        np.asarray(e)[:, ~signed], np.broadcast_to(gh[:, None], e[:, ~signed].shape)
    )


def test_zero_sd_is_the_smoothed_slip_exactly():
    zero = jnp.zeros_like(SD)
    np.testing.assert_array_equal(truncated_mean(SLIP, zero, MU), SLIP)
    np.testing.assert_array_equal(
        SLIP[None, :] + zero[None, :] * slip_nodes(SLIP, zero, MU), jnp.tile(SLIP, (GH_NODES, 1))
    )


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-1e4, 1e4),  # slip in units of sd: far beyond the bound on either side
    st.floats(1e-7, 1.0),
    st.sampled_from([-0.3, 0.0, 0.3]),
)
def test_finite_with_finite_gradients_anywhere(k, sd, mu):
    slip, sd, mu = jnp.array([k * sd]), jnp.array([sd]), jnp.array([mu])
    for f in (lambda s: truncated_mean(s, sd, mu)[0], lambda s: jnp.sum(slip_nodes(s, sd, mu))):
        value, grad = jax.value_and_grad(f)(slip)
        assert np.isfinite(float(value)) and np.all(np.isfinite(np.asarray(grad)))
    if mu[0] != 0:  # the law's mean is on the force's side
        assert float(jnp.sign(mu[0]) * truncated_mean(slip, sd, mu)[0]) >= 0.0


def test_the_truncated_law_leaves_no_offset_where_the_untruncated_one_does():
    """Traction at walking pace on a steep curve (22E-like k_eps): smoothed slips −2…12 mm/s, each
    sample's true slip drawn from the law this module states (the smoother's sd 2 mm/s, forward as
    the force says). At the true parameters the truncated expected curve leaves residuals of mean
    zero (within 3 standard errors) where the smoothed slip is below one sd; the untruncated one
    reads those samples as "slipping backwards" and leaves a positive residual there of more than
    0.03 — the constant the diagnosis's torque-offset candidate took up on clean foreign starts."""
    rng = np.random.default_rng(5)
    n, k_eps, theta = 3000, 130.0, jnp.array([0.6, 0.3, 0.38, 0.3, 0.3])
    v = np.full(n, 3.0)
    w_hat, sd = rng.uniform(-2e-3, 12e-3, n), np.full(n, 2e-3)
    w_true = stats.truncnorm.rvs(-w_hat / sd, np.inf, loc=w_hat, scale=sd, random_state=rng)
    noise = 2e-3
    mu = np.asarray(polach_adhesion(theta, w_true / v, w_true, k_eps)) + noise * rng.standard_normal(n)

    def residual(sign_source):  # the force's sign: forward on every sample (traction)
        e = slip_nodes(jnp.asarray(w_hat), jnp.asarray(sd), sign_source)
        nodes = w_hat[None, :] + sd[None, :] * e
        curve = polach_adhesion(theta, nodes / v[None, :], nodes, k_eps)
        return mu - np.asarray(jnp.sum(jnp.asarray(GH_WEIGHTS)[:, None] * curve, axis=0))

    low = w_hat < sd
    truncated, untruncated = residual(jnp.full(n, 0.3)), residual(jnp.zeros(n))
    se = np.std(truncated[low]) / np.sqrt(low.sum())
    assert abs(np.mean(truncated[low])) < 3 * se
    assert np.mean(untruncated[low]) > 0.03
