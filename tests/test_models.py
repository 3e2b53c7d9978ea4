"""Physics tests of the pure model functions (Polach, Kiencke, Hertz/Kalker contact, kinematics),
each against an independent reference: a closed form, scipy, a published table, or a dense grid."""

import csv
from importlib import resources

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

from jadhesion.data.vehicle import LOCO_22E
from jadhesion.models import (
    RAIL_SETS,
    Contact,
    adhesion_peak,
    creepage,
    elliptic_ke,
    friction,
    gradient_constant,
    hertz_semi_axes,
    initial_slope,
    kalker_c11,
    kiencke_adhesion,
    kiencke_optimum,
    kiencke_regressors,
    polach_adhesion,
    slip_velocity,
)

K_EPS = LOCO_22E.k_eps()
DRY = jnp.array([0.4288, 1.0, 0.3555, 0.3575, 0.1316])
WET = jnp.array([1.0, 1.0, 0.2610, 0.6858, 0.2251])
SAND = jnp.array([1.0, 0.4089, 0.4205, 0.0, 0.1554])
#: sup |mu_adh| / mu(w) over the whole domain: max x/(1+x²) = 1/2 at x = kA·eps = 1, atan < π/2,
#: so |mu_adh| < (2/π)(1/2 + π/2) mu = (1 + 1/π) mu ≤ (1 + 1/π) mu0. Approached (not attained) for
#: kA → 0 with kS·eps → ∞ at kA·eps = 1.
BOUND = 1.0 + 1.0 / np.pi

unit = st.floats(0.0, 1.0)
theta_st = st.tuples(unit, unit, unit, unit, unit).map(lambda t: jnp.array(t))


def _curve(theta, s, v):
    return polach_adhesion(theta, s, s * v, K_EPS)


_curve_jit = jax.jit(_curve)
# Jitted once at module level: the tests call them with many arguments of the same shapes.
_peak_jit = jax.jit(adhesion_peak)
_c11_jit = jax.jit(kalker_c11)
_hertz_jit = jax.jit(hertz_semi_axes)
_kiencke_jit = jax.jit(kiencke_adhesion)
_grad_all = jax.jit(jax.grad(_curve, argnums=(0, 1, 2)))
_kiencke_grads = jax.jit(jax.vmap(jax.grad(kiencke_adhesion, argnums=(0, 1, 2)), in_axes=(0, None, None)))


# ------------------------------------------------------------------------------ Polach vs Kalker


def _kalker_c11_reference(a_over_b, nu):
    """Kalker Table E.3 read afresh and interpolated with numpy (linear in ln(a/b), then in nu)."""
    rows = []
    with resources.files("jadhesion").joinpath("resources/kalker_c_table_e3.csv").open() as fh:
        for r in csv.DictReader(line for line in fh if not line.startswith("#")):
            g = float(r["g"])
            x = np.log(g) if r["case"] == "a_le_b" else -np.log(g)
            rows.append((x, float(r["c11_nu0"]), float(r["c11_nu025"]), float(r["c11_nu05"])))
    rows = np.array(sorted(set(rows)))
    per_nu = [np.interp(np.log(a_over_b), rows[:, 0], rows[:, j]) for j in (1, 2, 3)]
    return np.interp(nu, [0.0, 0.25, 0.5], per_nu)


def test_polach_initial_slope_is_kalker_linear_theory():
    """kA = kS = 1: d mu_adh/ds at s = 0 equals Kalker's linear theory F/(Q s) = G a b c11 / Q."""
    v = LOCO_22E
    contact = v.contact()
    a, b = float(contact.a), float(contact.b)
    kalker = v.shear_modulus * a * b * _kalker_c11_reference(a / b, v.poisson_ratio) / v.wheel_load
    theta = jnp.array([1.0, 1.0, 0.4, 0.4, 0.2])
    h = 1e-9
    fd = float(_curve_jit(theta, h, 0.6) - _curve_jit(theta, -h, 0.6)) / (2 * h)
    assert fd == pytest.approx(kalker, rel=1e-6)
    assert float(initial_slope(theta, K_EPS)) == pytest.approx(kalker, rel=1e-12)
    autodiff = float(jax.grad(_curve, argnums=1)(theta, 0.0, 0.6))
    assert autodiff == pytest.approx(kalker, rel=1e-12)


def test_initial_slope_general_reduction_factors():
    theta = jnp.array([0.3, 0.7, 0.5, 0.5, 0.5])
    h = 1e-9
    fd = float(_curve_jit(theta, h, 1.0) - _curve_jit(theta, -h, 1.0)) / (2 * h)
    assert fd == pytest.approx(2 / np.pi * (0.3 + 0.7) * K_EPS, rel=1e-6)


def test_gradient_constant_formula():
    c = Contact(jnp.asarray(0.008), jnp.asarray(0.005))
    stiff = 3 * 8e10 * float(kalker_c11(1.6, 0.28)) / (8 * 0.008)
    expected = 2 / 3 * stiff * np.pi * 0.008**2 * 0.005 / 1e5
    assert float(gradient_constant(c, 1e5, 8e10, 0.28)) == pytest.approx(expected, rel=1e-13)


# ------------------------------------------------------------------------------ gain identity


@settings(max_examples=40, deadline=None)
@given(theta=theta_st, gain=st.floats(0.05, 5.0), s=st.floats(-2.0, 2.0), v=st.floats(0.0, 30.0))
def test_gain_identity_is_exact(theta, gain, s, v):
    """g·mu_adh(s; mu0, kA, kS) = mu_adh(s; g·mu0, g·kA, g·kS) (DESIGN §1): mu scales by g,
    eps = k s/mu by 1/g, so kA·eps and kS·eps are invariant. Exact up to round-off (and the
    friction floor / eps clip at |eps| = 1e8, which break it where mu0 ≈ 0)."""
    mu_w = float(friction(theta, s * v))
    assume(min(gain, 1.0) * mu_w > 1e-6 * K_EPS * abs(s))  # |eps| < 1e6, far from the clip
    scaled = theta * jnp.array([gain, gain, gain, 1.0, 1.0])
    lhs = gain * _curve_jit(theta, s, v)
    rhs = _curve_jit(scaled, s, v)
    assert float(jnp.abs(lhs - rhs)) <= 1e-13 * max(1.0, float(jnp.abs(lhs)))


# ------------------------------------------------------------------------------ domain invariants


@settings(max_examples=100, deadline=None)
@given(theta=theta_st, s=st.floats(-50.0, 50.0), v=st.floats(0.0, 40.0), d_mu0=st.floats(0.0, 1.0))
def test_polach_invariants_over_parameter_box(theta, s, v, d_mu0):
    mu_adh = float(_curve_jit(theta, s, v))
    mu_w = float(friction(theta, s * v))
    assert np.isfinite(mu_adh)
    # Exact bound (see BOUND) and sign: the curve is odd and has the sign of the creep.
    # (friction is floored at 1e-12, so mu0 = 0 gives |mu_adh| ≈ 1e-12, not exactly 0)
    assert abs(mu_adh) <= BOUND * max(mu_w, 1e-12) * (1 + 1e-12)
    assert abs(mu_adh) <= BOUND * max(float(theta[2]), 1e-12) * (1 + 1e-12)
    assert mu_adh * s >= 0.0
    # Monotone in mu0 at fixed (s, w): d/dmu [mu h(k s/mu)] = 2x³/(1+x²)² + atan(y) − y/(1+y²) ≥ 0.
    bigger = theta.at[2].set(min(1.0, float(theta[2]) + d_mu0))
    assert abs(float(_curve_jit(bigger, s, v))) >= abs(mu_adh) * (1 - 1e-12) - 1e-15
    grads = _grad_all(theta, s, v)
    assert all(bool(jnp.all(jnp.isfinite(g))) for g in grads)


def test_bound_is_approached():
    theta = jnp.array([1e-4, 1.0, 0.4, 1.0, 0.0])  # A = 1: mu = mu0 everywhere
    s = 0.4 / (1e-4 * K_EPS)  # kA·eps = 1, kS·eps = 1e4
    assert float(_curve_jit(theta, s, 0.0)) / 0.4 == pytest.approx(BOUND, rel=2e-4)
    assert float(_curve_jit(theta, s, 0.0)) / 0.4 < BOUND


@pytest.mark.parametrize(
    "theta", [DRY, WET, SAND, jnp.array([1.0, 1.0, 0.0, 0.5, 0.5]), jnp.zeros(5), jnp.ones(5)]
)
@pytest.mark.parametrize(
    "s,v", [(0.0, 0.0), (0.0, 5.0), (1e-12, 0.0), (1e6, 30.0), (-1e6, 30.0), (1e300, 1.0), (-3.0, 0.0)]
)
def test_polach_finite_everywhere(theta, s, v):
    assert np.isfinite(float(_curve_jit(theta, s, v)))
    for g in _grad_all(theta, s, v):
        assert bool(jnp.all(jnp.isfinite(g)))


def test_standstill_through_kinematics():
    """At v = 0 the creepage uses the speed floor: finite, odd in slip, and the model stays finite."""
    w = slip_velocity(jnp.array([0.02, -0.02, 0.0]), 0.0)
    s = creepage(w, 0.0)
    assert np.all(np.isfinite(s)) and float(s[0]) == -float(s[1]) and float(s[2]) == 0.0
    mu = polach_adhesion(DRY, s, w, K_EPS)
    assert np.all(np.isfinite(mu)) and float(mu[0]) == -float(mu[1])
    assert bool(jnp.all(jnp.isfinite(jax.grad(lambda v: creepage(0.01, v))(0.0))))


@pytest.mark.parametrize("theta", [DRY, WET, SAND])
def test_polach_is_odd(theta):
    s = jnp.geomspace(1e-6, 5.0, 101)
    v = 1.3
    np.testing.assert_array_equal(np.asarray(_curve_jit(theta, -s, v)), -np.asarray(_curve_jit(theta, s, v)))


def test_zero_friction_gives_zero_adhesion():
    theta = DRY.at[2].set(0.0)
    s = jnp.array([-1.0, 0.0, 1e-3, 1.0])
    np.testing.assert_allclose(np.asarray(_curve_jit(theta, s, 1.0)), 0.0, atol=1e-11)


# ------------------------------------------------------------------------------ transforms


def test_jit_equals_no_jit_and_vmap_equals_loop():
    s = jnp.geomspace(1e-5, 1.0, 64)
    thetas = jnp.stack([DRY, jnp.array([0.2, 0.9, 0.7, 0.1, 0.9])])
    eager = np.stack([np.asarray(_curve(t, s, 0.7)) for t in thetas])
    jitted = np.stack([np.asarray(_curve_jit(t, s, 0.7)) for t in thetas])
    vmapped = np.asarray(jax.vmap(_curve, in_axes=(0, None, None))(thetas, s, 0.7))
    np.testing.assert_allclose(jitted, eager, rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(vmapped, eager, rtol=1e-14, atol=1e-16)
    # Broadcasting a (4, 1, 5) parameter batch against the creep grid gives the same numbers.
    broadcast = np.asarray(_curve_jit(thetas[:, None, :], s[None, :], 0.7))
    np.testing.assert_allclose(broadcast, eager, rtol=1e-14, atol=1e-16)
    k_eager = np.stack([np.asarray(kiencke_adhesion(s, *p)) for p in RAIL_SETS.values()])
    ps = jnp.array([tuple(p) for p in RAIL_SETS.values()])
    k_vmap = jax.vmap(jax.jit(kiencke_adhesion), in_axes=(None, 0, 0))(s, ps[:, 0], ps[:, 1])
    np.testing.assert_allclose(np.asarray(k_vmap), k_eager, rtol=1e-14)


# ------------------------------------------------------------------------------ adhesion peak


def _dense_peak(theta, v, n=200_001):
    s = jnp.geomspace(1e-5, 1.0, n)
    y = _curve_jit(theta, s, v)
    i = int(jnp.argmax(y))
    return float(y[i]), float(s[i])


@pytest.mark.parametrize(
    "theta",
    [
        DRY,
        WET,
        SAND,
        jnp.array([1.0, 0.0, 0.3, 0.5, 0.5]),
        jnp.array([0.05, 1.0, 0.9, 1.0, 0.0]),
        jnp.array([0.7, 0.2, 0.05, 0.0, 1.0]),
    ],
)
@pytest.mark.parametrize("v", [0.6, 10.0])
def test_adhesion_peak_matches_dense_grid(theta, v):
    mu_max, s_max = _peak_jit(theta, K_EPS, v)
    mu_ref, s_ref = _dense_peak(theta, v)
    assert float(mu_max) == pytest.approx(mu_ref, rel=1e-6)
    assert float(mu_max) <= mu_ref * (1 + 1e-9) + 1e-15  # never above the true maximum
    assert float(_curve_jit(theta, s_max, v)) == pytest.approx(float(mu_max), rel=1e-12)
    if s_ref < 0.999:  # an interior maximum: located to within the grid's resolution
        assert float(s_max) == pytest.approx(s_ref, rel=2e-2)


def test_adhesion_peak_vmaps_over_random_parameters():
    thetas = jnp.asarray(np.random.default_rng(7).uniform(0.0, 1.0, (16, 5)))
    thetas = thetas.at[:, 2].set(0.05 + 0.95 * thetas[:, 2])
    mu_max, _ = jax.jit(jax.vmap(adhesion_peak, in_axes=(0, None, None)))(thetas, K_EPS, 2.0)
    s = jnp.geomspace(1e-5, 1.0, 100_001)
    dense = jax.jit(jax.vmap(lambda t: jnp.max(_curve(t, s, 2.0))))(thetas)
    np.testing.assert_allclose(np.asarray(mu_max), np.asarray(dense), rtol=1e-6)


# ------------------------------------------------------------------------------ Kiencke


@pytest.mark.parametrize("name", sorted(RAIL_SETS))
def test_kiencke_optimum_matches_dense_argmax(name):
    p1, p2 = RAIL_SETS[name]
    lam = np.linspace(0.0, 1.0, 1_000_001)
    mu = np.asarray(_kiencke_jit(lam, p1, p2))
    lam_m, mu_m = kiencke_optimum(p1, p2)
    assert float(lam_m) == pytest.approx(lam[np.argmax(mu)], abs=2e-6)
    assert float(mu_m) == pytest.approx(mu.max(), rel=1e-10)
    assert float(lam_m) == pytest.approx(1 / np.sqrt(p2), rel=1e-15)
    assert float(mu_m) == pytest.approx(35.0 / (p1 + 2 * np.sqrt(p2)), rel=1e-15)
    assert float(mu_m) < 0.6  # DESIGN §1: Figure 1's curves peak below 0.6
    # Stationary point: dmu/dlam = 0 there (autodiff).
    assert abs(float(jax.grad(kiencke_adhesion)(lam_m, p1, p2))) < 1e-12


def test_kiencke_odd_finite_and_linear_form():
    lam = jnp.concatenate([-jnp.geomspace(1e-8, 1e6, 50), jnp.zeros(1), jnp.geomspace(1e-8, 1e6, 50)])
    for p1, p2 in [*RAIL_SETS.values(), (0.0, 0.0)]:
        mu = _kiencke_jit(lam, p1, p2)
        assert bool(jnp.all(jnp.isfinite(mu)))
        np.testing.assert_array_equal(np.asarray(mu[:50]), -np.asarray(mu[51:]))
        g = _kiencke_grads(lam, p1, p2)
        assert all(bool(jnp.all(jnp.isfinite(x))) for x in g)
        z, u = kiencke_regressors(lam, mu)
        np.testing.assert_allclose(np.asarray(z), np.asarray(u @ jnp.array([p1, p2])), rtol=1e-10, atol=1e-12)
    assert float(jax.grad(kiencke_adhesion)(0.0, 80.0, 100.0)) == pytest.approx(35.0)


# ------------------------------------------------------------------------------ elliptic integrals


def test_elliptic_ke_matches_scipy():
    m = np.array([0.0, 1e-12, 1e-6, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999999, 1 - 1e-12])
    k, e = elliptic_ke(jnp.asarray(m))
    np.testing.assert_allclose(np.asarray(k), ellipk(m), rtol=1e-13)
    np.testing.assert_allclose(np.asarray(e), ellipe(m), rtol=1e-13)


# ------------------------------------------------------------------------------ Hertz


def _e_star(e=2.1e11, nu=0.28):
    return e / (2 * (1 - nu**2))


def _hertz_reference(a_curv, b_curv, load, e_star):
    """Independent Hertz solution with scipy (Johnson, Contact Mechanics, eqs 4.39–4.40).

    With curvature sums A ≤ B, the long semi-axis (along A) a and short b = a·sqrt(1 − e²) solve
    B/A = [E(e)/(1 − e²) − K(e)]/[K(e) − E(e)] and a³ = 3 P (K − E)/(2π E* e² A)."""
    ratio = max(a_curv, b_curv) / min(a_curv, b_curv)

    def f(m):
        k, e = ellipk(m), ellipe(m)
        return (e / (1 - m) - k) / (k - e) - ratio

    m = brentq(f, 1e-14, 1 - 1e-15, xtol=1e-300) if ratio > 1 else 0.0
    if m == 0.0:
        long = (3 * load / (4 * e_star * 2 * a_curv)) ** (1 / 3)
        return long, long
    k, e = ellipk(m), ellipe(m)
    long = (3 * load * (k - e) / (2 * np.pi * e_star * m * min(a_curv, b_curv))) ** (1 / 3)
    short = long * np.sqrt(1 - m)
    return (long, short) if a_curv <= b_curv else (short, long)


@pytest.mark.parametrize("radius", [0.05, 0.3, 0.61])
@pytest.mark.parametrize("load", [1e3, 105e3])
def test_hertz_circular_limit(radius, load):
    """Crossed cylinders of equal radius R touch like a sphere of radius R on a plane:
    a = b = (3 Q R / (4 E*))^(1/3), 1/E* = 2 (1 − ν²)/E."""
    c = _hertz_jit(radius, radius, load)
    expected = (3 * load * radius / (4 * _e_star())) ** (1 / 3)
    assert float(c.a) == pytest.approx(expected, rel=1e-6)
    assert float(c.b) == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize(
    "wheel_r,rail_r,profile_r",
    [
        (0.61, 0.3, np.inf),  # 22E: rolling axis long
        (0.61, 0.3, 0.5),  # worn (concave wheel profile would be negative; convex here)
        (0.45, 0.08, np.inf),  # small rail crown: very elongated ellipse
        (0.3, 0.61, np.inf),  # rolling axis short
        (0.5, 2.0, 10.0),
    ],
)
def test_hertz_matches_independent_scipy_solution(wheel_r, rail_r, profile_r):
    q = LOCO_22E.wheel_load
    ref_a, ref_b = _hertz_reference(0.5 / wheel_r, 0.5 * (1 / rail_r + 1 / profile_r), q, _e_star())
    c = _hertz_jit(wheel_r, rail_r, q, 2.1e11, 0.28, profile_r)
    assert float(c.a) == pytest.approx(ref_a, rel=1e-9)
    assert float(c.b) == pytest.approx(ref_b, rel=1e-9)


# Timoshenko & Goodier, Theory of Elasticity (2nd ed. 1951, §140, table of m and n): the Hertz
# semi-axes are a = m·[3π P (k1 + k2) / (4 (A + B))]^(1/3), b = n·[…]^(1/3), with
# cos θ = (B − A)/(A + B) and k_i = (1 − ν_i²)/(π E_i), i.e. 3π(k1 + k2)/4 = 3/(4 E*).
TIMOSHENKO = [
    (30, 2.731, 0.493),
    (40, 2.136, 0.567),
    (50, 1.754, 0.641),
    (60, 1.486, 0.717),
    (70, 1.284, 0.802),
    (80, 1.128, 0.893),
    (90, 1.0, 1.0),
]


@pytest.mark.parametrize("theta_deg,m_coef,n_coef", TIMOSHENKO)
def test_hertz_against_timoshenko_table(theta_deg, m_coef, n_coef):
    """Published 3–4 digit table: agreement to its printed precision (≤ 0.5 %)."""
    cos = np.cos(np.radians(theta_deg))
    a_curv = 0.5 / 0.6  # rolling curvature sum A (wheel R = 0.6 m), B = A (1 + cos)/(1 − cos)
    b_curv = a_curv * (1 + cos) / (1 - cos)
    rail_r = 0.5 / b_curv
    load = 1e5
    scale = (3 * load / (4 * _e_star() * (a_curv + b_curv))) ** (1 / 3)
    c = _hertz_jit(0.6, rail_r, load)
    assert float(c.a) / scale == pytest.approx(m_coef, rel=5e-3)
    assert float(c.b) / scale == pytest.approx(n_coef, rel=5e-3)


def test_22e_contact_matches_documented_values():
    c = LOCO_22E.contact()
    assert float(c.a) == pytest.approx(8.4e-3, rel=0.01)
    assert float(c.b) == pytest.approx(5.2e-3, rel=0.01)
    assert K_EPS == pytest.approx(130.0, rel=0.01)


def test_hertz_vmaps_and_is_differentiable():
    loads = jnp.array([5e4, 1e5, 2e5])
    a = jax.jit(jax.vmap(lambda q: hertz_semi_axes(0.61, 0.3, q).a))(loads)
    # a ∝ Q^(1/3) at fixed geometry.
    np.testing.assert_allclose(np.asarray(a / a[1]), (np.asarray(loads) / 1e5) ** (1 / 3), rtol=1e-9)
    da = jax.jit(jax.grad(lambda q: hertz_semi_axes(0.61, 0.3, q).a))(1e5)
    assert float(da) == pytest.approx(float(a[1]) / (3 * 1e5), rel=1e-6)


# ------------------------------------------------------------------------------ Kalker c11


def _table_rows():
    with resources.files("jadhesion").joinpath("resources/kalker_c_table_e3.csv").open() as fh:
        return list(csv.DictReader(line for line in fh if not line.startswith("#")))


def test_kalker_c11_reproduces_table_nodes():
    for r in _table_rows():
        g = float(r["g"])
        a_over_b = g if r["case"] == "a_le_b" else 1.0 / g
        for nu, key in [(0.0, "c11_nu0"), (0.25, "c11_nu025"), (0.5, "c11_nu05")]:
            assert float(_c11_jit(a_over_b, nu)) == pytest.approx(float(r[key]), rel=1e-12), (r, nu)


def test_kalker_c11_interpolates_in_poisson_ratio():
    assert float(kalker_c11(1.0, 0.125)) == pytest.approx((3.40 + 4.12) / 2, rel=1e-12)
    ratio = float(LOCO_22E.contact().a / LOCO_22E.contact().b)
    assert float(kalker_c11(ratio, 0.28)) == pytest.approx(_kalker_c11_reference(ratio, 0.28), rel=1e-12)


@pytest.mark.parametrize("nu", [0.0, 0.25, 0.28, 0.5])
def test_kalker_c11_continuous_at_table_ends(nu):
    for edge in (0.1, 10.0):
        inside = float(_c11_jit(edge * (1 + 1e-9 if edge < 1 else 1 - 1e-9), nu))
        outside = float(_c11_jit(edge * (1 - 1e-9 if edge < 1 else 1 + 1e-9), nu))
        assert outside == pytest.approx(inside, rel=1e-7)


@pytest.mark.parametrize("nu", [0.0, 0.25, 0.5])
def test_kalker_c11_tends_to_asymptotes(nu):
    # a << b: c11 → π²/(4(1 − ν)).
    assert float(_c11_jit(1e-7, nu)) == pytest.approx(np.pi**2 / (4 * (1 - nu)), rel=1e-5)
    # a >> b (g = b/a → 0): c11 → 2π / (g (ln(16/g²) − 3/2 − 2ν)).
    g = 1e-7
    asym = 2 * np.pi / (g * (np.log(16 / g**2) - 1.5 - 2 * nu))
    assert float(_c11_jit(1 / g, nu)) == pytest.approx(asym, rel=1e-5)
    # and monotone increasing in a/b throughout (the table's nu = 0.5 column is not, for a < b)
    if nu < 0.5:
        x = jnp.geomspace(1e-4, 1e4, 2001)
        assert bool(jnp.all(jnp.diff(_c11_jit(x, nu)) > 0))


def test_vehicle_k_eps_is_the_gradient_constant_of_its_contact():
    """``Vehicle.k_eps`` (cached per vehicle, one compiled program) is eq 3 of its contact, for a
    hashable vehicle and for one given a list by hand (uncached); another contact, another value."""
    v = LOCO_22E
    direct = float(gradient_constant(v.contact(), v.wheel_load, v.shear_modulus, v.poisson_ratio))
    np.testing.assert_allclose(v.k_eps(), direct, rtol=1e-14)
    by_hand = v.replace(contact_semi_axes_m=[0.007, 0.006])
    as_tuple = v.replace(contact_semi_axes_m=(0.007, 0.006))
    assert by_hand.k_eps() == as_tuple.k_eps() != v.k_eps()
