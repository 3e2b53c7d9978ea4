"""The fitted curve's peak with its intervals (identify/peak.py): the gradient of the peak search
against finite differences, the delta method against Monte Carlo propagation of the same
covariance, and the warnings where the data or the curve give no peak."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.data.vehicle import LOCO_22E
from jadhesion.identify.peak import MU_BOX_MAX, S_MAX, peak_numbers, peak_report, reference_speed
from jadhesion.models.polach import adhesion_peak

K_EPS = LOCO_22E.k_eps()
DRY = jnp.array([0.43, 1.0, 0.3555, 0.36, 0.13])
WET = jnp.array([0.3, 0.3, 0.261, 0.4, 0.2])


@pytest.mark.parametrize("theta", [DRY, WET, jnp.array([0.8, 0.5, 0.42, 0.1, 0.5])])
@pytest.mark.parametrize("speed", [0.5, 3.0, 15.0])
def test_gradient_is_the_peak_search_differentiated(theta, speed):
    """The parabolic refinement makes the peak search smooth in θ: its forward-mode gradient agrees
    with central differences (step 1e-6) to their truncation error."""
    peak, jac = peak_numbers(theta, K_EPS, speed)
    h = 1e-6
    for j in range(5):
        e = jnp.zeros(5).at[j].set(h)
        up = jnp.stack(adhesion_peak(theta + e, K_EPS, speed))
        down = jnp.stack(adhesion_peak(theta - e, K_EPS, speed))
        fd = (up - down) / (2 * h)
        np.testing.assert_allclose(np.asarray(jac[:, j]), np.asarray(fd), rtol=1e-5, atol=1e-9)


def test_delta_method_matches_monte_carlo_propagation():
    """Parameters drawn from N(θ, Σ) with a fit-sized Σ (sd 0.2–0.5 % of the box; creep_opt's
    relative sd is then a few per cent, as in a fit of a 2 000-sample test): the spread of their
    peaks is the delta method's, μ_max on its scale and creep_opt on the log scale, to within 5 %
    (20 000 draws: the sd's sampling error is 0.5 %; at creep_opt's 9 % relative sd the
    linearisation itself is 3 % off)."""
    sd = jnp.array([0.005, 0.005, 0.002, 0.005, 0.005])
    corr = jnp.eye(5).at[0, 1].set(-0.6).at[1, 0].set(-0.6)
    cov = corr * sd[:, None] * sd[None, :]
    peak, jac = peak_numbers(WET, K_EPS, 2.0)
    derived, warnings = peak_report(peak, jac, cov, 2.0, max_creep=1.0)
    assert warnings == []
    draws = jax.random.multivariate_normal(jax.random.key(0), WET, cov, (20_000,))
    peaks = jax.vmap(lambda th: jnp.stack(adhesion_peak(th, K_EPS, 2.0)))(draws)
    mc_mu = float(jnp.std(peaks[:, 0]))
    mc_log = float(jnp.std(jnp.log(peaks[:, 1])))
    assert derived["mu_max"]["stderr"] == pytest.approx(mc_mu, rel=0.05)
    assert derived["creep_opt"]["stderr"] / derived["creep_opt"]["value"] == pytest.approx(mc_log, rel=0.05)
    lo, hi = derived["creep_opt"]["ci95"]
    assert lo * hi == pytest.approx(derived["creep_opt"]["value"] ** 2)  # symmetric on the log scale


def test_no_interior_peak_and_an_unreached_peak_are_said_so():
    """A curve still rising at creep 1 (kA = 0, no fall of friction with slip) has no peak:
    creep_opt gets no interval; a recording whose creep stays below the peak is extrapolated."""
    rising = jnp.array([0.0, 1.0, 0.3, 1.0, 0.0])
    peak, jac = peak_numbers(rising, K_EPS, 2.0)
    derived, warnings = peak_report(peak, jac, 1e-4 * jnp.eye(5), 2.0, max_creep=0.5)
    assert float(peak[1]) == pytest.approx(S_MAX, rel=0.05)
    assert derived["creep_opt"] == {
        "value": float(peak[1]),
        "stderr": None,
        "ci95": None,
        "stderr_hac": None,
        "stderr_jackknife": None,
    }
    assert [w["code"] for w in warnings] == ["peak_extrapolated"] and "no peak" in warnings[0]["message"]
    peak, jac = peak_numbers(DRY, K_EPS, 2.0)
    low = 0.5 * float(peak[1])
    derived, warnings = peak_report(peak, jac, 1e-4 * jnp.eye(5), 2.0, max_creep=low)
    assert derived["creep_opt"]["ci95"] is not None
    assert [w["code"] for w in warnings] == ["peak_extrapolated"] and "extrapolated" in warnings[0]["message"]


def test_a_peak_outside_the_recorded_creep_on_either_side_is_extrapolated():
    """creep_opt below the smallest recorded creep (only the falling branch seen) is flagged as
    well as above the largest (only the rising branch); a recording spanning it is not."""
    peak, jac = peak_numbers(DRY, K_EPS, 2.0)
    c = float(peak[1])
    for lo, hi, branch in ((2 * c, 4 * c, "falling"), (0.1 * c, 0.5 * c, "rising")):
        _, warnings = peak_report(peak, jac, 1e-4 * jnp.eye(5), 2.0, max_creep=hi, min_creep=lo)
        assert [w["code"] for w in warnings] == ["peak_extrapolated"]
        assert f"extrapolated from the {branch} branch" in warnings[0]["message"]
    _, warnings = peak_report(peak, jac, 1e-4 * jnp.eye(5), 2.0, max_creep=2 * c, min_creep=0.5 * c)
    assert warnings == []


@pytest.mark.parametrize("loose", [1, 2])
def test_an_undetermined_direction_the_peak_depends_on_gives_no_interval(loose):
    """μ0 (a gradient of about 1) or kS (a gradient well below 1) undetermined: the peak is too,
    reported null and named, never as a finite 10¹⁵⁴ (an infinite variance once read as the
    largest double, times a small gradient)."""
    peak, jac = peak_numbers(DRY, K_EPS, 2.0)
    cov = 1e-4 * np.eye(5)
    cov[loose, :] = cov[:, loose] = np.inf
    derived, warnings = peak_report(peak, jac, cov, 2.0, max_creep=1.0)
    assert derived["mu_max"]["stderr"] is None and derived["mu_max"]["ci95"] is None
    undetermined = [w for w in warnings if w["code"] == "undetermined"]
    assert len(undetermined) == 1 and "mu_max" in undetermined[0]["params"]
    for name, d in derived.items():
        assert (d["stderr"] is None) == (name in undetermined[0]["params"])


def test_reference_speed_is_the_median_speed_of_the_real_rows():
    v = jnp.array([-1.0, 2.0, -3.0, 4.0, 100.0, 100.0])
    assert float(reference_speed(v)) == pytest.approx(3.5)
    assert float(reference_speed(v, jnp.array([1, 1, 1, 1, 0, 0]))) == pytest.approx(2.5)


def test_box_bound_on_mu_max_holds_and_caps_a_huge_interval():
    """No curve of the unit box exceeds 1 + 1/π (dense creep grid at the box's corners and 2 000
    random points); a fit whose μ_max is barely determined (sd 0.8) gets an interval capped there,
    and one whose sd exceeds the whole box (seen at 10¹⁵¹ on a recording fitted against the wrong
    vehicle) gets none: the data do not determine it."""
    corners = jnp.array(np.array(np.meshgrid(*[[0.0, 1.0]] * 5)).reshape(5, -1).T)
    inside = jax.random.uniform(jax.random.key(1), (2000, 5))
    peaks = jax.vmap(lambda th: adhesion_peak(th, K_EPS, 0.5)[0])(jnp.concatenate([corners, inside]))
    assert float(jnp.max(peaks)) < MU_BOX_MAX
    peak, jac = peak_numbers(DRY, K_EPS, 2.0)
    grad = np.asarray(jac[0])
    derived, warnings = peak_report(peak, jac, 0.8**2 / (grad @ grad) * np.eye(5), 2.0, max_creep=1.0)
    assert derived["mu_max"]["stderr"] == pytest.approx(0.8)
    assert derived["mu_max"]["ci95"] == [0.0, MU_BOX_MAX]
    assert "mu_max" not in [n for w in warnings if w["code"] == "undetermined" for n in w["params"]]
    derived, warnings = peak_report(peak, jac, 1e6 * np.eye(5), 2.0, max_creep=1.0)
    assert derived["mu_max"] == {
        "value": float(peak[0]),
        "stderr": None,
        "ci95": None,
        "stderr_hac": None,
        "stderr_jackknife": None,
    }
    assert "mu_max" in [n for w in warnings if w["code"] == "undetermined" for n in w["params"]]
