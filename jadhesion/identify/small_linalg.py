"""Linear algebra for the few-parameter problems of the fits, written in ``jax.numpy`` only.

``jnp.linalg.solve`` and ``jnp.linalg.svd`` lower to LAPACK custom calls on CPU; the first program
holding one that a process loads or traces makes jaxlib initialise its LAPACK kernels from
``scipy.linalg.cython_lapack``, which imports ``scipy.linalg`` — about 0.12–0.2 s of a warm
``jadhesion fit`` process, a third of a bare ``import jax`` (``benchmarks/bench_startup.py``). The
fits only ever solve 5 × 5 or 6 × 6 systems and take the SVD of an ``(n, 5)`` Jacobian, for which
plain array operations in small loops cost no more (loops rather than unrolled code: the
compiled program stays small, and a kept program's load time grows with its size).

* :func:`solve`: Gaussian elimination with partial pivoting (LAPACK ``getrf``/``getrs``'s method).
* :func:`svd_tall`: one-sided Jacobi SVD (Hestenes 1958; Demmel & Veselić 1992), singular values
  to high relative accuracy.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

#: Safety cap on Jacobi sweeps (a 5-column matrix converges in about 6–8).
MAX_SWEEPS = 40


def solve(a, b):
    """``x`` (d,) with ``a x = b`` for ``a`` (d, d) and ``b`` (d,). A singular ``a`` gives
    ``inf``/``nan``, as ``jnp.linalg.solve`` does."""
    d = a.shape[-1]
    rows = jnp.arange(d)

    def eliminate(k, m):
        p = jnp.argmax(jnp.where(rows >= k, jnp.abs(m[:, k]), -1.0))
        row_k, row_p = m[k], m[p]
        m = m.at[p].set(row_k).at[k].set(row_p)
        below = (rows > k)[:, None]
        return jnp.where(below, m - (m[:, k] / m[k, k])[:, None] * m[k][None, :], m)

    def substitute(i, x):
        k = d - 1 - i
        return x.at[k].set((m[k, d] - m[k, :d] @ x) / m[k, k])

    m = jax.lax.fori_loop(0, d, eliminate, jnp.concatenate([a, b[:, None]], axis=1))
    return jax.lax.fori_loop(0, d, substitute, jnp.zeros_like(b))


def svd_tall(a):
    """``(s, vt)`` of ``a`` (n, d), n ≥ d: singular values ``s`` (d,) in descending order and
    right singular vectors ``vt`` (d, d) (rows), as ``jnp.linalg.svd(a, full_matrices=False)[1:]``
    up to the signs of the rows (and their choice within a repeated singular value). Columns are
    rotated pairwise (cyclic order) until every pair is orthogonal to ``sqrt(n)·eps`` of their
    norms."""
    n, d = a.shape
    tol = jnp.sqrt(jnp.asarray(n, a.dtype)) * jnp.finfo(a.dtype).eps
    pairs = jnp.asarray(
        np.array([(p, q) for p in range(d - 1) for q in range(p + 1, d)], np.int32).reshape(-1, 2)
    )

    def rotate(i, state):
        cols, vs, turned = state
        p, q = pairs[i, 0], pairs[i, 1]
        a_p, a_q = cols[p], cols[q]
        alpha, beta, gamma = a_p @ a_p, a_q @ a_q, a_p @ a_q
        turn = jnp.abs(gamma) > tol * jnp.sqrt(alpha * beta)
        zeta = (beta - alpha) / (2.0 * jnp.where(turn, gamma, 1.0))
        t = jnp.where(zeta >= 0, 1.0, -1.0) / (jnp.abs(zeta) + jnp.hypot(1.0, zeta))
        c = jnp.where(turn, 1.0 / jnp.sqrt(1.0 + t * t), 1.0)
        s = jnp.where(turn, c * t, 0.0)
        cols = cols.at[p].set(c * a_p - s * a_q).at[q].set(s * a_p + c * a_q)
        vs = vs.at[p].set(c * vs[p] - s * vs[q]).at[q].set(s * vs[p] + c * vs[q])
        return cols, vs, turned | turn

    def sweep(state):
        cols, vs, _, count = state
        cols, vs, turned = jax.lax.fori_loop(0, len(pairs), rotate, (cols, vs, jnp.asarray(False)))
        return cols, vs, turned, count + 1

    def more(state):
        return state[2] & (state[3] < MAX_SWEEPS)

    cols, vs = a.T, jnp.eye(d, dtype=a.dtype)
    if d > 1:
        cols, vs, _, _ = jax.lax.while_loop(more, sweep, (cols, vs, jnp.asarray(True), 0))
    s = jnp.sqrt(jnp.sum(cols * cols, axis=1))
    order = jnp.argsort(-s, stable=True)
    return s[order], vs[order]
