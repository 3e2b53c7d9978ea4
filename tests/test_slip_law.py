"""The true slip's law given the smoothed slip: normal truncated to the sign of the force, and the
posterior under the recording's own population of slips.

The truncated normal against scipy's (means, quadrature), at its limits (zero sd, no sign, far from
and beyond the bound), and the errors-in-variables effect it exists for: on data drawn from the law,
the untruncated expected curve leaves the offset that the diagnosis's torque-offset candidate took
up. The population law: Richardson–Lucy recovers a crowded population's spread from slips with
classical errors; its nodes leave the expected curve unbiased where the normal law's do not; where
the population is flat over the sd they are the normal law's; finite at the limits.
"""

import jax
import jax.numpy as jnp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from jadhesion.cli.recording_options import SLIP_LAWS as OFFERED_LAWS
from jadhesion.data.scenarios import SCENARIOS
from jadhesion.data.vehicle import LOCO_22E
from jadhesion.identify.likelihood import SLIP_LAWS
from jadhesion.identify.slip_law import (
    GH_NODES,
    GH_WEIGHTS,
    SLIP_SIGN_MIN,
    population_law,
    posterior_nodes,
    slip_nodes,
    truncated_mean,
)
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


#: Value and slip-gradient of the law's mean and of its nodes' sum, jitted once for every example.
_VALUE_AND_GRAD = tuple(
    jax.jit(jax.value_and_grad(f))
    for f in (
        lambda s, sd, mu: truncated_mean(s, sd, mu)[0],
        lambda s, sd, mu: jnp.sum(slip_nodes(s, sd, mu)),
    )
)


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-1e4, 1e4),  # slip in units of sd: far beyond the bound on either side
    st.floats(1e-7, 1.0),
    st.sampled_from([-0.3, 0.0, 0.3]),
)
def test_finite_with_finite_gradients_anywhere(k, sd, mu):
    slip, sd, mu = jnp.array([k * sd]), jnp.array([sd]), jnp.array([mu])
    for value_and_grad in _VALUE_AND_GRAD:
        value, grad = value_and_grad(slip, sd, mu)
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


def _crowded(n=3000, sd=6e-4, seed=3):
    """A steady start's slips [m/s]: 3/4 crowd at 3 ± 1 mm/s, the rest 5–300 mm/s; smoothed ones
    with classical errors of ``sd`` (the smoother's on our simulator: its error's mean over the
    samples of one true slip is ~0)."""
    rng = np.random.default_rng(seed)
    crowd = rng.random(n) < 0.75
    true = np.where(crowd, rng.normal(3e-3, 1e-3, n), rng.uniform(0.005, 0.3, n))
    return true, true + sd * rng.standard_normal(n), crowd


def test_population_law_recovers_the_crowd_from_classical_errors():
    """The crowd's true sd is 1 mm/s; the smoothed slips spread 1.17 mm/s (√(1 + 0.6²)); the
    deconvolved law 1.01 mm/s (measured). Bound: 10 %, the sampling error of an sd from ~2250
    samples being 1.5 %."""
    true, smoothed, crowd = _crowded()
    grid, log_density = (
        np.asarray(a)
        for a in population_law(jnp.asarray(smoothed), jnp.full(true.size, 6e-4), jnp.full(true.size, 0.3))
    )
    inside = (grid > -2e-3) & (grid < 8e-3)
    mass = np.exp(log_density[inside]) * np.gradient(grid)[inside]
    mass /= mass.sum()
    mean = np.sum(mass * grid[inside])
    sd = np.sqrt(np.sum(mass * (grid[inside] - mean) ** 2))
    assert abs(mean - 3e-3) < 1e-4
    assert abs(sd - 1e-3) < 1e-4 < abs(np.std(smoothed[crowd]) - 1e-3)


def test_population_nodes_leave_no_bias_where_the_normal_law_does():
    """Dry Polach curve at 0.6 m/s, the adhesion exact at the true slip. Among samples smoothed
    below 2 mm/s (the crowd's lower flank: their true slips lie higher) the normal law's expected
    curve is 0.040 short of the data (measured; 15 standard errors), the population law's within 3
    standard errors (measured −0.0038 ± 0.0026)."""
    true, smoothed, _ = _crowded()
    theta, k_eps, v = jnp.asarray(SCENARIOS["dry"].params), LOCO_22E.k_eps(), 0.6
    mu = np.asarray(polach_adhesion(theta, jnp.asarray(true / v), jnp.asarray(true), k_eps))
    sd, force = jnp.full(true.size, 6e-4), jnp.full(true.size, 0.3)

    def residual(nodes):  # nodes (GH_NODES, n) [m/s]
        curve = polach_adhesion(theta, nodes / v, nodes, k_eps)
        return mu - np.asarray(jnp.sum(jnp.asarray(GH_WEIGHTS)[:, None] * curve, axis=0))

    low = (smoothed >= 0) & (smoothed < 2e-3)
    population = residual(posterior_nodes(jnp.asarray(smoothed), sd, force).T)[low]
    normal = residual(
        jnp.asarray(smoothed)[None, :] + sd[None, :] * slip_nodes(jnp.asarray(smoothed), sd, force)
    )[low]
    se = np.std(population) / np.sqrt(low.sum())
    assert abs(np.mean(population)) < 3 * se
    assert np.mean(normal) > 10 * se


def test_population_nodes_are_the_normal_law_where_the_population_is_flat():
    """Slips spread uniformly over 10–300 mm/s, sd 0.1 mm/s: away from the population's edges the
    nodes are the truncated normal's (measured: median 0.04 sd apart, largest 0.2 sd, from the
    estimate's sampling noise); at its edges they move inward, as they should."""
    rng = np.random.default_rng(4)
    true = rng.uniform(0.01, 0.3, 3000)
    smoothed, sd, force = (
        jnp.asarray(true + 1e-4 * rng.standard_normal(3000)),
        jnp.full(3000, 1e-4),
        jnp.full(3000, 0.3),
    )
    population = posterior_nodes(smoothed, sd, force).T
    normal = smoothed[None, :] + sd[None, :] * slip_nodes(smoothed, sd, force)
    apart = np.max(np.abs(np.asarray(population - normal)), axis=0) / 1e-4
    inner = (np.asarray(smoothed) > 0.02) & (np.asarray(smoothed) < 0.29)
    assert np.median(apart[inner]) < 0.1 and np.max(apart[inner]) < 0.5
    edge = np.asarray(smoothed) < 0.01
    assert np.all(np.asarray(population.mean(axis=0))[edge] > np.asarray(smoothed)[edge])


def test_population_nodes_at_the_limits():
    """Zero sd gives the smoothed slip exactly; a sample far on the wrong side of its force gets
    the truncated normal's nodes; every node finite and on the force's side; padding (weight 0)
    changes no real sample's nodes."""
    slip = jnp.concatenate([SLIP, jnp.array([-1.0, 0.0])])
    sd = jnp.concatenate([SD, jnp.array([1e-3, 0.0])])
    mu = jnp.concatenate([MU, jnp.array([0.3, 0.3])])
    nodes_of = jax.jit(posterior_nodes)  # one program per shape, not one per primitive
    nodes = np.asarray(nodes_of(slip, sd, mu))
    assert np.all(np.isfinite(nodes))
    np.testing.assert_array_equal(nodes[-1], np.zeros(GH_NODES))
    normal = np.asarray(slip[-2] + sd[-2] * slip_nodes(slip[-2:-1], sd[-2:-1], mu[-2:-1])[:, 0])
    # slip + sd·e with |slip| = 1 and a result near 0: equal to the rounding of the sum (eps·|slip|)
    np.testing.assert_allclose(nodes[-2], normal, rtol=1e-12, atol=4 * np.finfo(float).eps)
    signed = np.abs(np.asarray(mu)) >= SLIP_SIGN_MIN
    assert np.all(np.sign(np.asarray(mu))[signed, None] * nodes[signed] >= -1e-12)
    padded = nodes_of(
        jnp.concatenate([slip, jnp.full(50, slip[-1])]),
        jnp.concatenate([sd, jnp.full(50, sd[-1])]),
        jnp.concatenate([mu, jnp.full(50, mu[-1])]),
        jnp.concatenate([jnp.ones(slip.size), jnp.zeros(50)]),
    )
    np.testing.assert_allclose(np.asarray(padded)[: slip.size], nodes, rtol=1e-9, atol=1e-15)


def test_the_command_line_offers_the_likelihoods_laws():
    """The literal list of ``--slip-law`` (no JAX at ``--help``) is the likelihood's."""
    assert OFFERED_LAWS == SLIP_LAWS
