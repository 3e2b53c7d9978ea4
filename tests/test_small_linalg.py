"""The fits' small linear algebra (:mod:`jadhesion.identify.small_linalg`) against NumPy's LAPACK.

Both sides are backward stable, so they agree to a few ``eps`` times the condition number (solve)
or times the largest singular value (SVD); the tolerances below are that bound with a margin of
10–100, far below any difference that matters to a fit (the fits' parameters and standard errors
are reported to ~1e-12).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from jadhesion.identify.small_linalg import solve, svd_tall

EPS = np.finfo(np.float64).eps
_solve = jax.jit(solve)
_svd = jax.jit(svd_tall)


@st.composite
def _square(draw):
    d = draw(st.sampled_from([1, 2, 5, 6]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(d, d)) * 10.0 ** rng.uniform(-3, 3, size=(1, d))  # badly scaled columns
    if draw(st.booleans()):  # symmetric positive definite, as LM's damped normal equations
        a = a.T @ a + np.diag(10.0 ** rng.uniform(-8, 0, size=d))
    return a, rng.normal(size=d)


@settings(max_examples=60, deadline=None)
@given(_square())
def test_solve_matches_numpy(case):
    a, b = case
    cond = np.linalg.cond(a)
    assume(cond < 1e10)
    x, ref = np.asarray(_solve(a, b)), np.linalg.solve(a, b)
    assert np.linalg.norm(x - ref) <= 100 * a.shape[0] * EPS * cond * np.linalg.norm(ref)


def test_solve_pivots():
    """A zero leading entry (no elimination without a row swap) and a vmap over systems."""
    a = np.array([[0.0, 2.0, 1.0], [1.0, 1e-20, 0.0], [3.0, 0.0, 1.0]])
    b = np.array([1.0, 2.0, 3.0])
    np.testing.assert_allclose(_solve(a, b), np.linalg.solve(a, b), rtol=1e-14)
    batch = np.stack([a, a + np.eye(3)])
    got = jax.vmap(solve)(batch, np.stack([b, b]))
    np.testing.assert_allclose(got, np.linalg.solve(batch, b), rtol=1e-14)


@st.composite
def _tall(draw):
    d = draw(st.sampled_from([1, 2, 5, 6]))
    n = draw(st.sampled_from([d, 40]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    a = rng.normal(size=(n, d)) * 10.0 ** rng.uniform(-4, 4, size=(1, d))
    if d > 1 and draw(st.booleans()):  # rank deficient: a zero column and a repeated one
        a[:, 0] = 0.0
        a[:, -1] = 3.0 * a[:, 1 % d]
    return a


@settings(max_examples=60, deadline=None)
@given(_tall())
def test_svd_is_an_svd_and_matches_numpy(a):
    n, d = a.shape
    s, vt = map(np.asarray, _svd(a))
    ref = np.linalg.svd(a, compute_uv=False)
    tol = 100 * n * EPS * ref[0]
    np.testing.assert_allclose(s, ref, rtol=0, atol=tol)
    assert np.all(np.diff(s) <= 0)
    np.testing.assert_allclose(vt @ vt.T, np.eye(d), rtol=0, atol=100 * d * EPS)
    # A vᵢ = sᵢ uᵢ with orthonormal uᵢ (over the nonzero sᵢ), and A = U S Vᵀ
    av = a @ vt.T
    np.testing.assert_allclose(np.linalg.norm(av, axis=0), s, rtol=0, atol=tol)
    big = s > tol
    u = av[:, big] / s[big]
    np.testing.assert_allclose(u.T @ u, np.eye(big.sum()), rtol=0, atol=tol / s[big].min())
    np.testing.assert_allclose((u * s[big]) @ vt[big], a, rtol=0, atol=tol)


@pytest.mark.parametrize("fn, args", [(solve, (np.eye(5), np.ones(5))), (svd_tall, (np.ones((40, 5)),))])
def test_no_lapack_custom_call(fn, args):
    """The point of the module: the compiled program holds no LAPACK call (whose first use in a
    process imports scipy.linalg)."""
    text = jax.jit(fn).lower(*map(jnp.asarray, args)).as_text()
    assert "custom_call" not in text
    assert "custom_call" in jax.jit(jnp.linalg.solve).lower(jnp.eye(5), jnp.ones(5)).as_text()
