"""Joint LM fits of the extended models, vmapped over candidates × cross-validation folds.

Held-out error is measured by blocked cross-validation in time: the recording is cut into
``N_FOLDS`` contiguous blocks; fold k fits on the other blocks (zero weight on block k) and predicts
block k. Contiguous blocks keep autocorrelated neighbours out of the training set, so the held-out
error is honest for slowly varying effects. Every fit uses :func:`jadhesion.identify.lm.lm_solve`
(optimistix Levenberg–Marquardt, sine-map box).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..identify.lm import lm_solve
from . import extensions as ext
from .signals import Signals

N_FOLDS = 5
#: LM budgets (full-data fit; folds warm-start from it) and tolerances: the decisions compare
#: errors at the 1 % level, so 1e-5 relative is ample.
MAX_STEPS, MAX_STEPS_FOLD = 30, 10
RTOL, ATOL = 1e-5, 1e-8
#: Base-fit starts: the paper's three identified parameter sets and two generic points.
BASE_STARTS = np.array([[0.4288, 1.0, 0.3555, 0.3575, 0.1316], [1.0, 1.0, 0.2610, 0.6858, 0.2251],
                         [1.0, 0.4089, 0.4205, 0.0, 0.1554], [0.5, 0.5, 0.3, 0.5, 0.3],
                         [0.1, 0.05, 0.5, 0.2, 0.6]])
#: The superset vector gets one unused slot, so candidates with fewer free parameters than the
#: round's width pad their index list with it (one compiled program per width).
PAD = ext.N_PARAMS
_LO = np.concatenate([ext.BOUNDS[0], [-1.0]])
_HI = np.concatenate([ext.BOUNDS[1], [1.0]])


class FitTable(NamedTuple):
    """Fits of C candidates: ``params`` (C, P) on all data, ``mae``/``sse`` (C,) in-sample,
    ``heldout_mae`` (C,) blocked-CV, ``residual`` (C, n) of the full-data fit."""

    params: jax.Array
    mae: jax.Array
    sse: jax.Array
    heldout_mae: jax.Array
    residual: jax.Array


def fold_weights(n: int, n_folds: int = N_FOLDS) -> jax.Array:
    """(n_folds + 1, n) weights: row 0 all ones; row k + 1 zero on contiguous block k."""
    block = jnp.minimum(jnp.arange(n) * n_folds // n, n_folds - 1)
    rows = [jnp.ones(n)] + [(block != k).astype(float) for k in range(n_folds)]
    return jnp.stack(rows)


def free_indices(names, width: int):
    """Indices of the Polach five and the extras of ``names`` in the padded superset vector."""
    idx = list(range(5)) + [5 + ext.EXTRA_NAMES.index(p) for e in ext.EFFECTS if e.name in names
                            for p in e.params]
    if len(idx) > width:
        raise ValueError(f"{names} need {len(idx)} free parameters, more than {width}")
    return idx + [PAD] * (width - len(idx))


def _free_residual(z, args):
    full, idx, active, weights, sig = args
    return ext.residual(full.at[idx].set(z)[:PAD], (active, weights, sig))


def _solve(full, idx, active, weights, sig, max_steps):
    """LM over the free entries ``idx`` of ``full`` (P + 1,), started 0.1 % inside the box (the
    sine map is flat on the bounds); returns the updated ``full``."""
    lo, hi = jnp.asarray(_LO)[idx], jnp.asarray(_HI)[idx]
    margin = 1e-3 * (hi - lo)
    z0 = jnp.clip(full[idx], lo + margin, hi - margin)
    z = lm_solve(_free_residual, z0, (full, idx, active, weights, sig), (lo, hi), rtol=RTOL,
                 atol=ATOL, max_steps=max_steps).params
    return full.at[idx].set(z)


def _pad(p):
    return jnp.concatenate([p, jnp.zeros(p.shape[:-1] + (1,))], axis=-1)


@jax.jit
def fit_base(sig: Signals) -> jax.Array:
    """Best LM fit of the plain Polach model from :data:`BASE_STARTS`; the full vector (P,)."""
    inactive = jnp.zeros(ext.N_EXTRA, bool)
    weights = jnp.ones_like(sig.time)
    idx = jnp.arange(5)
    starts = jnp.concatenate([BASE_STARTS, jnp.broadcast_to(ext.NEUTRAL, (BASE_STARTS.shape[0],
                                                                           ext.N_EXTRA))], axis=1)
    params = jax.vmap(lambda p: _solve(_pad(p), idx, inactive, weights, sig, MAX_STEPS))(starts)
    params = params[:, :PAD]
    sse = jax.vmap(lambda p: jnp.sum(ext.residual(p, (inactive, weights, sig)) ** 2))(params)
    return params[jnp.argmin(jnp.where(jnp.isfinite(sse), sse, jnp.inf))]


@jax.jit
def fit_candidates(p0, idx, actives, sig: Signals) -> FitTable:
    """Fit every candidate — free indices ``idx`` (C, K), effect masks ``actives`` (C, N_EXTRA),
    starts ``p0`` (C, P) — on the full recording, then on each CV fold warm-started from that fit;
    evaluate in-sample and held-out errors."""
    n = sig.time.shape[0]
    weights = fold_weights(n)
    full = jax.vmap(lambda p, i, a: _solve(_pad(p), i, a, weights[0], sig, MAX_STEPS))(
        p0, idx, actives)
    folds = jax.vmap(lambda p, i, a: jax.vmap(
        lambda w: _solve(p, i, a, w, sig, MAX_STEPS_FOLD))(weights[1:]))(full, idx, actives)

    def resid(p, a):
        target, pred = ext.predict(p[:PAD], a, sig)
        return target - pred

    r_full = jax.vmap(resid)(full, actives)  # (C, n)
    r_folds = jax.vmap(lambda ps, a: jax.vmap(lambda p: resid(p, a))(ps))(folds, actives)
    heldout = jnp.sum(jnp.abs(r_folds) * (1.0 - weights[None, 1:]), axis=(1, 2)) / n
    return FitTable(full[:, :PAD], jnp.mean(jnp.abs(r_full), axis=1), jnp.sum(r_full**2, axis=1),
                    heldout, r_full)
